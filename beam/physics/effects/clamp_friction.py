"""``clamp_friction``: frictional microslip where the clamp grips the strip.

The root is held by a rotational joint of stick stiffness k_f (``clamp_friction_stiffness_Nm_rad``)
whose contact slips progressively as the root moment grows, until the whole contact slips at the
moment M_s (``clamp_slip_moment_Nm``). The joint is Iwan's parallel array of Jenkins elements with
a uniform density of slip strengths (Iwan 1966, J. Appl. Mech. 33, 893–900; Segalman 2005,
J. Appl. Mech. 72, 752–760): its loading curve is M(theta) = k_f theta (1 - |theta| / (2
theta_s)) for |theta| <= theta_s = 2 M_s / k_f and M_s beyond, and it unloads and reloads along
Masing's branches M = M_r + 2 M((theta - theta_r) / 2) from the last reversal (theta_r, M_r)
(Masing 1926). In microslip (|theta| < theta_s) the cycle of amplitude A has the mean stiffness
k_f - (k_f / 2 theta_s) A (half the sum of its branches) and dissipates (4 / 3) (k_f / 2 theta_s)
A³: the frequency of every mode falls, and its damping ratio grows, linearly with the amplitude,
the damping ratio 4 / 3 pi (0.42) times the relative frequency drop
(``docs/physics-clamp-friction.md``). The linear part k_f theta replaces the rigid clamp (the
basis keeps the root rotation, as ``clamp_compliance``); the softening, the hysteresis and the
slip are its channel (:data:`~beam.physics.effects.channel.LAW_IWAN_JOINT` on the root's
rotation), integrated with the drag's ETDRK4 scheme (:func:`beam.physics.nonlinear.integrate_general`).
Both parameters vanish at the top of their ranges (a rigid joint that never slips), where the
model nests the model without it.

**Plausible values** (:data:`PLAUSIBLE_SOURCE`), in units of the strip's EI / L
(``plausible_scale = "EI/L"``): the stick stiffness as a compliant clamp's, from 3 EI / L to rigid
(:mod:`beam.physics.effects.clamp_compliance`); the slip moment from 1e-4 to 1 EI / L. A swing
whose tip moves by d has the root moment 3 EI d / L² of the static cantilever, 3 d / L in these
units: 3e-3 for a 0.5 mm swing of a 50 cm strip, 0.3 for a 5 cm one. A contact that slips at a
hundredth of the smallest of them holds nothing (the root is a hinge), one that slips only above
EI / L never slips in a lab's swing. The shared 50 cm runs: 0.07–0.09 N m, 0.015–0.02 EI / L.

**Averaged (slow-flow) form** (:class:`AveragedFriction`, the slot of
:mod:`beam.physics.effects.averaged`): the Iwan joint's describing function. With the root
rotating theta = X cos psi on the settled Masing loop of amplitude X (x = X / theta_s), the
nonlinear part g = k_f theta - R(theta) has the first-harmonic in-phase stiffness
k_f s(x) (the joint's loss of stiffness), the loop dissipates k_f theta_s² e(x) per cycle, and
the tangent stiffness dR / dtheta averaged over the cycle is k_f (1 - t(x)) (:func:`joint_describing`):

    microslip (x <= 1):  s = t = x / 2,  e = (2 / 3) x³          (closed forms, the physics page)
    slip (x > 1):        e = 2 x - 4 / 3, s and t closed forms of the branch's angle of slip
                         (:func:`joint_describing`; s, t -> 1, e -> 2 x as the whole contact slips).

The mode p whose root rotation |r_p| A_p is largest (r_k the root rotation per unit modal
coordinate, mode 1 of a released strip) sets X = |r_p| A_p; then, to first order,

    d omega_p = -r_p² k_f s(x) / 2 omega_p,   d ln A_p / dt = -c_p - k_f theta_s² e(x) / (2 pi omega_p A_p²),
    d omega_k = -r_k² k_f t(x) / 2 omega_k   (k != p: the small mode rides the loop's mean tangent,
                                             with no loss at first order in its amplitude).

In microslip the slow flow is the drag's: dA_p/dt = -c_p A_p - b A_p², b = (2 / 3 pi) alpha
|r_p|³ / omega_p, alpha = k_f / 2 theta_s = k_f² / 4 M_s, so A_p(tau) = a_p e^(-c_p tau) /
(1 + b a_p tau phi(c_p tau)), a closed form (the check of the envelope in the tests). The
envelope integrates the dominant mode's one-dimensional flow by quadrature in ln A
(:meth:`AveragedFriction.dominant_flow`), in microslip and beyond, and the phases along it
(a faster mode's share of the cycle stuck to the joint changes as the amplitudes fall).
Limits: first order in the softening (the frequency's shift, not sqrt(omega² - r² k_f s)); the
dominant mode's joint only (two modes of comparable root rotation share one loop, which the
full integrator follows); no loss of the other modes from the dominant one's reversals
(their minor loops are of third order in their amplitude); the joint's first harmonic only.
Measured against the full integrator in ``docs/decisions.md`` (averaged forms).

Calibrated on free decays only (its joint's history is taken from the swing at the window's
start). Not a ranking candidate: the diagnosis's note on a held-out phase lag names it where the
record's own frequency rises as the swing dies (its calibration takes minutes, the ranking fits
every candidate).
"""

