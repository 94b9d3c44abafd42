"""The clamp friction (``clamp_friction``): an Iwan joint at the root with Masing's hysteresis,
against an independent integration of the same modal equations, against the closed-form
(describing-function) softening and decay of one mode, its linear limit, and the record feature
that offers it."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.signal import hilbert

from beam.errors import BeamInputError
from beam.physics.effects import effect_needs
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.residuals.envelope import RISING_DRIFT, decay_frequency_drift

#: An aluminium strip 500 x 50 x 2 mm (E = 70 GPa): EI = 2.333 N m², rho = 0.27 kg/m.
STRIP = BeamGeometry(0.5, 0.27, None, None, 0.44, width_m=0.05)
EI = 2.333


def _relative_l2(value, reference):
    return np.linalg.norm(value - reference) / np.linalg.norm(reference)


def _backbone(x, k, moment_s):
    """The joint's loading curve, written out again (not imported): k x (1 - |x| / 2 x_s), M_s sign x beyond."""
    theta_s = 2.0 * moment_s / k
    return np.where(np.abs(x) >= theta_s, np.sign(x) * moment_s, k * x * (1.0 - np.abs(x) / (2.0 * theta_s)))


def _tip_state(model, parameters, tips_m):
    _, shapes = model.mode_shapes(parameters, len(tips_m))
    return np.asarray(tips_m) / (model.parts.tip_values @ shapes)


def test_a_joint_that_never_slips_is_the_compliant_clamp():
    """M_s -> infinity: the linear compliant clamp of stiffness k_f; the remaining softening falls as 1 / M_s."""
    values = {"bending_stiffness_Nm2": EI, "damping_ratio_mode_1": 0.002, "damping_ratio_mode_2": 0.003}
    linear = BeamModel(STRIP, ["modal_damping", "clamp_compliance"], input_kind=None)
    friction = BeamModel(STRIP, ["modal_damping", "clamp_friction"], input_kind=None)
    time = np.arange(0.0, 3.0, 1e-3)
    lin_values = dict(values, clamp_stiffness_Nm_rad=300.0)
    eta = _tip_state(linear, lin_values, [0.02, 0.001])
    expected = linear.free_response(lin_values, time, eta, modes=2, output="acceleration")
    gaps = []
    for moment in (1e2, 1e3):
        got = friction.free_response(dict(values, clamp_friction_stiffness_Nm_rad=300.0, clamp_slip_moment_Nm=moment),
                                     time, eta, modes=2, output="acceleration")
        gaps.append(_relative_l2(got, expected))
    assert gaps[1] < 1e-3
    assert 5.0 < gaps[0] / gaps[1] < 20.0  # the softening's share goes as A / theta_s = A k_f / 2 M_s


def _modal_reference(model, values, eta, time, modes):
    """The same retained modes integrated by DOP853 (rtol 1e-11) in real first-order form, the
    joint's Masing branch switched at each reversal of the root's rotation found as an event."""
    omega2, shapes = model.mode_shapes(values, modes)
    omega = np.sqrt(omega2)
    zeta = np.array([values[f"damping_ratio_mode_{j + 1}"] for j in range(modes)])
    root = model.parts.basis.evaluate(np.zeros(1), 1)[0] @ shapes
    sensor = model.parts.sensor_values @ shapes
    k, moment_s = values["clamp_friction_stiffness_Nm_rad"], values["clamp_slip_moment_Nm"]

    def restoring(theta, branch):
        theta_r, r_r = branch
        return r_r + 2.0 * _backbone(0.5 * (theta - theta_r), k, moment_s)

    def acceleration(state, branch):
        q, v = state[:modes], state[modes:]
        theta = root @ q
        moment = k * theta - restoring(theta, branch)
        return -2 * zeta * omega * v - omega2 * q + root * moment

    # released from rest: the first branch starts at the release (the settled cycle's reversal)
    theta0 = root @ eta
    branch = (theta0, float(_backbone(theta0, k, moment_s)))
    state = np.concatenate([eta, np.zeros(modes)])
    t0, out_t, out_a = time[0], [], []
    while True:
        def reversal(t, y, branch=branch):
            return root @ y[modes:]

        reversal.terminal, reversal.direction = True, 0
        sol = solve_ivp(lambda t, y: np.concatenate([y[modes:], acceleration(y, branch)]), (t0, time[-1]), state,
                        method="DOP853", rtol=1e-11, atol=1e-14, events=reversal, dense_output=True,
                        first_step=1e-6 if t0 > time[0] else None)
        inside = (time >= t0) & (time <= sol.t[-1])
        if out_t:
            inside &= time > out_t[-1][-1]
        ys = sol.sol(time[inside])
        out_t.append(time[inside])
        out_a.append(np.array([sensor @ acceleration(y, branch) for y in ys.T]))
        if sol.status != 1:
            break
        t0, state = sol.t[-1], sol.y[:, -1]
        theta = root @ state[:modes]
        branch = (theta, float(restoring(theta, branch)))
        # step off the event so it does not fire again at once
        nudge = solve_ivp(lambda t, y: np.concatenate([y[modes:], acceleration(y, branch)]), (t0, t0 + 1e-7), state,
                          method="DOP853", rtol=1e-12, atol=1e-15)
        t0, state = nudge.t[-1], nudge.y[:, -1]
    return np.concatenate(out_t), np.concatenate(out_a)


