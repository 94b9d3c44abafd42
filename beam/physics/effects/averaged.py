"""The averaged (slow-flow) slot of an effect: a closed-form free decay with one nonlinear effect.

A free decay of the retained modes rings, mode k, at its damped frequency omega_d,k under an
exponential envelope a_k e^(-c_k tau) (c_k = -Re(pole_k), tau the time since the window's
start). A weak nonlinear effect changes, to first order in the averaging over one cycle, each
mode's envelope and phase slowly (Krylov–Bogoliubov): the averaged response is the linear
free-response basis with mode k's two columns multiplied by ``ratio_k(tau)`` =
A_k(tau) / (a_k e^(-c_k tau)) and turned by ``phase_k(tau)`` (rad, added to omega_d,k tau). At
the effect's null value the ratio is 1 and the phase 0: the averaged model *is* the linear one.

**The contract of the slot** (what a module implements to give its effect an averaged form; the
calibration, :mod:`beam.calibration.free_averaged`, does the rest: the linear basis, the
amplitudes and offset, the MAP, the Laplace covariance, the bands and the preview event; the
scoring on the identified curves, :mod:`beam.calibration.slowflow`, reads ``describing``):

``note`` : str
    The label of every result of the averaged form (a preview, not the full integration).
``prepare(model, values, shapes, omega, sigma, tau, output="displacement")``
    What depends on the parameters only (the caller caches it per parameter set): ``model`` the
    :class:`~beam.physics.model.BeamModel`, ``values`` the natural-unit parameters (floats by
    name), ``shapes`` (n, m) its mass-normalised undamped shapes (Galerkin coefficients, tip
    positive), ``omega`` (m,) their undamped frequencies (rad/s), ``sigma`` (m,) the linear
    poles' real parts (1/s, negative), ``tau`` (N,) the times since the window's start (s; may
    be empty when only ``describing`` is asked for), ``output`` the record's output kind
    (``"displacement"``, ``"velocity"``, ``"acceleration"``, ``"strain"``: the full model's
    static correction applies to displacements and strains only; a form whose full model treats
    the outputs alike ignores it). The response of a velocity or acceleration record is the
    caller's: it scales each mode's columns by (omega_k(A) / omega_k)^order, the instantaneous
    frequency of ``describing``.
    Raise :class:`~beam.errors.BeamInputError` when the form does not apply (the caller then
    shows no averaged preview).
``envelope(prepared, amplitudes)``
    ``(ratio, phase)``: (N, m) arrays for the initial modal envelopes ``amplitudes`` (m,)
    (modal coordinates at the window's start); ``phase`` may be None (no phase change). A form
    without a closed form returns :func:`slow_flow` of its own ``describing``.
``describing(prepared, amplitudes)``
    ``(shift, rate)``: (N, m) arrays for N states of the modal envelopes ``amplitudes`` (N, m):
    the first-order change of each mode's frequency (rad/s, added to its undamped omega_k) and
    the decay rate the effect adds to its envelope (1/s: d ln A_k / dt = -c_k - rate_k), both at
    that instant (the describing function of the effect, averaged over one cycle of the dominant
    mode). What the backbone and damping curves of a record measure
    (:mod:`beam.residuals.amplitude_id`): omega_k(A) = omega_k + shift_k and
    zeta_k(A) = (c_k + rate_k) / omega_k(A). The envelope is its integral over the decay; with
    several nonlinear effects the calibration integrates the sum of their ``describing``
    (:func:`slow_flow`), first-order correct, since at first order the effects add.

Why ``describing`` was added to the slot (it held ``prepare`` and ``envelope`` only): scoring a
candidate on a record's identified backbone and damping curves needs the instantaneous
frequency and decay rate at each block's amplitudes, which the envelope (their time integral
from one initial state) does not give; and a model with two nonlinear effects (the drag and the
clamp's friction on a real strip) needs their sum, which two closed-form envelopes do not give.

**Linear effects** need no form: their modal shifts (a mass, a compliant clamp, a rotary inertia,
an effective length change each mode's frequency and so the ratios of the modes) are the linear
model's own eigenproblem (:meth:`~beam.physics.model.BeamModel.mode_shapes`, exact, from the
terms of the effect's module), which both the averaged calibration and the scoring solve.

Limits belong to each form's module docstring (what it keeps of the coupling of the modes, when it
holds): the drag's in :mod:`beam.physics.effects.quadratic_drag`, the Iwan joint's in
:mod:`beam.physics.effects.clamp_friction`, the cubic spring's in
:mod:`beam.physics.effects.tip_cubic_spring`.
"""

from __future__ import annotations

from typing import Any, Protocol

__all__ = ["AveragedForm", "SLOW_FLOW_RTOL", "slow_flow"]

#: Tolerance of the numerical slow flow (:func:`slow_flow`) on ln A (and, in its fallback, the phase).
SLOW_FLOW_RTOL = 1e-7