from __future__ import annotations

import math

import beam.physics.effects.base as base
from beam.errors import BeamInputError
from beam.physics.effects.channel import LAW_IWAN_JOINT, Channel
from beam.physics.effects.effect import Effect, ParameterSpec, Refusal, StartHints, Term

__all__ = ["AVERAGED_NOTE", "AveragedFriction", "EFFECT", "FRICTION_SLIP_RATIOS", "FRICTION_STIFFNESS_RATIOS", "PLAUSIBLE_SOURCE",
           "SLIP", "STICK", "friction_starts", "joint_describing"]

PLAUSIBLE_SOURCE = ("the stick stiffness: a compliant clamp's (beam.physics.effects.clamp_compliance); the slip "
                    "moment: the static cantilever's root moment 3 EI d / L² for a lab swing of tip amplitude d "
                    "(L/1000 to L/10: 3e-3 to 0.3 EI / L), a hundredth of the smallest to three times the largest")
STICK = ParameterSpec("clamp_friction_stiffness_Nm_rad", "N m/rad", "k_f", "stick stiffness of the clamp's frictional joint",
                      0.01, 1e6, absent_at="high", plausible=(3.0, math.inf), plausible_source=PLAUSIBLE_SOURCE,
                      plausible_scale="EI/L")
SLIP = ParameterSpec("clamp_slip_moment_Nm", "N m", "M_s", "root moment at which the whole clamp contact slips", 1e-4, 1e4,
                     absent_at="high", plausible=(1e-4, 1.0), plausible_source=PLAUSIBLE_SOURCE, plausible_scale="EI/L")

#: The friction's starts (:func:`friction_starts`): the joint's stick stiffness k_f in units of the
#: strip's EI / L (a clamp far stiffer than the strip's root, which still lowers f1 by 0.1-3 %) ...
FRICTION_STIFFNESS_RATIOS = (100.0, 300.0, 1000.0, 3000.0)
#: ... and the root rotation's amplitude at the window's start in units of the slip rotation
#: theta_s = 2 M_s / k_f (microslip to whole slip over a swing).
FRICTION_SLIP_RATIOS = (0.5, 1.0, 2.0)


def root_row(model):
    """The root's rotation row (1, n): w'(0) = row . q."""
    import numpy as np

    return model.parts.basis.evaluate(np.zeros(1), 1)


def coefficients(model, values):
    """(k_f, M_s) (B, 1, 2) (N m/rad, N m)."""
    import numpy as np

    return np.stack([np.asarray(values[STICK.name], dtype=float), np.asarray(values[SLIP.name], dtype=float)],
                    axis=1)[:, None, :]


#: The label of every result of the averaged model with the clamp friction.
AVERAGED_NOTE = ("averaged (slow-flow) approximation of the clamp friction: the Iwan joint's describing function "
                 "softens and damps the mode of the largest root rotation as its amplitude (cycle-averaged, first "
                 "order); a preview, not the full integration")
