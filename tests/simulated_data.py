"""Measurements simulated in memory with known truth, for the calibration and diagnosis tests."""

from __future__ import annotations

import numpy as np

from beam.io.config import Sampling, SimulationConfig
from beam.io.measurement import Measurement
from beam.io.simulation import simulate
from beam.physics.excitation import Excitation
from beam.physics.geometry import BeamGeometry

#: Smith's B1TAPIH beam geometry (sensor at 3L/5).
GEOMETRY = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
#: Published base + damping values of B1TAPIH.
TRUE_BASE = {
    "bending_stiffness_Nm2": 0.491,
    "patch_coupling_NmV": 1.746e-2,
    "air_damping_Ns_m2": 0.013,
    "kelvin_voigt_Nm2s": 0.649e-5,
}
#: A chirp that excites the first three modes of the uniform beam (6.2, 38.5, 108 Hz).
THREE_MODE_CHIRP = Excitation("chirp", amplitude_V=10.0, start_Hz=2.0, stop_Hz=130.0, duration_s=1.0)


def simulated_measurement(
    parameters: dict[str, float],
    *,
    geometry: BeamGeometry = GEOMETRY,
    excitation: Excitation = THREE_MODE_CHIRP,
    rate_Hz: float = 1000.0,
    duration_s: float = 3.0,
    noise_m: float = 1e-5,
    seed: int = 0,
    modes: int | None = 4,
    nominal: dict[str, float] | None = None,
    name: str = "simulated",
) -> Measurement:
    """A noisy record of the beam with ``parameters`` (its effects switched on by their names).

    ``modes`` retained modes (default 4, the calibration default, so that modal truncation is
    not itself a discrepancy); ``nominal`` defaults to the true base values.
    """
    config = SimulationConfig(
        title=name, geometry=geometry, parameters=dict(parameters), excitation=excitation,
        sampling=Sampling(rate_Hz, duration_s, noise_m, seed),
        nominal=dict(TRUE_BASE if nominal is None else nominal),
    )
    return simulate(config, modes=modes).measurement(name)


#: The effects a diagnosis from the default base model (air + Kelvin-Voigt damping) can find.
HIDDEN_EFFECTS = ("tip_mass", "clamp_compliance", "patch_stiffening", "tip_cubic_spring")


def random_beam_case(rng, hidden: str | None) -> tuple[Measurement, dict[str, float], float]:
    """A random plausible beam record with one hidden effect (or none).

    Geometry, properties, sensor, excitation (chirp, burst at mode 2, or pulse), noise (0.3-2 %
    of the RMS) and the effect's magnitude are drawn from ``rng``; the sidecar's nominal values
    are the true base values with EI off by up to 10 %. Returns (measurement, true parameters,
    noise sd in m). The record is simulated with every mode of the Galerkin model.
    """
    from beam.physics.model import BeamModel

    length = rng.uniform(0.25, 0.6)
    density = rng.uniform(0.08, 0.2)
    patch_start = rng.uniform(0.03, 0.2) * length
    patch_end = patch_start + rng.uniform(0.1, 0.25) * length
    geometry = BeamGeometry(length, density, patch_start, patch_end, rng.uniform(0.4, 0.95) * length)
    base = {
        "bending_stiffness_Nm2": rng.uniform(0.2, 1.5),
        "patch_coupling_NmV": rng.uniform(0.005, 0.03),
        "air_damping_Ns_m2": rng.uniform(0.005, 0.03),
        "kelvin_voigt_Nm2s": rng.uniform(2e-6, 2e-5),
    }
    frequencies, _ = BeamModel(geometry, ["air_damping", "kelvin_voigt"]).natural_modes(base, 4)
    f1, f2, f3 = frequencies[:3]
    rate = max(500.0, float(np.ceil(4 * frequencies[3] / 100) * 100))
    duration = float(np.clip(20 / f1, 2.0, 4.0))
    kind = "pulse" if hidden == "tip_cubic_spring" else rng.choice(["chirp", "burst", "pulse"])
    if kind == "chirp":
        excitation = Excitation("chirp", amplitude_V=10.0, start_Hz=0.5 * f1, stop_Hz=float(0.8 * f3 + 0.2 * frequencies[3]),
                                duration_s=0.4 * duration)
    elif kind == "burst":
        excitation = Excitation("burst", amplitude_V=10.0, frequency_Hz=float(f2), cycles=12)
    else:
        excitation = Excitation("pulse", amplitude_V=20.0, width_s=float(1.0 / (2.5 * f3)))
    parameters = dict(base)
    stiffness, mass = base["bending_stiffness_Nm2"], density * length
    if hidden == "tip_mass":
        parameters["tip_mass_kg"] = rng.uniform(0.05, 0.25) * mass
    elif hidden == "clamp_compliance":
        parameters["clamp_stiffness_Nm_rad"] = rng.uniform(3.0, 30.0) * stiffness / length
    elif hidden == "patch_stiffening":
        parameters["patch_added_density_kg_m"] = rng.uniform(1.0, 4.0) * density
        parameters["patch_added_stiffness_Nm2"] = rng.uniform(0.5, 2.0) * stiffness
    elif hidden == "tip_cubic_spring":
        # a large pulse, then a spring whose tangent stiffness at the linear tip amplitude is
        # 10-40 % of the beam's static tip stiffness 3 EI / L³
        excitation = Excitation("pulse", amplitude_V=40.0, width_s=float(1.0 / (2.0 * f1)))
        model = BeamModel(geometry, ["air_damping", "kelvin_voigt"])
        t = np.arange(int(rate * duration)) / rate
        reduced, _, _ = model.reduced_system(base, modes=4)
        tip_over_sensor = abs(reduced["tip"][0, 0] / reduced["sensor"][0, 0])
        amplitude = np.abs(model.response(base, excitation.voltage(t), 1 / rate)).max() * tip_over_sensor
        parameters["tip_cubic_stiffness_N_m3"] = rng.uniform(0.1, 0.4) * 3 * stiffness / length**3 / amplitude**2
    probe = simulate(SimulationConfig("probe", geometry, parameters, excitation, Sampling(rate, duration, 0.0, 0)), modes=None)
    noise = float(rng.uniform(0.003, 0.02) * np.sqrt(np.mean(probe.clean_displacement_m**2)))
    nominal = dict(base, bending_stiffness_Nm2=base["bending_stiffness_Nm2"] * rng.uniform(0.9, 1.1))
    config = SimulationConfig(f"random {hidden}", geometry, parameters, excitation,
                              Sampling(rate, duration, noise, int(rng.integers(1 << 30))), nominal=nominal)
    return simulate(config, modes=None).measurement("random"), parameters, noise