def test_the_friction_matches_an_independent_integration_with_its_reversals_as_events():
    """Two retained modes released from 2 cm at the tip, the joint slipping over most of the
    swing (theta reaches 0.6 theta_s): the ETDRK4 response against DOP853 with the Masing
    branch switched at each reversal found as an event (relative L2 <= 1e-4; 1e-6 measured), while the
    compliant clamp without the friction is much further away."""
    values = {"bending_stiffness_Nm2": EI, "damping_ratio_mode_1": 0.002, "damping_ratio_mode_2": 0.003,
              "clamp_friction_stiffness_Nm_rad": 300.0, "clamp_slip_moment_Nm": 2.0}
    model = BeamModel(STRIP, ["modal_damping", "clamp_friction"], input_kind=None)
    eta = _tip_state(model, values, [0.02, 0.0])
    time = np.arange(0.0, 2.0, 1e-3)
    got = model.free_response(values, time, eta, modes=2, output="acceleration")
    ref_t, ref = _modal_reference(model, values, eta, time, 2)
    assert np.array_equal(ref_t, time)
    linear = BeamModel(STRIP, ["modal_damping", "clamp_compliance"], input_kind=None)
    stuck = linear.free_response({k: v for k, v in values.items() if not k.startswith("clamp_")}
                                 | {"clamp_stiffness_Nm_rad": 300.0}, time, eta, modes=2, output="acceleration")
    error = _relative_l2(got, ref)
    assert error <= 1e-4
    assert _relative_l2(stuck, ref) > 20 * error


def test_one_mode_softens_and_decays_as_the_describing_function_says():
    """One retained mode without viscous damping, in microslip: with alpha = k_f² / 4 M_s, r the
    root rotation per unit modal coordinate and A the modal amplitude, the Masing loop's mean
    curve (half the sum of its two branches) is k_f theta - alpha A theta: the joint lowers omega
    by alpha |r|³ A / 2 omega² (relative), and its loop's area (4 / 3) alpha (|r| A)³ takes
    dA/dt = -(2 / 3 pi) alpha |r|³ A² / omega, i.e. A(t) = A0 / (1 + (2 / 3 pi) alpha |r|³ A0 t / omega)."""
    values = {"bending_stiffness_Nm2": EI, "damping_ratio_mode_1": 0.0,
              "clamp_friction_stiffness_Nm_rad": 300.0, "clamp_slip_moment_Nm": 2.0}
    model = BeamModel(STRIP, ["modal_damping", "clamp_friction"], input_kind=None)
    omega2, shapes = model.mode_shapes(values, 1)
    omega = float(np.sqrt(omega2[0]))
    r = abs(float(model.parts.basis.evaluate(np.zeros(1), 1)[0] @ shapes[:, 0]))
    alpha = values["clamp_friction_stiffness_Nm_rad"] ** 2 / (4 * values["clamp_slip_moment_Nm"])
    a0 = 0.01 / float(model.parts.tip_values @ shapes[:, 0])
    assert r * a0 < 0.5 * 2 * values["clamp_slip_moment_Nm"] / values["clamp_friction_stiffness_Nm_rad"]  # microslip
    time = np.arange(0.0, 20.0, 1e-3)
    model._sensor_row = model.parts.tip_values  # read the tip displacement (a modal coordinate times a constant)
    tip = model.free_response(values, time, np.array([a0]), modes=1, output="displacement")
    modal = tip / float(model.parts.tip_values @ shapes[:, 0])
    rate = 2 / (3 * np.pi) * alpha * r**3 / omega
    expected = a0 / (1 + rate * a0 * time)
    envelope = np.abs(hilbert(modal))
    middle = (time > 1.0) & (time < 19.0)
    assert np.max(np.abs(envelope[middle] - expected[middle]) / expected[middle]) < 0.01
    assert expected[-1] < 0.8 * a0  # the joint took a fifth of the swing or more
    # the frequency at the start and at the end against omega (1 - alpha r³ A / 2 omega²)
    phase = np.unwrap(np.angle(hilbert(modal)))
    for lo, hi in ((1.0, 3.0), (17.0, 19.0)):
        part = (time > lo) & (time < hi)
        measured = np.polyfit(time[part], phase[part], 1)[0]
        amplitude = float(np.mean(expected[part]))
        predicted = omega * (1 - alpha * r**3 * amplitude / (2 * omega2[0]))
        assert abs(measured / omega - 1 - (predicted / omega - 1)) < 0.03 * abs(predicted / omega - 1)