def joint_describing(x):
    """The uniform Iwan joint's describing function on its settled Masing loop of amplitude
    x = X / theta_s (array): (s, e, t) of the module notes, in units of k_f and k_f theta_s².

    Closed forms throughout. In microslip (x <= 1) s = t = x / 2, e = 2 x³ / 3. Beyond, on the
    rising branch theta = -x cos(alpha) (alpha in [0, pi], the falling branch its mirror) the
    joint's moment R is the Masing branch -1/2 + 2u - u², u = (theta + x) / 2 (k = theta_s = 1),
    up to alpha_c = arccos((x - 2) / x) where u = 1, and the slip moment 1/2 after it; the
    branch's first harmonics are trigonometric polynomials integrated exactly:

        e = 2 ∫ R dtheta = 2 x - 4 / 3,
        1 - t = ((1 - x / 2) alpha_c + (x / 2) sin alpha_c) / pi,
        s = 1 + (2 / pi x) (P - sin alpha_c / 2),
        P = (x - 1/2 - x² / 4) S1 + (x² / 2 - x) S2 - (x² / 4) S3,

    S1 = sin alpha_c, S2 = alpha_c / 2 + sin(2 alpha_c) / 4, S3 = sin alpha_c - sin³ alpha_c / 3;
    at x = 1 they meet the microslip forms, and as x grows s, t -> 1 (as x^-3/2, x^-1/2), e -> 2 x.
    Checked against the loop integrated on 200,001 points (``tests/test_averaged_forms.py``)."""
    import numpy as np

    x = np.asarray(x, dtype=float)
    s, e, t = 0.5 * x, (2.0 / 3.0) * x**3, 0.5 * x
    slip = x > 1.0
    if not np.any(slip):
        return s, e, t
    xs = x[slip]
    alpha = np.arccos(np.clip((xs - 2.0) / xs, -1.0, 1.0))
    sine = np.sin(alpha)
    s1, s2, s3 = sine, 0.5 * alpha + 0.25 * np.sin(2.0 * alpha), sine - sine**3 / 3.0
    part = (xs - 0.5 - 0.25 * xs**2) * s1 + (0.5 * xs**2 - xs) * s2 - 0.25 * xs**2 * s3
    s, e, t = s.copy(), e.copy(), t.copy()
    s[slip] = 1.0 + 2.0 / (np.pi * xs) * (part - 0.5 * sine)
    e[slip] = 2.0 * xs - 4.0 / 3.0
    t[slip] = 1.0 - ((1.0 - 0.5 * xs) * alpha + 0.5 * xs * sine) / np.pi
    return s, e, t


