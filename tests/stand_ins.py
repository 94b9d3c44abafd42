"""Records made to stand in for other labs' (#38): a phone taped to a 30 cm strip, steel bars with a
strain gauge near the root and a slipping clamp, one strip clamped at four lengths.

Each is simulated by the project's own model (:class:`beam.physics.model.BeamModel`, every mode
of its mesh that matters, the nonlinear effects by its integrator) with known truth and a fixed
seed, and carries only what a lab would know (geometry, the stated sensor mass, the nominal EI).
Short by default (a few seconds, two modes): the diagnoses are CPU-heavy on a shared machine.
"""

from __future__ import annotations

import numpy as np

from beam.io.measurement import Measurement
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

#: Aluminium strip 50 x 2 mm (the shared runs' strip): linear density (kg/m), nominal EI (N m²).
STRIP_DENSITY = 0.27
STRIP_EI = 2.333
#: A phone taped near the tip (kg): stated as approximate, as a user who read it off a spec sheet.
PHONE_MASS = 0.17


def _tip_state(model: BeamModel, values: dict, tip_m: float, modes: int) -> np.ndarray:
    """The modal displacements eta (m sqrt(kg)) of a release from a static tip deflection ``tip_m``
    in mode 1 only (the released shape's other modes are small on a plucked strip)."""
    _, shapes = model.mode_shapes(values, modes)
    tip = model.parts.tip_values @ shapes
    eta = np.zeros(modes)
    eta[0] = tip_m / tip[0]
    return eta


def phone_strip(*, length_m: float = 0.3, duration_s: float = 6.0, rate_Hz: float = 400.0, seed: int = 0,
                noise: float = 0.02, truth: dict | None = None, effects: tuple[str, ...] | None = None,
                tip_m: float = 0.02) -> Measurement:
    """A phone's accelerometer record (m/s², jittered stamps around ``rate_Hz``, offset 0.3 m/s²) of
    an aluminium strip 50 x 2 mm clamped at ``length_m``, the phone 3 cm from the tip; released from
    ``tip_m``. Truth (default): the phone's mass, a clamp that slips (Iwan joint) and 0.2 % modal
    damping: the damping and the frequency change with the swing, as a real clamp's do."""
    geometry = BeamGeometry(length_m=length_m, linear_density_kg_m=STRIP_DENSITY, patch_start_m=None,
                            patch_end_m=None, sensor_position_m=length_m - 0.03, width_m=0.05, thickness_m=0.002)
    if truth is None:
        truth = {"bending_stiffness_Nm2": 2.2, "sensor_mass_kg": PHONE_MASS, "damping_ratio_mode_1": 0.002,
                 "damping_ratio_mode_2": 0.003, "clamp_friction_stiffness_Nm_rad": 3000.0,
                 "clamp_slip_moment_Nm": 0.25}
        effects = ("sensor_mass", "clamp_friction", "modal_damping")
    model = BeamModel(geometry, effects, input_kind=None)
    rng = np.random.default_rng(seed)
    steps = (1.0 + 0.25 * rng.uniform(-1.0, 1.0, int(rate_Hz * duration_s))) / rate_Hz  # a phone's jittered clock
    t = np.concatenate([[0.0], np.cumsum(steps)])
    t = t[t <= duration_s]
    clean = model.free_response(truth, t, _tip_state(model, truth, tip_m, 2), modes=2, output="acceleration")
    y = clean + 0.3 + noise * rng.standard_normal(t.size)
    return Measurement(f"phone_strip_{round(100 * length_m)}cm", "simulated phone on a strip", geometry, t,
                       acceleration_m_s2=y, nominal={"bending_stiffness_Nm2": STRIP_EI, "sensor_mass_kg": PHONE_MASS},
                       nominal_spread={"sensor_mass_kg": 0.35})


#: Steel: Young's modulus (Pa) and density (kg/m³).
STEEL_E, STEEL_RHO = 200e9, 7850.0


