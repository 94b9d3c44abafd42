"""Measurements simulated in memory with known truth, for the calibration and diagnosis tests."""

from __future__ import annotations

from beam.config import Sampling, SimulationConfig
from beam.excitation import Excitation
from beam.geometry import BeamGeometry
from beam.measurement import Measurement
from beam.simulation import simulate

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