class AveragedForm(Protocol):
    """The averaged (slow-flow) form of an effect's free decay (see the module notes)."""

    note: str

    def prepare(self, model: Any, values: dict, shapes: Any, omega: Any, sigma: Any, tau: Any,
                output: str = "displacement") -> Any:
        """Per-parameter constants of the form (see the module notes)."""

    def envelope(self, prepared: Any, amplitudes: Any) -> tuple[Any, Any | None]:
        """(ratio (N, m), phase (N, m) or None) for initial modal envelopes ``amplitudes`` (m,)."""

    def describing(self, prepared: Any, amplitudes: Any) -> tuple[Any, Any]:
        """(frequency shift (N, m) rad/s, added decay rate (N, m) 1/s) at modal envelopes (N, m)."""


def slow_flow(describing, amplitudes, sigma, tau):
    """The envelopes and phases of the slow flow d ln A_k / dt = sigma_k - rate_k(A),
    d phi_k / dt = shift_k(A) from A(0) = ``amplitudes`` (m,), integrated numerically.

    Parameters
    ----------
    describing : callable
        ``describing(A (N, m)) -> (shift (N, m) rad/s, rate (N, m) 1/s)``: the sum of the
        model's forms' ``describing`` (their prepared constants bound).
    amplitudes : array (m,)
        Initial modal envelopes (modal coordinates).
    sigma : array (m,)
        The linear poles' real parts (1/s, negative).
    tau : array (N,)
        Times since the start (s, >= 0).

    Returns
    -------
    ratio, phase : arrays (N, m)
        A_k(tau) / (a_k e^(sigma_k tau)) and the phase added to omega_d,k tau (rad): the slot's
        ``envelope``. A mode of zero amplitude keeps ratio 1 (its envelope's own law at A -> 0).

    How: Picard's iteration of the integral form y(t) = -∫ rate(a e^(sigma t + y)) dt on a grid of
    :data:`SLOW_FLOW_POINTS` times (and the asked ones), trapezoids, each pass one vectorised call
    of ``describing``, until the passes agree to :data:`SLOW_FLOW_RTOL` (a few passes: the
    effects move the envelope by a fraction of the linear decay, and Picard's iterates converge as
    (L t)^n / n!). Why not scipy's ``solve_ivp`` alone: its adaptive steps call ``describing`` one
    state at a time, ~900 calls and 0.2 s per envelope on a 5 s window, and a calibration asks
    for hundreds; the grid takes milliseconds. ``solve_ivp`` (DOP853, dense output) remains the
    fallback where the passes do not settle within :data:`SLOW_FLOW_PASSES`.
    """
    import numpy as np

    a0 = np.asarray(amplitudes, dtype=float)
    m = a0.size
    tau = np.asarray(tau, dtype=float)
    if tau.size == 0:
        return np.ones((0, m)), np.zeros((0, m))
    end = float(np.max(tau))
    if end <= 0.0:
        return np.ones((tau.size, m)), np.zeros((tau.size, m))
    sigma = np.asarray(sigma, dtype=float)
    grid = np.union1d(np.linspace(0.0, end, SLOW_FLOW_POINTS), np.clip(tau, 0.0, end))
    steps = 0.5 * np.diff(grid)[:, None]
    linear = a0[None, :] * np.exp(sigma[None, :] * grid[:, None])

    def integral(rates):
        return np.concatenate([np.zeros((1, m)), np.cumsum(steps * (rates[1:] + rates[:-1]), axis=0)])

    y = np.zeros((grid.size, m))
    for _ in range(SLOW_FLOW_PASSES):
        shift, rate = describing(linear * np.exp(y))
        new = -integral(rate)
        settled = float(np.max(np.abs(new - y))) <= SLOW_FLOW_RTOL
        y = new
        if settled:
            shift, _ = describing(linear * np.exp(y))
            phase = integral(shift)
            return (np.exp(np.column_stack([np.interp(tau, grid, y[:, j]) for j in range(m)])),
                    np.column_stack([np.interp(tau, grid, phase[:, j]) for j in range(m)]))
    return _slow_flow_ivp(describing, a0, sigma, tau)


#: Times of the grid (besides the asked ones) :func:`slow_flow` integrates on, and its most passes.
SLOW_FLOW_POINTS, SLOW_FLOW_PASSES = 10000, 40


def _slow_flow_ivp(describing, a0, sigma, tau):
    """:func:`slow_flow` by scipy's ``solve_ivp`` (DOP853 at :data:`SLOW_FLOW_RTOL`, dense output)."""
    import numpy as np
    from scipy.integrate import solve_ivp

    m = a0.size
    log_a0 = np.log(np.maximum(a0, 1e-300))

    def rhs(t, y):
        shift, rate = describing(np.exp(log_a0 + y[:m] + sigma * t)[None, :])
        return np.concatenate([-rate[0], shift[0]])

    end = float(np.max(tau))
    solution = solve_ivp(rhs, (0.0, end), np.zeros(2 * m), method="DOP853", rtol=SLOW_FLOW_RTOL,
                         atol=1e-12, dense_output=True)
    if not solution.success:
        from beam.errors import BeamInputError

        raise BeamInputError(f"the averaged slow flow failed: {solution.message}")
    y = solution.sol(np.clip(tau, 0.0, end))  # (2m, N)
    return np.exp(y[:m].T), y[m:].T