def steel_bar(thickness_m: float, *, length_m: float = 0.419, width_m: float = 0.025, gauge_at_m: float = 0.02,
              duration_s: float = 4.0, rate_Hz: float = 1000.0, seed: int = 0, noise_strain: float = 2e-7,
              slip_share: float = 1.0, tip_m: float | None = None) -> Measurement:
    """A strain gauge's record (strain, 1 = 1e6 µε) at ``gauge_at_m`` from the clamp of a steel bar
    ``width_m`` x ``thickness_m`` clamped at ``length_m``, released from ``tip_m`` (default: 1.5 % of
    the length), 0.05 % material damping; the clamp slips (Iwan joint: stick stiffness 30 EI / L,
    the slip moment chosen so that the root moment at release is ``1 / slip_share`` slip moments).
    A clamp's damping that grows with the amplitude, on a bar where air drag is negligible."""
    area, inertia = width_m * thickness_m, width_m * thickness_m**3 / 12.0
    ei, rho = STEEL_E * inertia, STEEL_RHO * area
    geometry = BeamGeometry(length_m=length_m, linear_density_kg_m=rho, patch_start_m=None, patch_end_m=None,
                            sensor_position_m=gauge_at_m, width_m=width_m, thickness_m=thickness_m)
    tip = 0.015 * length_m if tip_m is None else tip_m
    root_moment = 3.0 * ei * tip / length_m**2  # the static cantilever's root moment at release
    truth = {"bending_stiffness_Nm2": ei, "damping_ratio_mode_1": 5e-4, "damping_ratio_mode_2": 5e-4,
             "clamp_friction_stiffness_Nm_rad": 30.0 * ei / length_m,
             "clamp_slip_moment_Nm": root_moment / max(slip_share, 1e-9)}
    model = BeamModel(geometry, ("clamp_friction", "modal_damping"), input_kind=None)
    rng = np.random.default_rng(seed)
    t = np.arange(int(rate_Hz * duration_s)) / rate_Hz
    clean = model.free_response(truth, t, _tip_state(model, truth, tip, 2), modes=2, output="strain")
    y = clean + noise_strain * rng.standard_normal(t.size)
    name = f"steel_{1000 * thickness_m:.1f}mm".replace(".", "_")
    return Measurement(name, "simulated steel bar, strain gauge near the root", geometry, t, strain=y,
                       nominal={"bending_stiffness_Nm2": ei})


#: The four lengths of the joint case (m) and the joint strip's truth: a 4 g sensor 6 cm from the tip
#: and a compliant clamp (233 N m/rad: about 10 mm of extra length on this strip).
JOINT_LENGTHS = (0.3, 0.4, 0.5, 0.6)
JOINT_TRUTH = {"bending_stiffness_Nm2": 2.2, "sensor_mass_kg": 0.004, "clamp_stiffness_Nm_rad": 233.0,
               "damping_ratio_mode_1": 0.004, "damping_ratio_mode_2": 0.005}
JOINT_EFFECTS = ("clamp_compliance", "sensor_mass", "modal_damping")


def joint_strip(length_m: float, *, seed: int, duration_s: float = 3.0, rate_Hz: float = 400.0, noise: float = 0.05,
                second: float = 0.15, truth: dict | None = None) -> Measurement:
    """An accelerometer's free decay (m/s², offset 0.43 m/s², noise ``noise``) of the 50 x 2 mm strip
    clamped at ``length_m`` with the sensor 6 cm from the tip: :data:`JOINT_TRUTH` (sensor mass and a
    compliant clamp), modes 1 and 2 in the record (``second``: mode 2's share of the release)."""
    truth = JOINT_TRUTH if truth is None else truth
    geometry = BeamGeometry(length_m=length_m, linear_density_kg_m=STRIP_DENSITY, patch_start_m=None,
                            patch_end_m=None, sensor_position_m=length_m - 0.06)
    model = BeamModel(geometry, JOINT_EFFECTS, input_kind=None)
    t = np.arange(int(rate_Hz * duration_s)) / rate_Hz
    eta = _tip_state(model, truth, 0.01 * length_m / 0.5, 2)
    eta[1] = -second * eta[0] * 0.16  # mode 2's share of the pluck (its modal coordinate per tip metre is ~6x)
    clean = model.free_response(truth, t, eta, modes=2, output="acceleration")
    y = clean + 0.43 + noise * np.random.default_rng(seed).standard_normal(t.size)
    return Measurement(f"strip_{round(100 * length_m)}cm", "simulated strip", geometry, t, acceleration_m_s2=y,
                       nominal={"bending_stiffness_Nm2": STRIP_EI})