def test_a_softening_decay_is_offered_the_friction_and_a_drag_decay_is_not():
    noise = np.random.default_rng(4)
    time = np.arange(0.0, 20.0, 1e-3)
    base = {"bending_stiffness_Nm2": EI, "damping_ratio_mode_1": 0.0015, "damping_ratio_mode_2": 0.004}
    cases = {"clamp_friction": {"clamp_friction_stiffness_Nm_rad": 2400.0, "clamp_slip_moment_Nm": 0.09},
             "quadratic_drag": {"drag_coefficient": 15.0}, "clamp_compliance": {"clamp_stiffness_Nm_rad": 2400.0}}
    drifts = {}
    for effect, extra in cases.items():
        model = BeamModel(STRIP, ["modal_damping", effect], input_kind=None)
        values = base | extra
        eta = _tip_state(model, values, [0.006, 0.0])
        record = model.free_response(values, time, eta, modes=2, output="acceleration")
        drifts[effect] = decay_frequency_drift(time, record + 0.05 * noise.standard_normal(time.size))
    assert drifts["clamp_friction"] < -RISING_DRIFT
    assert abs(drifts["quadratic_drag"]) < RISING_DRIFT and abs(drifts["clamp_compliance"]) < RISING_DRIFT
    assert effect_needs("clamp_friction") == {"free", "rising_frequency"}


def test_the_state_space_references_refuse_the_friction():
    model = BeamModel(STRIP, ["clamp_friction"], input_kind=None)
    with pytest.raises(BeamInputError, match="clamp_friction"):
        model.free_response_basis({"bending_stiffness_Nm2": EI, "clamp_friction_stiffness_Nm_rad": 300.0,
                                   "clamp_slip_moment_Nm": 1.0}, np.arange(0, 1, 1e-3), modes=2)


@pytest.mark.slow
def test_a_simulated_slipping_clamp_is_recovered_and_predicted_to_the_noise():
    """A 12 s accelerometer decay of the strip (1 kHz, white noise 0.05 m/s²) whose clamp slips
    (k_f = 2400 N m/rad, M_s = 0.09 N m: its root rotation starts at the slip rotation), calibrated
    on 0-4 s: k_f, M_s, EI and the mode-1 damping inside their 95 % intervals, the held-out
    4-12 s predicted to the noise, where the model without the friction misses by twice that;
    the larger model's MAP log posterior above the smaller one's (nested)."""
    from beam.calibration import calibration_preview
    from beam.calibration.engine import Engine
    from beam.io.measurement import Measurement

    truth = {"bending_stiffness_Nm2": 2.2, "damping_ratio_mode_1": 0.0015, "damping_ratio_mode_2": 0.004,
             "clamp_friction_stiffness_Nm_rad": 2400.0, "clamp_slip_moment_Nm": 0.09}
    model = BeamModel(STRIP, ("modal_damping", "clamp_friction"), input_kind=None)
    time = np.arange(0.0, 12.0, 1e-3)
    eta = _tip_state(model, truth, [0.006, 0.0003])
    clean = model.free_response(truth, time, eta, modes=2, output="acceleration")
    noisy = clean + 0.05 * np.random.default_rng(3).standard_normal(time.size)
    record = Measurement("simulated_friction", "simulated", STRIP, time, acceleration_m_s2=noisy,
                         nominal={"bending_stiffness_Nm2": 2.333})
    engine = Engine()
    base = calibration_preview(record, window=(0.0, 4.0), effects="modal_damping", modes=2, engine=engine)
    result = calibration_preview(record, window=(0.0, 4.0), effects="modal_damping,clamp_friction", modes=2,
                                 engine=engine)
    summary = result.summary()
    for name in ("clamp_friction_stiffness_Nm_rad", "clamp_slip_moment_Nm", "bending_stiffness_Nm2",
                 "damping_ratio_mode_1"):
        assert summary[name]["q025"] <= truth[name] <= summary[name]["q975"], (name, summary[name])
    assert result.rmse_prediction == pytest.approx(0.05, rel=0.1)
    assert base.rmse_prediction > 2 * result.rmse_prediction
    assert result.laplace.map.log_posterior > base.laplace.map.log_posterior


def test_a_driven_record_is_refused_the_friction_at_once():
    from beam.calibration import make_setup
    from beam.io.bundled import bundled_path
    from beam.io.measurement import read_measurement

    with pytest.raises(BeamInputError, match="clamp_friction is calibrated on free decays only"):
        make_setup(read_measurement(bundled_path("lab_run_1")), window=(0.0, 0.5),
                   effects="air_damping,clamp_friction", modes=2)