class AveragedFriction:
    """The clamp friction's averaged (slow-flow) form (module notes; the contract of
    :mod:`beam.physics.effects.averaged`)."""

    note = AVERAGED_NOTE

    def prepare(self, model, values, shapes, omega, sigma, tau, output="displacement"):
        import numpy as np

        stiffness, moment = float(values[STICK.name]), float(values[SLIP.name])
        if not (stiffness > 0.0 and moment > 0.0):
            raise BeamInputError("clamp_friction's averaged form needs a positive k_f and M_s")
        root = root_row(model)[0] @ shapes  # (m,) rad per unit modal coordinate
        return {"k": stiffness, "theta_s": 2.0 * moment / stiffness, "root": root, "omega": np.asarray(omega, float),
                "sigma": np.asarray(sigma, float), "tau": np.asarray(tau, float)}

    def describing(self, prepared, amplitudes):
        import numpy as np

        a = np.atleast_2d(np.asarray(amplitudes, dtype=float))
        root, omega, k, theta_s = prepared["root"], prepared["omega"], prepared["k"], prepared["theta_s"]
        rows = np.arange(a.shape[0])
        p = np.argmax(np.abs(root)[None, :] * a, axis=1)
        x = np.abs(root[p]) * a[rows, p] / theta_s
        s, e, t = joint_describing(x)
        # a faster mode whose root rate outruns the dominant one's near its turning points reverses the
        # joint there: for that share of the cycle, (2 / pi) asin(v_k / v_p), it sees the stick stiffness
        speed = (np.abs(root) * omega)[None, :] * a
        with np.errstate(divide="ignore", invalid="ignore"):
            outrun = np.clip(speed / speed[rows, p][:, None], 0.0, 1.0)
        stuck = np.where(np.isfinite(outrun), 2.0 / np.pi * np.arcsin(np.nan_to_num(outrun)), 0.0)
        shift = -(root**2)[None, :] * k * t[:, None] * (1.0 - stuck) / (2.0 * omega[None, :])
        shift[rows, p] = -root[p] ** 2 * k * s / (2.0 * omega[p])
        rate = np.zeros_like(a)
        with np.errstate(divide="ignore", invalid="ignore"):
            own = k * theta_s**2 * e / (2.0 * np.pi * omega[p] * a[rows, p] ** 2)
        rate[rows, p] = np.where(a[rows, p] > 0.0, own, 0.0)
        return shift, rate

    def envelope(self, prepared, amplitudes):
        import numpy as np

        a = np.asarray(amplitudes, dtype=float)
        root = prepared["root"]
        p = int(np.argmax(np.abs(root) * a))
        # microslip has closed forms (module notes) for the dominant mode, but the other modes'
        # share of the cycle stuck to the joint changes as their amplitudes fall: one quadrature for all
        return self.dominant_flow(prepared, a, p)

    def dominant_flow(self, prepared, amplitudes, p):
        """(ratio, phase) (N, m) of the slow flow from modal envelopes ``amplitudes`` (m,), mode
        ``p`` dominant (the only one the joint damps): its flow d ln A_p / dt = sigma_p - rate_p(A_p)
        is one-dimensional, so its time is the quadrature t(u) = ∫ du / (sigma_p - rate_p(e^u))
        on a grid of u = ln A_p (step :data:`FLOW_LOG_STEP`, trapezoids), inverted by
        interpolation; the other modes decay linearly, and every mode's phase is the integral of
        its frequency shift along the grid.

        Why not :func:`~beam.physics.effects.averaged.slow_flow`: its adaptive steps call the
        describing function one state at a time, ~900 calls and 0.24 s per envelope on a 4 s
        window (a calibration asks for hundreds); the grid evaluates it once, vectorised, in
        milliseconds, and agrees with it to 1e-6 (``tests/test_averaged_forms.py``)."""
        import numpy as np

        a = np.asarray(amplitudes, dtype=float)
        sigma, tau = prepared["sigma"], prepared["tau"]
        m = a.size
        end = float(np.max(tau)) if tau.size else 0.0
        if end <= 0.0:
            return np.ones((tau.size, m)), np.zeros((tau.size, m))
        root, k, theta_s, omega_p = prepared["root"], prepared["k"], prepared["theta_s"], prepared["omega"][p]
        u0 = math.log(a[p])
        u = u0 - FLOW_LOG_STEP * np.arange(int(FLOW_LOG_SPAN / FLOW_LOG_STEP) + 1)
        amplitude = np.exp(u)
        _, e, _ = joint_describing(abs(root[p]) * amplitude / theta_s)
        speed = -sigma[p] + k * theta_s**2 * e / (2.0 * np.pi * omega_p * amplitude**2)  # -d u / dt (1/s)
        t = np.concatenate([[0.0], np.cumsum(0.5 * FLOW_LOG_STEP * (1.0 / speed[1:] + 1.0 / speed[:-1]))])
        last = int(np.searchsorted(t, end)) + 2  # the grid to just beyond the window's end
        u, amplitude, t = u[:last], amplitude[:last], t[:last]
        beyond = np.maximum(tau - t[-1], 0.0)  # past the grid's span: A_p negligible, its decay linear
        log_a = np.interp(tau, t, u) + sigma[p] * beyond
        ratio = np.ones((tau.size, m))
        ratio[:, p] = np.exp(log_a - u0 - sigma[p] * tau)
        # the phases on a fine grid of time (a faster mode's share of the cycle stuck to the joint
        # has a square-root kink where its root speed falls below the dominant one's)
        fine = np.union1d(np.linspace(0.0, end, FLOW_PHASE_POINTS), np.clip(tau, 0.0, end))
        states = a[None, :] * np.exp(sigma[None, :] * fine[:, None])
        states[:, p] = np.exp(np.interp(fine, t, u) + sigma[p] * np.maximum(fine - t[-1], 0.0))
        shift, _ = self.describing(prepared, states)
        phase = np.concatenate([np.zeros((1, m)), np.cumsum(0.5 * np.diff(fine)[:, None] * (shift[1:] + shift[:-1]),
                                                            axis=0)])
        return ratio, np.column_stack([np.interp(tau, fine, phase[:, j]) for j in range(m)])


