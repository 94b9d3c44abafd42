"""The averaged (slow-flow) model of a free decay with one nonlinear effect: a closed-form preview
of its calibration and the start of the full one.

The effects' averaged forms (:attr:`beam.physics.effects.effect.Effect.averaged`, the contract
of :mod:`beam.physics.effects.averaged`; the drag's, the clamp friction's and the tip spring's
are in their modules) say how each retained mode's envelope and phase depart from the linear
model's (one effect: its closed form; several: the slow flow of their summed describing
functions). Here the calibration around it: the response is the linear
free-response basis of :class:`~beam.calibration.free.ProjectedFreeModel` with each mode's two
columns scaled (and turned) by the form, so at the effect's null value it *is* the linear model;
its amplitudes (two per mode: cosine and sine at the window's start) and offset are the
coordinates of :class:`~beam.calibration.free_nonlinear.NonlinearFreeModel` (the same initial
modal state, a_k = hypot(eta_k, (eta'_k - Re(pole_k) eta_k) / omega_d,k)). Its MAP and Laplace
covariance (:meth:`AveragedDragModel.fit`), its linearised bands (:meth:`AveragedDragModel.bands`)
and the Laplace result that shows them (:func:`averaged_laplace`) are the averaged model's: they
do not include its approximation error (the drag's against the full integrator on a strip decay,
relative L2, is in ``docs/decisions.md``, nonlinear free decays).

Why hand-written: the response is a closed form (no library evaluates it), and it is what makes
the preview cheaper than the ETDRK4 integration it stands for (no integration at all).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from beam.errors import BeamInputError
from beam.inference import AR1_COEFFICIENT, LaplaceResult, MapResult, PredictiveBands, Problem
from beam.physics.effects import EFFECTS
from beam.physics.effects.averaged import slow_flow

#: Orders of the time derivative of the displacement each output kind is.
OUTPUT_ORDERS = {"displacement": 0, "velocity": 1, "acceleration": 2, "strain": 0}
from beam.physics.effects.quadratic_drag import AVERAGED_NOTE  # noqa: F401 - the drag's label, re-exported

__all__ = ["AVERAGED_NOTE", "AveragedDragFit", "AveragedDragModel", "AveragedModel", "MIXED_NOTE", "averaged_laplace"]

#: The label of the averaged model of several nonlinear effects.
MIXED_NOTE = ("averaged (slow-flow) approximation of {}: the effects' describing functions summed and the slow "
              "flow of each mode's envelope and phase integrated (cycle-averaged, first order); a preview, not the "
              "full integration")


#: The averaged model's search stops once its Gauss–Newton step is shorter than this (posterior
#: sd): a tenth of the posterior's width, well below the averaged model's own bias (its MAP lies
#: several posterior sd from the full model's; ``docs/decisions.md``), which the full
#: calibration started from it removes.
PREVIEW_STOP_SD = 0.1


@dataclass(frozen=True)
class AveragedDragFit:
    """The MAP and Laplace approximation of the averaged model.

    Attributes
    ----------
    values : dict of str to float
        MAP of the physical parameters, natural units.
    internal : ndarray (d,)
        The same, the problem's internal coordinates.
    covariance : ndarray (d, d)
        Laplace covariance in internal coordinates (the amplitudes and offset eliminated).
    intervals : dict of str to (float, float)
        95 % intervals, natural units (internal mean ± 1.96 sd, mapped).
    amplitudes : ndarray (k,)
        Basis amplitudes (2 per mode, output units) and the offset at the MAP.
    noise_sd : float
        Root-mean-square residual at the MAP (the output's unit).
    n_evaluations : int
        Residual evaluations of the least squares.
    ar1_coefficient : float or None
        The AR(1) coefficient the residuals were whitened with (the start's), None for i.i.d. noise.
    note : str
        The averaged form's label (the drag's :data:`AVERAGED_NOTE`).
    """

    values: dict
    internal: np.ndarray
    covariance: np.ndarray
    intervals: dict
    amplitudes: np.ndarray
    noise_sd: float
    n_evaluations: int
    ar1_coefficient: float | None = None
    note: str = AVERAGED_NOTE


class AveragedDragModel:
    """The averaged model on the window of a :class:`~beam.calibration.free_nonlinear.NonlinearFreeModel`
    (its beam model, modes, output, times, data, offset and state map).

    Parameters
    ----------
    free : NonlinearFreeModel
        A free decay whose nonlinear effects all have averaged forms (``quadratic_drag``,
        ``clamp_friction``, ``tip_cubic_spring``; one: its closed form; several: their summed
        describing functions integrated).
    time_s : ndarray, optional
        Times (s, none before the window's first sample) the response is evaluated at: the
        window's (``free.fit_time_s``) by default, the record's after the window to predict it.
    """

    def __init__(self, free, time_s: np.ndarray | None = None) -> None:
        nonlinear = [e for e in free.model.effects if EFFECTS[e].nonlinear]
        if not nonlinear or any(EFFECTS[e].averaged is None for e in nonlinear):
            forms = ", ".join(e for e in EFFECTS if EFFECTS[e].averaged is not None)
            raise BeamInputError(f"the averaged model covers nonlinear effects that have an averaged form ({forms})")
        self.effects = tuple(EFFECTS[e] for e in nonlinear)
        self.effect = self.effects[0]
        self.forms = tuple(e.averaged for e in self.effects)
        self.form = self.forms[0]
        self.note = self.form.note if len(self.forms) == 1 else MIXED_NOTE.format(", ".join(nonlinear))
        self.free = free
        self.time_s = free.fit_time_s if time_s is None else np.asarray(time_s, dtype=float)
        self.tau = self.time_s - free.reference_s
        if self.tau.size and self.tau[0] < -1e-12:
            raise BeamInputError("the averaged model predicts forward from the window's first sample only")
        self._cache: dict[bytes, dict] = {}

    def _theta(self, one: Mapping[str, float]) -> dict:
        """What depends on the parameters only (cached): the linear basis (n, 2m), c_k, omega_d,k,
        the state map, and the averaged form's own constants."""
        free, m = self.free, self.free.modes
        one = {n: float(one[n]) for n in free.names}
        key = np.array([one[n] for n in free.names]).tobytes()
        if key in self._cache:
            return self._cache[key]
        values = {n: np.array([one[n]]) for n in free.names}
        poles = free.poles(values)[0]
        upper = poles[::2]
        if poles.size != 2 * m or np.any(np.abs(upper.imag) <= 0.0):
            raise BeamInputError("the averaged model needs every retained mode underdamped")
        basis = free.design(poles[None, :], self.time_s)[0][:, : 2 * m]  # (n, 2m)
        sigma, omega_d = upper.real, np.abs(upper.imag)
        omega2, shapes = free.model.mode_shapes(one, m)
        omega = np.sqrt(np.maximum(omega2, 0.0))
        entry = {"basis": basis, "sigma": sigma, "omega_d": omega_d, "T": free.state_matrix(one),
                 "forms": [form.prepare(free.model, one, shapes, omega, sigma, self.tau, output=free.output_kind)
                           for form in self.forms]}
        if len(self._cache) > 64:
            self._cache.clear()
        self._cache[key] = entry
        return entry

    def modal_amplitudes(self, one: Mapping[str, float], amplitudes: np.ndarray) -> np.ndarray:
        """Initial envelope a_k (m,) of each mode (modal coordinate) of basis amplitudes (2m or k,)."""
        entry, m = self._theta(one), self.free.modes
        state = entry["T"] @ np.asarray(amplitudes[: 2 * m], dtype=float)
        eta, rate = state[:m], state[m:]
        return np.hypot(eta, (rate - entry["sigma"] * eta) / entry["omega_d"])

    def response(self, one: Mapping[str, float], amplitudes: np.ndarray) -> np.ndarray:
        """The averaged response (n,) on the window, the offset included (output units)."""
        entry, m = self._theta(one), self.free.modes
        modal = self.modal_amplitudes(one, amplitudes)
        ratio, phase = self.envelope(entry, modal)
        order = OUTPUT_ORDERS.get(self.free.output_kind, 0)
        if phase is not None and order:  # a velocity or acceleration: omega(A)^order times the displacement's
            envelopes = modal[None, :] * np.exp(entry["sigma"][None, :] * self.tau[:, None]) * ratio
            shift = sum(form.describing(prepared, envelopes)[0] for form, prepared in zip(self.forms, entry["forms"]))
            ratio = ratio * (1.0 + shift / entry["omega_d"][None, :]) ** order
        basis = entry["basis"]
        out = np.zeros(self.tau.size)
        for k in range(m):
            cosine, sine = basis[:, 2 * k], basis[:, 2 * k + 1]
            if phase is not None:  # each mode's phase turned: the columns at omega_d tau + phase
                c, s = np.cos(phase[:, k]), np.sin(phase[:, k])
                cosine, sine = c * cosine - s * sine, s * cosine + c * sine
            out += ratio[:, k] * (cosine * amplitudes[2 * k] + sine * amplitudes[2 * k + 1])
        return out + (amplitudes[-1] if self.free.offset else 0.0)

    def envelope(self, entry: dict, modal: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """(ratio, phase) (N, m) of the model's forms from initial modal envelopes ``modal`` (m,):
        one form's own envelope (its closed form); several forms' summed describing functions
        integrated (:func:`beam.physics.effects.averaged.slow_flow`: at first order the effects add)."""
        if len(self.forms) == 1:
            return self.forms[0].envelope(entry["forms"][0], modal)

        def describing(amplitudes):
            parts = [form.describing(prepared, amplitudes) for form, prepared in zip(self.forms, entry["forms"])]
            return sum(p[0] for p in parts), sum(p[1] for p in parts)

        return slow_flow(describing, modal, entry["sigma"], self.tau)

    def bands(self, fit: AveragedDragFit, problem: Problem, time_s: np.ndarray, level: float = 0.95) -> PredictiveBands:
        """Predictive bands of the averaged model at ``time_s`` (s, from the window's first sample
        on; output units) by the delta method, as the full model's
        :meth:`~beam.calibration.free_nonlinear.NonlinearFreeModel.linearised_bands`: the averaged
        response at the MAP ``fit`` (a :meth:`fit` of this model, on the window), its sd from
        ``fit.covariance`` (the physical parameters) through the response's derivative with the
        amplitudes and offset re-fitted on the window (d a / d theta from the window's normal
        equations), the prediction band widened by ``fit.noise_sd``. Closed forms only: no
        integration. The bands hold the averaged model's uncertainty, not its approximation error.
        """
        from scipy import stats

        physical = [n for n in problem.names if n not in problem.noise_names]
        d = len(physical)
        x = np.concatenate([fit.internal, fit.amplitudes])
        record = AveragedDragModel(self.free, time_s)

        def on(model):
            return lambda v: model.response(_natural(problem, physical, v[:d]), v[d:])

        steps = np.concatenate([np.full(d, 1e-6), np.full(x.size - d, 1e-6 * max(float(np.max(np.abs(x[d:]))),
                                                                                   1e-300))])
        record_columns, window_columns = jacobian_of(on(record), x, steps), jacobian_of(on(self), x, steps)
        sensitivity, *_ = np.linalg.lstsq(window_columns[:, d:], window_columns[:, :d], rcond=None)  # -d a / d theta
        derivative = record_columns[:, :d] - record_columns[:, d:] @ sensitivity  # (n, d)
        model_sd = np.sqrt(np.maximum(np.einsum("ti,ij,tj->t", derivative, fit.covariance, derivative), 0.0))
        mean = on(record)(x)
        quantile = float(stats.norm.ppf(0.5 + 0.5 * level))
        spread = np.sqrt(model_sd**2 + fit.noise_sd**2)
        return PredictiveBands(time_s=record.time_s, mean=mean, credible_lower=mean - quantile * model_sd,
                               credible_upper=mean + quantile * model_sd, prediction_lower=mean - quantile * spread,
                               prediction_upper=mean + quantile * spread, level=float(level), n_draws=0)

    # ------------------------------------------------------------------ MAP + Laplace
    def fit(self, problem: Problem, start: Mapping[str, float], amplitudes: np.ndarray,
            also: Sequence[Mapping[str, float]] = ()) -> AveragedDragFit:
        """MAP of the averaged model (trust-region least squares over the internal physical
        parameters, the amplitudes and the offset, from ``start`` and its ``amplitudes``) and its
        Laplace covariance (Gauss–Newton, the amplitudes and offset eliminated with their
        N(0, A²) prior, as :meth:`NonlinearFreeModel._laplace_hessian`). White noise at the
        start's residual sd (the AR(1) coefficient of ``start`` whitens, if the likelihood has it).
        The search runs from the best of ``start``, its equivalent starts and the starts ``also``
        (natural values; each given ``start``'s initial modal state, its amplitudes refined)."""
        from beam.calibration.fit import internal_starts

        free = self.free
        physical = [n for n in problem.names if n not in problem.noise_names]
        d = len(physical)
        lo, hi = problem.internal_bounds
        margin = 1e-9 * np.maximum(hi - lo, 1e-300)
        z0 = internal_starts(problem, [dict(start)])[0][:d]
        quadratic = [problem.parameter(n).prior.internal_quadratic() for n in physical]
        rho = float(start.get(AR1_COEFFICIENT, 0.0)) if free.likelihood == "ar1" else None
        y = free.fit_data

        if self.time_s is not free.fit_time_s:
            raise BeamInputError("the averaged model is fitted on its window's times")

        def natural(z):
            return _natural(problem, physical, z)

        def data_residual(x):
            return free.whitened((y - self.response(natural(x[:d]), x[d:]))[None, :], rho)[0]

        a = np.asarray(amplitudes, dtype=float)
        # the best of the start and its equivalent starts (the same initial modal state, the
        # amplitudes then refined at fixed parameters: cheap, the parameters' part is cached)
        m2 = 2 * free.modes
        state = self._theta(dict(start))["T"] @ a[:m2]
        best = (float(np.sum(data_residual(np.concatenate([z0, a])) ** 2)), z0, a)
        keep = [*free.names, *([AR1_COEFFICIENT] if AR1_COEFFICIENT in start else [])]  # the AR(1) whitens the linear fit
        equivalent = free.equivalent_starts({n: start[n] for n in keep}, tuple(e.id for e in self.effects))
        best_also = None
        for i, other in enumerate([*equivalent, *also]):
            z = internal_starts(problem, [other])[0][:d]
            b = np.concatenate([np.linalg.solve(self._theta(natural(z))["T"], state), a[m2:]])
            scale0 = max(math.sqrt(float(np.mean(data_residual(np.concatenate([z, b])) ** 2))), 1e-300)

            def amplitude_residuals(v, z=z, scale0=scale0):
                return data_residual(np.concatenate([z, v])) / scale0

            def amplitude_jacobian(v, z=z, scale0=scale0):
                return jacobian_of(lambda w: data_residual(np.concatenate([z, w])) / scale0, v, np.full(
                    v.size, 1e-6 * max(float(np.max(np.abs(v))), 1e-300)))

            b, _ = _levenberg_marquardt(amplitude_residuals, amplitude_jacobian, b, np.full(b.size, -np.inf),
                                        np.full(b.size, np.inf), iterations=8)
            rss = float(np.sum(data_residual(np.concatenate([z, b])) ** 2))
            if not np.isfinite(rss):
                continue
            if rss < best[0]:
                best = (rss, z, b)
            if i >= len(equivalent) and (best_also is None or rss < best_also[0]):
                best_also = (rss, z, b)
        scale = {"sd": 1.0}

        def residuals(x):
            return np.concatenate([data_residual(x) / scale["sd"], free.prior_residuals(x[:d], quadratic)])

        def jacobian(x):
            steps = np.concatenate([np.full(d, 1e-6), np.full(x.size - d, 1e-6 * max(float(np.max(np.abs(x[d:]))),
                                                                                     1e-300))])
            columns = jacobian_of(data_residual, x, steps).T
            prior = np.zeros((d, x.size))
            for j, (_, _, sigma) in enumerate(quadratic):
                if math.isfinite(sigma):
                    prior[j, j] = 1.0 / sigma
            return np.vstack([columns.T / scale["sd"], prior])

        lower = np.concatenate([lo[:d] + margin[:d], np.full(a.size, -np.inf)])
        upper = np.concatenate([hi[:d] - margin[:d], np.full(a.size, np.inf)])

        def search(z0, a):
            # the search from one start, at the noise sd of its residual; its end's profiled
            # objective (n ln rss + the priors' squared residuals) ranks it against the other's
            scale["sd"] = max(math.sqrt(float(np.mean(data_residual(np.concatenate([z0, a])) ** 2))), 1e-300)
            x, evaluations = _levenberg_marquardt(residuals, jacobian, np.clip(np.concatenate([z0, a]), lower, upper),
                                                  lower, upper, stop=PREVIEW_STOP_SD)
            rss = float(np.sum(data_residual(x) ** 2))
            objective = y.size * math.log(max(rss, 1e-300)) + float(np.sum(free.prior_residuals(x[:d], quadratic) ** 2))
            return objective if math.isfinite(objective) else math.inf, x, evaluations, scale["sd"]

        # the best screened start, and the best of ``also`` when it is another (a start of the
        # curves: its frequencies are the backbone's, which the waveform's phase, screened at the
        # start, resolves far more finely, so it is searched before it is judged)
        ends = [search(best[1], best[2])]
        if best_also is not None and best_also[1] is not best[1]:
            ends.append(search(best_also[1], best_also[2]))
        _, x, evaluations, sd = min(ends, key=lambda end: end[0])
        scale["sd"] = sd
        evaluations = sum(end[2] for end in ends)
        noise = math.sqrt(float(np.mean(data_residual(x) ** 2)))
        info = (jacobian(x)[: y.size] * sd / noise).T @ (jacobian(x)[: y.size] * sd / noise)
        for j, (_, _, sigma) in enumerate(quadratic):
            if math.isfinite(sigma):
                info[j, j] += 1.0 / sigma**2
        info[d:, d:] += np.eye(a.size) / free.prior_sd**2
        schur = info[:d, :d] - info[:d, d:] @ np.linalg.solve(info[d:, d:], info[d:, :d])
        cov = np.linalg.inv(schur)
        spread = 1.959963984540054 * np.sqrt(np.maximum(np.diag(cov), 0.0))
        intervals = {n: (float(problem.parameter(n).prior.from_internal(x[i] - spread[i])),
                         float(problem.parameter(n).prior.from_internal(x[i] + spread[i])))
                     for i, n in enumerate(physical)}
        return AveragedDragFit(values=natural(x[:d]), internal=x[:d].copy(), covariance=cov, intervals=intervals,
                               amplitudes=x[d:].copy(), noise_sd=noise, n_evaluations=evaluations, ar1_coefficient=rho,
                               note=self.note)

    def fit_nested(self, problem: Problem, sub_values: Mapping[str, float]) -> AveragedDragFit:
        """:meth:`fit` from the optimum ``sub_values`` (natural units) of the model without the
        effect (the linear sub-model): its parameters (and AR(1) coefficient) with the effect's at
        their null values, clipped into the priors, and the linear model's amplitudes there."""
        from beam.calibration.fit import internal_starts
        from beam.calibration.free import ProjectedFreeModel
        from beam.calibration.nulls import null_value

        physical = [n for n in problem.names if n not in problem.noise_names]
        one = {n: float(v) for n, v in sub_values.items() if n in physical or n == AR1_COEFFICIENT}
        for name in (n for e in self.effects for n in e.parameter_names):
            if name in physical:
                one[name] = null_value(problem, name)
        one = {n: float(problem.from_internal(internal_starts(problem, [one]))[n][0]) for n in one}  # in the priors
        amplitudes = ProjectedFreeModel.fit(self.free, {n: np.array([v]) for n, v in one.items()})["amplitudes"][0]
        return self.fit(problem, one, amplitudes)


def averaged_laplace(problem: Problem, fit: AveragedDragFit, seconds: float = 0.0) -> LaplaceResult:
    """The averaged model's fit ``fit`` as a Laplace approximation of ``problem`` (the full
    model's), for a result that shows it: centred at its MAP (internal coordinates), its noise
    sd at ``fit.noise_sd`` (and the AR(1) coefficient at ``fit.ar1_coefficient``); the physical
    block of the covariance is ``fit.covariance``, each noise parameter's variance that of its
    Gaussian likelihood on the window's n samples (Fisher information 2n / sigma² of the sd,
    n / (1 - rho²) of the AR(1) coefficient, mapped to the internal coordinate), no cross terms.

    The log posterior and the log evidence are NaN (the full model's at this point would need
    the integration the averaged model avoids); ``warnings`` holds :data:`AVERAGED_NOTE`.
    """
    from beam.inference import NOISE_SD

    d = fit.internal.size
    n = problem.model.fit_data.size
    lo, hi = problem.internal_bounds
    z = np.empty(problem.ndim)
    z[:d] = fit.internal
    cov = np.zeros((problem.ndim, problem.ndim))
    cov[:d, :d] = fit.covariance
    for name in problem.noise_names:
        i, prior = problem.names.index(name), problem.parameter(name).prior
        value, information = ((fit.noise_sd, 2.0 * n / fit.noise_sd**2) if name == NOISE_SD else
                              (fit.ar1_coefficient or 0.0, n / max(1.0 - (fit.ar1_coefficient or 0.0) ** 2, 1e-12)))
        inside = 1e-9 * (hi[i] - lo[i]) if np.isfinite(hi[i] - lo[i]) else 0.0  # a logit coordinate: unbounded
        z[i] = float(np.clip(prior.to_internal(value), lo[i] + inside, hi[i] - inside))
        x = float(prior.from_internal(z[i]))
        h = 1e-6 * max(abs(x), 1e-6)
        slope = float(prior.to_internal(x + h) - prior.to_internal(x - h)) / (2.0 * h)  # d z / d x
        cov[i, i] = slope**2 / information
    values = {name: float(v[0]) for name, v in problem.from_internal(z[None, :]).items()}
    found = MapResult(z=z, values=values, log_posterior=math.nan, gradient=np.full(problem.ndim, math.nan),
                      hessian=-np.linalg.inv(cov), hessian_point=z.copy(), converged=True,
                      message=f"averaged model: {fit.n_evaluations} residual evaluations", n_starts=1)
    return LaplaceResult(problem=problem, map=found, mean=z.copy(), cov=cov, log_evidence=math.nan, ok=True,
                         warnings=[fit.note], seconds=seconds)


def _natural(problem: Problem, physical: list[str], z: np.ndarray) -> dict[str, float]:
    """The physical parameters ``physical`` at internal ``z`` (d,), natural units."""
    return {n: float(problem.parameter(n).prior.from_internal(z[i])) for i, n in enumerate(physical)}


def _levenberg_marquardt(residuals, jacobian, x: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                         iterations: int = 100, stop: float = 0.01) -> tuple[np.ndarray, int]:
    """Levenberg–Marquardt on the normal equations, bounds by projection (a coordinate at a bound
    with the gradient pushing out is held), an accepted step repeated (doubling) while it
    gains, until the Gauss–Newton step is shorter than ``stop`` in the residuals' metric
    (residuals scaled to unit noise: posterior sd). Hand-written because scipy's trust-region search takes
    a singular value decomposition of the whole (samples x unknowns) Jacobian at every iteration
    (~0.18 s on a 5 s window: 10 s of a preview), while its normal equations are 16 x 16.

    Returns the point and the number of residual evaluations."""
    r = residuals(x)
    cost, evaluations = float(r @ r), 1
    jac = jacobian(x)
    damping = 1e-3
    span = np.where(np.isfinite(upper - lower), upper - lower, np.inf)
    for _ in range(iterations):
        gradient = jac.T @ r
        held = (((x - lower) < 1e-4 * span) & (gradient > 0)) | (((upper - x) < 1e-4 * span) & (gradient < 0))
        free = ~held
        normal = jac[:, free].T @ jac[:, free]
        newton, *_ = np.linalg.lstsq(normal, -gradient[free], rcond=None)
        if float(np.linalg.norm(jac[:, free] @ newton)) < stop:
            break
        scale = np.maximum(np.diag(normal), 1e-300)
        while damping < 1e12:
            step = np.zeros_like(x)
            step[free] = np.linalg.solve(normal + damping * np.diag(scale), -gradient[free])
            trial = np.clip(x + step, lower, upper)
            r_trial = residuals(trial)
            evaluations += 1
            trial_cost = float(r_trial @ r_trial)
            if np.isfinite(trial_cost) and trial_cost < cost:
                x, r, cost = trial, r_trial, trial_cost
                for _ in range(6):  # along a direction the linearisation underestimates (a ratio
                    trial = np.clip(x + step, lower, upper)  # crawling to its bound): further while it gains
                    r_trial = residuals(trial)
                    evaluations += 1
                    trial_cost = float(r_trial @ r_trial)
                    if not (np.isfinite(trial_cost) and trial_cost < cost):
                        break
                    x, r, cost = trial, r_trial, trial_cost
                    step = 2.0 * step
                jac = jacobian(x)
                damping = max(damping / 10.0, 1e-9)
                break
            damping *= 4.0
        else:
            break
    return x, evaluations


def jacobian_of(function, x: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Forward-difference Jacobian (n, len(x)) of ``function`` (x -> (n,)) with ``steps``."""
    base = function(x)
    columns = np.empty((base.size, x.size))
    for j in range(x.size):
        point = x.copy()
        point[j] += steps[j]
        columns[:, j] = (function(point) - base) / steps[j]
    return columns


#: The averaged model of any free decay whose nonlinear effects all have averaged forms (the
#: drag's name kept for its callers).
AveragedModel = AveragedDragModel