#: Step (in ln A) and span of the grid of :meth:`AveragedFriction.dominant_flow`: trapezoids of
#: 0.005 in ln A change the envelope by under 1e-6 of itself; past 40 e-folds the joint is idle.
FLOW_LOG_STEP, FLOW_LOG_SPAN = 0.005, 40.0
#: Points of the time grid (besides the asked times) the phases of :meth:`AveragedFriction.dominant_flow` are integrated on.
FLOW_PHASE_POINTS = 10000


def friction_starts(model, one, state, duration_s):
    """Starts with the clamp friction on, from a sub-model's optimum ``one`` (natural units, the
    friction at its null values: a rigid joint that never slips) and its modal state ``state`` at
    the window's start.

    For each stick stiffness k_f of :data:`FRICTION_STIFFNESS_RATIOS` (times EI / L), EI is raised
    so that the compliant root keeps the sub-model's f1 (one correction, f1² ∝ EI), and for each
    ratio q of :data:`FRICTION_SLIP_RATIOS` the slip moment is set so that the root's rotation at
    the window's start, |r_1| A_1 (r_1 the root rotation per unit mode-1 coordinate, A_1 the
    sub-model's mode-1 amplitude there), is q slip rotations: M_s = k_f |r_1| A_1 / 2 q. The
    joint's softening and loss are of order (theta / theta_s) times its share of the mode's strain
    energy, so the grid spans a drift of f1 from negligible to several times what a strip's decay
    shows. Empty when ``one`` lacks a parameter of it.
    """
    import numpy as np

    ei = base.BENDING_STIFFNESS.name
    if not all(n in one for n in (STICK.name, SLIP.name, ei)):
        return []
    m = state.size // 2
    names = model.parameter_names_for(m)
    omega2, _ = model.mode_shapes({n: one[n] for n in names}, m)
    if not (np.all(np.isfinite(state)) and omega2[0] > 0.0):
        return []
    mode_1 = math.hypot(state[0], state[m] / math.sqrt(omega2[0]))
    stiffness = one[ei]
    root = root_row(model)[0]
    starts = []
    for ratio in FRICTION_STIFFNESS_RATIOS:
        trial = dict(one, **{STICK.name: ratio * stiffness / model.geometry.length_m})
        softened, _ = model.mode_shapes({n: trial[n] for n in names}, m)
        trial[ei] = stiffness * float(omega2[0] / softened[0])
        _, shapes = model.mode_shapes({n: trial[n] for n in names}, m)
        rotation = abs(float(root @ shapes[:, 0])) * mode_1  # rad at the window's start
        if not (math.isfinite(rotation) and rotation > 0.0):
            continue
        for slip in FRICTION_SLIP_RATIOS:
            moment = trial[STICK.name] * rotation / (2.0 * slip)
            starts.append(dict(trial, **{SLIP.name: float(moment)}))
    return starts


EFFECT = Effect(
    "clamp_friction",
    "Clamp friction",
    "the clamp grips the strip by friction: a root joint of stick stiffness k_f that slips progressively "
    "(Iwan microslip, Masing hysteresis) and wholly at the moment M_s",
    (STICK, SLIP),
    (Term("stiffness", "stiffness_clamp", STICK.name),),
    channel=Channel("clamp_friction", LAW_IWAN_JOINT, (STICK.name, SLIP.name), SLIP.name, root_row, coefficients,
                    on_when_given=True),
    frees_root_rotation=True,
    missing_effect_candidate=False,
    needs=frozenset({"free", "rising_frequency"}),
    refusals=(Refusal(frozenset({"free"}), "clamp_friction is calibrated on free decays only (a record without input): "
                      "its joint's history is taken from the swing at the window's start"),),
    averaged=AveragedFriction(),
    hints=StartHints(free_decay=friction_starts),
    catalogue_order=90,
)
