"""Free decays with a nonlinear effect (``quadratic_drag``, ``clamp_friction``, ``tip_cubic_spring``): the initial
state fitted by a Gauss–Newton inner solve, the MAP by a joint least-squares search.

A linear free response is linear in its initial state, which :class:`~beam.calibration.free.ProjectedFreeModel`
profiles out exactly. With the drag (or the spring) the response is no longer linear in the
state, but it stays close to it: :class:`NonlinearFreeModel` keeps the linear model's
coordinates — the amplitudes a of the free-response basis X(theta) (two per mode) and the
sensor's offset — and maps them to the modal state the nonlinear model integrates from
(:meth:`beam.physics.model.BeamModel.free_state_from_amplitudes`, linear in a). For each
parameter set the amplitudes start at the linear profile â_lin(theta) and are refined by
Gauss–Newton on the nonlinear response f(theta, a) (Jacobian by forward differences, the 2m
state directions in one batched integration; the offset's column is exact). At a nonlinear
parameter's null value the response *is* X(theta) a, the Jacobian is X(theta), and the first
Gauss–Newton step is zero: the profile equals the linear model's to round-off, so the model
with the drag nests the model without it exactly (the nested identity of the calibration).

The marginalisation over the amplitudes (:meth:`ProjectedFreeModel.log_likelihood_correction`)
uses the same formula with the Gauss–Newton Gram matrix J̃ᵀJ̃ at the inner optimum and c = J̃ᵀJ̃ â
(the Laplace approximation of the integral over a; exact at the null, where c = X̃ᵀỹ).

**Why a joint search, not the engine's profile search.** One integration of the nonlinear
model over a 5 s window at 4 kHz (19,124 stamps, 4 modes) costs ~45 ms of CPU, the inner solve
2-3 batched integrations of 1 + 2m sets each (~1 s per parameter set), and the engine's
lock-step search with its finite-difference Newton polish evaluates 150-500 parameter sets
(plus 1 + 2 d² per polish iteration): minutes for one preview. :meth:`NonlinearFreeModel.map_search`
instead runs one trust-region least squares (:func:`scipy.optimize.least_squares`) over the
physical parameters (internal coordinates), the amplitudes and the offset together, from the
best of the linear sub-model's optimum (the nested start: C_d at its null value, and at a few
values across its plausible range) and each nonlinear effect's own starts from it (its
:attr:`~beam.physics.effects.effect.StartHints.free_decay` hint, :meth:`NonlinearFreeModel.equivalent_starts`:
the drag's cycle-averaged viscous share taken out of the modal damping ratios, the friction's
grid of joints) and the MAP of the averaged model where the effect has an averaged form
(:mod:`beam.calibration.free_averaged`, closed form, no integration), each Jacobian one batched integration of
1 + d + 2m sets, until its Gauss–Newton step is shorter than :data:`JOINT_STOP_SD` posterior
sd (in the posterior's own metric: the trust-region search otherwise spends its last iterations
on moves far below the posterior's width); the Laplace
Hessian over the physical parameters is the Gauss–Newton matrix of that fit with the amplitudes
and offset eliminated (Schur complement: their Laplace marginalisation), the noise sd's
curvature from the profile. The predictive bands are linearised (:meth:`NonlinearFreeModel.linearised_bands`)
for the same reason: 400 draws, each an inner solve and an integration of the whole record, would
cost minutes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from beam.calibration.free import ProjectedFreeModel
from beam.errors import BeamInputError
from beam.inference import AR1_COEFFICIENT, NOISE_SD, MapResult, PredictiveBands, Problem
from beam.inference.progress import report
from beam.physics.effects import EFFECTS, effect_of_parameter

__all__ = ["INNER_ITERATIONS", "NonlinearFreeModel", "nonlinear_parameters"]

#: Most Gauss–Newton iterations of the inner solve for the amplitudes (it stops earlier once a
#: step would lower the residual sum of squares by less than :data:`INNER_TOLERANCE` of it:
#: ~1e-4 nats on a window of 20,000 samples).
INNER_ITERATIONS = 6
INNER_TOLERANCE = 1e-8
#: Forward-difference step of a state direction, relative to the largest modal state.
STATE_STEP = 1e-6
#: Most objective evaluations of the joint search, per unknown.
JOINT_MAX_NFEV_PER_UNKNOWN = 12
#: The joint search stops once its Gauss–Newton step (free coordinates) is shorter than this in
#: the posterior's own metric (Mahalanobis length, posterior sd): no coordinate would move by
#: more than 0.01 of its marginal sd, and the log posterior would gain at most 5e-5 nats.
JOINT_STOP_SD = 0.01
#: A coordinate within this fraction of its prior's internal range from a bound, the gradient
#: pushing out, is held at the bound by the stopping rule (the search's own bound handling).
JOINT_BOUND_FRACTION = 1e-4
#: How far (internal scales of its prior) the noise search reaches from its start along an
#: unbounded coordinate (the AR(1) coefficient's logit: ±10 of it is 0.99995 either way).
UNBOUNDED_NOISE_REACH = 10.0
#: Effects' own starts (:meth:`NonlinearFreeModel.equivalent_starts`) whose amplitudes are refined
#: by the inner solve before the search picks its start (the best screened; each refinement costs
#: ~6 batched integrations).
REFINED_STARTS = 1


def nonlinear_parameters(names: Sequence[str]) -> tuple[str, ...]:
    """The parameters among ``names`` that belong to a nonlinear effect of the catalogue."""
    out = []
    for name in names:
        effect = effect_of_parameter(name)
        if effect is not None and EFFECTS[effect].nonlinear:
            out.append(name)
    return tuple(out)


class NonlinearFreeModel(ProjectedFreeModel):
    """Forward model of a free response with a nonlinear effect, its amplitudes and offset fitted
    by Gauss–Newton from the linear profile (see the module notes).

    Takes the arguments of :class:`~beam.calibration.free.ProjectedFreeModel`; the model must
    have a nonlinear effect. Predictions are made forward from the first calibration sample
    only (the nonlinear model is integrated forward in time).
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.nonlinear_names = nonlinear_parameters(self.names)
        if not self.nonlinear_names:
            raise BeamInputError("NonlinearFreeModel needs a nonlinear effect; use ProjectedFreeModel")
        self._nl_cache: tuple | None = None
        self._seeds: dict[bytes, np.ndarray] = {}
        self.averaged = None  # the averaged model's fit of the last map_search (a drag preview), if any
        #: Starts (natural values) from the record's own backbone and damping curves
        #: (:func:`beam.calibration.slowflow.curve_starts`), set by the calibration before its
        #: search: the averaged model searches from the best of them before judging it.
        self.curve_starts: list[dict[str, float]] = []

    # ------------------------------------------------------------------ the response
    def _one(self, values: Mapping[str, np.ndarray], i: int) -> dict[str, float]:
        """Parameter set ``i`` of ``values`` (scalars broadcast)."""
        return {name: float(np.atleast_1d(values[name])[i if np.size(values[name]) > 1 else 0]) for name in self.names}

    def state_matrix(self, one: Mapping[str, float]) -> np.ndarray:
        """T (2m, 2m): the modal state (eta, eta') whose free response is ``basis @ a`` is T a."""
        m = self.modes
        columns = []
        for j in range(2 * m):
            unit = np.zeros(2 * m)
            unit[j] = 1.0
            eta, rate = self.model.free_state_from_amplitudes(one, unit, m, output=self.output_kind)
            columns.append(np.concatenate([eta, rate]))
        return np.array(columns).T

    def response(self, values: Mapping[str, np.ndarray], states: np.ndarray, time_s: np.ndarray) -> np.ndarray:
        """Nonlinear free responses (B, n) from modal states (B, 2m) at ``time_s`` (s, increasing,
        at or after the reference time), without the offset."""
        m = self.modes
        t = np.asarray(time_s, dtype=float)
        prepend = t[0] > self.reference_s
        grid = np.concatenate([[self.reference_s], t]) if prepend else t
        if grid[0] < self.reference_s - 1e-12:
            raise BeamInputError("a nonlinear free decay is predicted forward from the first calibration sample only")
        out = self.model.free_response(values, grid, states[:, :m], states[:, m:], m, output=self.output_kind)
        out = np.atleast_2d(out)
        return out[:, 1:] if prepend else out

    # ------------------------------------------------------------------ the inner solve
    def _inner(self, one: Mapping[str, float], start: np.ndarray, rho: float | None) -> dict[str, np.ndarray]:
        """Gauss–Newton for the amplitudes and offset (k,) of one parameter set from ``start``."""
        m, k = self.modes, self.columns
        transform = self.state_matrix(one)
        a = np.array(start, dtype=float)
        y = self.fit_data
        batch = {name: np.full(1 + 2 * m, value) for name, value in one.items()}
        for iteration in range(INNER_ITERATIONS):
            state = transform @ a[: 2 * m]
            step = STATE_STEP * max(float(np.max(np.abs(state))), 1e-300)
            states = np.tile(state, (1 + 2 * m, 1)) + np.vstack([np.zeros(2 * m), step * np.eye(2 * m)])
            f = self.response(batch, states, self.fit_time_s)
            rows = ((f[1:] - f[0]) / step).T @ transform  # (n, 2m): d f / d a
            rows = rows.T
            if self.offset:
                rows = np.vstack([rows, np.ones(y.size)])
            offset = a[-1] if self.offset else 0.0
            residual = y - f[0] - offset
            if rho is not None:
                rows_w = self._whiten(rows, np.full(k, rho))
                residual_w = self._whiten(residual[None, :], np.array([rho]))[0]
            else:
                rows_w, residual_w = rows, residual
            delta, *_ = np.linalg.lstsq(rows_w.T, residual_w, rcond=None)
            gain = float(np.sum((delta @ rows_w) ** 2))  # the decrease of the RSS the step predicts
            done = gain <= INNER_TOLERANCE * float(np.sum(residual_w**2))
            if done or iteration == INNER_ITERATIONS - 1:
                break
            a = a + delta
        gram = rows_w @ rows_w.T
        return {"amplitudes": a, "fitted": f[0] + offset, "gram": gram, "c": gram @ a, "state": state}

    def fit(self, values: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """As :meth:`ProjectedFreeModel.fit`, the amplitudes refined on the nonlinear response
        where a nonlinear parameter is on (cached for the last call); adds ``states`` (B, 2m)."""
        key, rho = self._key(values)
        if self._nl_cache is not None and self._nl_cache[0] == key:
            return self._nl_cache[1]
        linear = dict(super().fit(values))
        batch = linear["amplitudes"].shape[0]
        states = np.zeros((batch, 2 * self.modes))
        amplitudes, fitted = linear["amplitudes"].copy(), linear["fitted"].copy()
        gram, c = linear["gram"].copy(), linear["c"].copy()
        solved: dict[bytes, dict[str, np.ndarray]] = {}  # sets that differ only in the noise: one inner solve
        for i in range(batch):
            one = self._one(values, i)
            if all(one[name] <= 0.0 for name in self.nonlinear_names):
                states[i] = self.state_matrix(one) @ amplitudes[i, : 2 * self.modes]
                continue
            set_key = self._set_key(values, i)
            if set_key not in solved:
                start = self._seeds.get(set_key, amplitudes[i])
                solved[set_key] = self._inner(one, start, None if rho is None else float(rho[i]))
            inner = solved[set_key]
            amplitudes[i], fitted[i], gram[i], c[i], states[i] = (inner[n] for n in ("amplitudes", "fitted", "gram",
                                                                                      "c", "state"))
        result = {"poles": linear["poles"], "amplitudes": amplitudes, "fitted": fitted, "gram": gram, "c": c,
                  "certified": np.zeros(batch, dtype=bool), "states": states}
        self._nl_cache = (key, result)
        return result

    def __call__(self, values: Mapping[str, np.ndarray], time_s: np.ndarray) -> np.ndarray:
        fit = self.fit(values)
        times = np.asarray(time_s, dtype=float)
        if times is self.fit_time_s or (times.shape == self.fit_time_s.shape and np.array_equal(times, self.fit_time_s)):
            return fit["fitted"]
        batch = fit["states"].shape[0]
        out = np.full((batch, times.size), np.nan)  # before the first calibration sample: not predicted
        after = times >= self.reference_s - 1e-12
        if np.count_nonzero(after) == 0:
            return out
        for i in range(batch):
            one = {name: np.array([v]) for name, v in self._one(values, i).items()}
            offset = fit["amplitudes"][i, -1] if self.offset else 0.0
            out[i, after] = self.response(one, fit["states"][i : i + 1], times[after])[0] + offset
        return out

    # ------------------------------------------------------------------ the joint search
    def _joint_values(self, problem: Problem, x: np.ndarray, d: int) -> dict[str, np.ndarray]:
        physical = [n for n in problem.names if n not in problem.noise_names]
        return {name: np.atleast_1d(problem.parameter(name).prior.from_internal(x[..., i])) for i, name in enumerate(physical[:d])}

    def whitened(self, rows: np.ndarray, rho: float | None) -> np.ndarray:
        """Residual rows (n_rows, samples) whitened by the AR(1) coefficient ``rho`` (None: i.i.d.,
        returned as they are)."""
        return rows if rho is None else self._whiten(rows, np.full(rows.shape[0], rho))

    def map_search(self, problem: Problem, guesses: Sequence[Mapping[str, float]]) -> MapResult:
        """MAP of ``problem`` (whose model is this one) from ``guesses`` by the joint least squares
        of the module notes.

        The guesses are screened by the residual of the nonlinear response from the linear
        profile's amplitudes (one batched integration); each guess at its nulls adds its
        equivalent starts (:meth:`equivalent_starts`), which keep its initial modal state and are
        screened by their refined profile (the inner solve). The joint least squares runs from
        the best. A guess with every nonlinear parameter at its null value (the nested start: a
        sub-model's optimum) is evaluated exactly and kept when the search ends lower, so the
        MAP is never below it (nested fits are monotone).

        Parameters
        ----------
        problem : Problem
            The calibration problem of this model.
        guesses : sequence of mapping
            Starting points in natural units (physical parameters).

        Returns
        -------
        MapResult
            With the Laplace Hessian over the problem's internal coordinates (see the module notes).
        """
        from beam.calibration.fit import internal_starts
        from beam.calibration.nulls import null_value

        physical = [n for n in problem.names if n not in problem.noise_names]
        d, k = len(physical), self.columns
        lo, hi = problem.internal_bounds
        margin = 1e-9 * np.maximum(hi - lo, 1e-300)
        starts = internal_starts(problem, list(guesses))
        values = problem.from_internal(starts)
        # a start at its nulls (within the clipping margin of internal_starts): a sub-model's optimum
        null_z = {n: (problem.names.index(n), float(problem.parameter(n).prior.to_internal(null_value(problem, n))),
                      2e-6 * problem.parameter(n).prior.internal_scale) for n in self.nonlinear_names}
        # the nonlinear parameters each start holds at their nulls: a start with any is a sub-model's optimum
        off = [{n for n, (j, z, within) in null_z.items() if abs(starts[i, j] - z) <= within} for i in range(len(starts))]
        nulls = [i for i in range(len(starts)) if off[i]]
        sources, derived = [], []
        for i in nulls:
            sub = {n: float(values[n][i]) for n in values if n in self.names or n == AR1_COEFFICIENT}
            more = self.equivalent_starts(sub, [e for e in self.model.effects if EFFECTS[e].channel is not None
                                                and EFFECTS[e].channel.switch in off[i]])
            sources += [i] * len(more)
            derived += more
        if derived:
            starts = np.vstack([starts, internal_starts(problem, derived)])
            values = problem.from_internal(starts)
        report(f"nonlinear MAP search: screening {len(starts)} starts")
        linear = ProjectedFreeModel.fit(self, values)
        amplitudes = linear["amplitudes"].copy()
        m2 = 2 * self.modes
        ar1 = AR1_COEFFICIENT in values
        for i in sorted(set(sources)):
            if len(off[i]) < len(self.nonlinear_names):  # a nonlinear sub-model: its state refined on its own response
                amplitudes[i] = self._inner(self._one(values, i), amplitudes[i], float(values[AR1_COEFFICIENT][i]) if ar1
                                            else (0.0 if self.likelihood == "ar1" else None))["amplitudes"]
        for row, source in enumerate(sources, start=len(starts) - len(sources)):
            # an equivalent start keeps its sub-model's initial modal state (the same swing at the
            # window's start), not the linear profile at its lowered damping
            state = self.state_matrix(self._one(values, source)) @ amplitudes[source, :m2]
            amplitudes[row, :m2] = np.linalg.solve(self.state_matrix(self._one(values, row)), state)
            amplitudes[row, m2:] = amplitudes[source, m2:]
        screen = self._record_response(problem, np.concatenate([starts[:, :d], amplitudes], axis=1), d,
                                      self.fit_time_s)
        with np.errstate(all="ignore"):
            rss = np.sum((self.fit_data - screen) ** 2, axis=1)
        rss[~np.isfinite(rss)] = np.inf
        averaged = self._averaged_start(problem, starts, amplitudes, rss, nulls)
        derived_rows = np.arange(len(starts) - len(sources), len(starts))
        derived_rows = derived_rows[np.argsort(rss[derived_rows], kind="stable")][:REFINED_STARTS]
        # the averaged model's MAP replaces the equivalent starts only where it beats the nested
        # start on the full response (a first-order form can end where it does not hold: a joint
        # wholly slipping, whose softening is no longer small)
        useful = averaged is not None and averaged[2] < float(np.min(rss[list(nulls)]))
        for row in () if useful else derived_rows:
            # an equivalent start's amplitudes refined on its own response (its swing is the
            # sub-model's, its decay is not): screened by its profile, as the nested start is
            # (not needed with a useful averaged MAP, a start of the same kind, refined further)
            refined = self._inner(self._one(values, row), amplitudes[row], float(values[AR1_COEFFICIENT][row]) if ar1
                                  else (0.0 if self.likelihood == "ar1" else None))
            amplitudes[row] = refined["amplitudes"]
            rss[row] = float(np.sum((self.fit_data - refined["fitted"]) ** 2))
        if averaged is not None:  # the averaged model's MAP, its amplitudes refined on the full response
            starts, amplitudes, rss = (np.vstack([starts, averaged[0]]), np.vstack([amplitudes, averaged[1]]),
                                       np.append(rss, averaged[2]))
            values = problem.from_internal(starts)
        best = int(np.argmin(rss))
        quadratic = [problem.parameter(n).prior.internal_quadratic() for n in physical]
        lower = np.concatenate([lo[:d] + margin[:d], np.full(k, -np.inf)])
        upper = np.concatenate([hi[:d] - margin[:d], np.full(k, np.inf)])
        # the joint least squares from the best-screened start, and from the averaged model's MAP
        # when that is another: a start in the effect's basin can screen worse than the nested
        # one (its first-order frequencies a few 1e-5 off, which the waveform's phase over a
        # window of hundreds of cycles punishes), and only the search tells (module notes)
        rows = [best] + ([len(starts) - 1] if averaged is not None and best != len(starts) - 1 else [])
        ends = [self._joint_search(problem, starts, amplitudes, rss, values, row, d, k, quadratic, lower, upper, lo, hi)
                for row in rows]
        found, solution, settled_at = max(ends, key=lambda end: end[3])[:3]
        self._seed(problem.from_internal(found), solution.x[d:])  # the inner solve starts where the search ended
        candidates = [self._noise_at(problem, found)] + [self._noise_at(problem, starts[i]) for i in nulls]
        scores = [float(problem.log_posterior(z)[0]) for z in candidates]
        chosen = int(np.argmax(scores))
        best_z, best_lp = candidates[chosen], scores[chosen]
        report("the Laplace approximation's Hessian at the MAP")
        hessian = self._laplace_hessian(problem, best_z, d, quadratic)
        values = {n: float(v[0]) for n, v in problem.from_internal(best_z).items()}
        scale = np.array([p.prior.internal_scale for p in problem.parameters])
        at_bound = tuple(n for i, n in enumerate(problem.names)
                         if best_z[i] <= lo[i] + 1e-6 * scale[i] or best_z[i] >= hi[i] - 1e-6 * scale[i])
        message = ("joint least squares of the nonlinear free decay" if chosen == 0 else
                   "the nested start (a sub-model's optimum) kept: the joint least squares ended lower")
        return MapResult(z=best_z, values=values, log_posterior=best_lp, gradient=np.zeros(problem.ndim),
                         hessian=hessian, hessian_point=best_z.copy(), converged=bool(solution.status > 0 or settled_at),
                         message=message, n_starts=len(starts), start_log_posteriors=scores,
                         at_bound=at_bound, n_iterations=int(solution.nfev))

    def _joint_search(self, problem: Problem, starts: np.ndarray, amplitudes: np.ndarray, rss: np.ndarray, values,
                      best: int, d: int, k: int, quadratic, lower: np.ndarray, upper: np.ndarray, lo: np.ndarray,
                      hi: np.ndarray):
        """The joint least squares of :meth:`map_search` from row ``best`` of ``starts``: (its end
        as an internal point, scipy's solution, whether it stopped settled, its log posterior)."""
        from scipy import optimize

        ar1 = AR1_COEFFICIENT in values
        rho = (float(values[AR1_COEFFICIENT][best]) if ar1 and np.isfinite(values[AR1_COEFFICIENT][best])
               else (0.0 if self.likelihood == "ar1" else None))
        y = self.fit_data
        sd = max(math.sqrt(rss[best] / y.size), 1e-300) if np.isfinite(rss[best]) else 1.0
        x0 = np.concatenate([starts[best, :d], amplitudes[best]])

        integrations = [0]

        def residuals(x):
            integrations[0] += 1
            report(f"nonlinear MAP search from start {best}: integration {integrations[0]}")
            f = self._record_response(problem, x[None, :], d, self.fit_time_s)[0]
            data = self.whitened((y - f)[None, :], rho)[0] / sd
            return np.concatenate([data, self.prior_residuals(x[:d], quadratic)])

        last: dict[str, np.ndarray] = {}

        def jacobian(x):
            report(f"nonlinear MAP search from start {best}: Jacobian after {integrations[0]} integrations")
            data = -self.whitened(self._joint_columns(problem, x, d, self.fit_time_s)[1], rho) / sd
            prior = np.zeros((d, x.size))
            for j, (_, _, sigma) in enumerate(quadratic):
                if math.isfinite(sigma):
                    prior[j, j] = 1.0 / sigma
            last["x"], last["J"] = x.copy(), np.vstack([data.T, prior])
            return last["J"]

        tolerance = JOINT_BOUND_FRACTION * np.concatenate([(hi - lo)[:d], np.full(k, np.inf)])
        settled = {"at": False}

        def stop_when_settled(intermediate_result):
            # the Gauss–Newton step at the accepted point, the coordinates held at a bound left out
            if "x" not in last or not np.array_equal(intermediate_result.x, last["x"]):
                return
            jac, r = last["J"], intermediate_result.fun
            gradient = jac.T @ r
            x = intermediate_result.x
            held = (((x - lower) < tolerance) & (gradient > 0)) | (((upper - x) < tolerance) & (gradient < 0))
            step, *_ = np.linalg.lstsq(jac[:, ~held], -r, rcond=None)
            noise_ratio = math.sqrt(y.size / max(float(np.sum(r[: y.size] ** 2)), 1e-300))  # sd of the start / now
            if float(np.linalg.norm(jac[:, ~held] @ step)) * noise_ratio < JOINT_STOP_SD:
                settled["at"] = True
                raise StopIteration

        solution = optimize.least_squares(residuals, np.clip(x0, lower, upper), jac=jacobian, bounds=(lower, upper),
                                          x_scale="jac", method="trf", callback=stop_when_settled,
                                          max_nfev=JOINT_MAX_NFEV_PER_UNKNOWN * x0.size)
        found = np.concatenate([solution.x[:d], starts[best, d:]])
        self._seed(problem.from_internal(found), solution.x[d:])
        return found, solution, settled["at"], float(problem.log_posterior(self._noise_at(problem, found))[0])

    def _averaged_start(self, problem: Problem, starts: np.ndarray, amplitudes: np.ndarray, rss: np.ndarray,
                        nulls: Sequence[int]) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The start from the averaged model (:class:`beam.calibration.free_averaged.AveragedDragModel`):
        its MAP from the best-screened nested start (and from the best of :attr:`curve_starts`,
        the better end kept), as an internal point (ndim,), its amplitudes refined by the
        inner solve on the full response (k,) and their residual sum of squares; None without a
        nested start or with a nonlinear effect that has no averaged form. Kept as
        :attr:`averaged` (the preview of the averaged model)."""
        from beam.calibration.fit import internal_starts
        from beam.calibration.free_averaged import AveragedDragModel

        self.averaged = None
        nonlinear = [e for e in self.model.effects if EFFECTS[e].nonlinear]
        if not nulls or any(EFFECTS[e].averaged is None for e in nonlinear):
            return None
        source = min(nulls, key=lambda i: rss[i])
        values = problem.from_internal(starts[source : source + 1])
        one = {n: float(v[0]) for n, v in values.items()}
        try:
            fit = AveragedDragModel(self).fit(problem, one, amplitudes[source], also=self.curve_starts)
        except (BeamInputError, np.linalg.LinAlgError):
            return None
        self.averaged = fit
        point = starts[source].copy()
        point[: len(fit.internal)] = internal_starts(problem, [fit.values])[0][: len(fit.internal)]
        rho = (float(values[AR1_COEFFICIENT][0]) if AR1_COEFFICIENT in values
               else (0.0 if self.likelihood == "ar1" else None))
        refined = self._inner({n: fit.values.get(n, one[n]) for n in self.names}, fit.amplitudes, rho)
        return point, refined["amplitudes"], float(np.sum((self.fit_data - refined["fitted"]) ** 2))

    def equivalent_starts(self, one: Mapping[str, float], effects: Sequence[str] | None = None) -> list[dict[str, float]]:
        """Starts with nonlinear effects on, from a sub-model's optimum ``one`` (natural units, the
        effects at their null values): each effect's own (its
        :attr:`~beam.physics.effects.effect.StartHints.free_decay` hint: the drag's slow-flow
        equivalent damping, :func:`beam.physics.effects.quadratic_drag.equivalent_starts`; the
        friction's grid of joints, :func:`beam.physics.effects.clamp_friction.friction_starts`)
        from the sub-model's initial modal state at the window's start (its linear profile),
        in catalogue order.

        Parameters
        ----------
        one : mapping
            The sub-model's optimum (the effects' parameters at their nulls).
        effects : sequence of str, optional
            Whose hints; default every nonlinear effect of the model.

        Returns
        -------
        list of dict
            Natural-unit starts; empty when no effect has a hint that applies.
        """
        wanted = [e for e in self.model.effects if EFFECTS[e].nonlinear] if effects is None else effects
        hints = [EFFECTS[e].hints.free_decay for e in self.model.effects if e in set(wanted)]
        hints = [hint for hint in hints if hint is not None]
        if not hints:
            return []
        m = self.modes
        amplitudes = ProjectedFreeModel.fit(self, {n: np.array([v]) for n, v in one.items()})["amplitudes"][0]
        state = self.state_matrix({n: one[n] for n in self.names}) @ amplitudes[: 2 * m]
        duration = float(self.fit_time_s[-1] - self.reference_s)
        return [start for hint in hints for start in hint(self.model, dict(one), state, duration)]

    def _joint_columns(self, problem: Problem, x: np.ndarray, d: int, time_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The response at a joint point ``x`` (internal theta, amplitudes, offset) at ``time_s``
        (n,) and its derivative (d + k, n) by forward differences (one batched integration of
        1 + d + 2m sets; the offset's row exact)."""
        m2 = 2 * self.modes
        steps = np.concatenate([np.full(d, 1e-6), np.full(m2, STATE_STEP * max(float(np.max(np.abs(x[d:d + m2]))),
                                                                             1e-300))])
        points = np.tile(x, (1 + d + m2, 1))
        for j in range(d + m2):
            points[1 + j, j] += steps[j]
        f = self._record_response(problem, points, d, time_s)
        columns = (f[1:] - f[0]) / steps[:, None]
        if self.offset:
            columns = np.vstack([columns, np.ones(f.shape[1])])
        return f[0], columns

    def _seed(self, values: Mapping[str, np.ndarray], amplitudes: np.ndarray) -> None:
        """Start the inner solve of the parameter set ``values`` (one) at ``amplitudes`` (it
        converges to the same optimum as from the linear profile, in fewer iterations)."""
        self._seeds[self._set_key(values, 0)] = np.array(amplitudes, dtype=float)

    def _set_key(self, values: Mapping[str, np.ndarray], i: int) -> bytes:
        one = self._one(values, i)
        rho = (float(np.atleast_1d(values[AR1_COEFFICIENT])[i if np.size(values[AR1_COEFFICIENT]) > 1 else 0])
               if self.likelihood == "ar1" else 0.0)
        return np.array([one[n] for n in self.names] + [rho]).tobytes()

    @staticmethod
    def prior_residuals(z: np.ndarray, quadratic) -> np.ndarray:
        """The priors as residuals, (z − mu) / sigma per internal coordinate (0 where a prior
        has no quadratic form); ``quadratic`` from each prior's ``internal_quadratic()``."""
        return np.array([(z[j] - mu) / sigma if math.isfinite(sigma) else 0.0
                         for j, (_, mu, sigma) in enumerate(quadratic)])

    def _complete(self, problem: Problem, guess: Mapping[str, float]) -> np.ndarray:
        """Internal point of a guess (physical parameters; the noise at its conditional optimum)."""
        from beam.calibration.fit import internal_starts

        return self._noise_at(problem, internal_starts(problem, [guess])[0])

    def _noise_at(self, problem: Problem, z: np.ndarray) -> np.ndarray:
        """``z`` with its noise coordinates at their maximum of the log posterior, the physical
        ones fixed (one inner fit: the noise does not enter it, and it is cached)."""
        from scipy import optimize

        z = np.array(z, dtype=float)
        lo, hi = problem.internal_bounds
        for name in problem.noise_names:
            i = problem.names.index(name)

            def negative(v, i=i):
                point = z.copy()
                point[i] = v
                value = problem.log_posterior(point)[0]
                return -value if np.isfinite(value) else 1e300

            if np.isfinite(lo[i]) and np.isfinite(hi[i]):
                span = hi[i] - lo[i]
                bounds = (lo[i] + 1e-9 * span, hi[i] - 1e-9 * span)
            else:  # an unbounded coordinate (the AR(1) coefficient's logit): searched around its start
                reach = UNBOUNDED_NOISE_REACH * problem.parameter(name).prior.internal_scale
                bounds = (max(lo[i], z[i] - reach), min(hi[i], z[i] + reach))
            found = optimize.minimize_scalar(negative, bounds=bounds, method="bounded", options={"xatol": 1e-7})
            z[i] = float(found.x)
        return z

    def _laplace_hessian(self, problem: Problem, z: np.ndarray, d: int, quadratic) -> np.ndarray:
        """Hessian of the log posterior (ndim, ndim) at ``z``: the physical block from the joint
        Gauss–Newton matrix with the amplitudes and offset eliminated (Schur complement, their
        prior N(0, A²) included), the noise block by central differences of the profile at
        fixed physical parameters, no cross terms (zero at the noise's conditional optimum to
        first order)."""
        values = problem.from_internal(z)
        fit = self.fit(values)
        sd = float(np.atleast_1d(values[NOISE_SD])[0])
        rho = float(np.atleast_1d(values[AR1_COEFFICIENT])[0]) if AR1_COEFFICIENT in values else None
        _, columns = self._joint_columns(problem, np.concatenate([z[:d], fit["amplitudes"][0]]), d, self.fit_time_s)
        white = self.whitened(columns, rho) / sd
        info = white @ white.T
        for j, (_, _, sigma) in enumerate(quadratic):
            if math.isfinite(sigma):
                info[j, j] += 1.0 / sigma**2
        info[d:, d:] += np.eye(info.shape[0] - d) / self.prior_sd**2
        schur = info[:d, :d] - info[:d, d:] @ np.linalg.solve(info[d:, d:], info[d:, :d])
        hessian = np.zeros((problem.ndim, problem.ndim))
        hessian[:d, :d] = -schur
        for name in problem.noise_names:
            i = problem.names.index(name)
            h = 1e-4 * problem.parameters[i].prior.internal_scale
            points = np.tile(z, (3, 1))
            points[1, i] += h
            points[2, i] -= h
            lp = problem.log_posterior(points)
            hessian[i, i] = (lp[1] - 2 * lp[0] + lp[2]) / h**2
        return hessian

    # ------------------------------------------------------------------ bands
    def linearised_bands(self, laplace_result, time_s: np.ndarray, level: float = 0.95) -> PredictiveBands:
        """Predictive bands at ``time_s`` (s, from the first calibration sample on) by the delta
        method: the MAP response, its sd from the Laplace covariance of the physical parameters
        through the response's derivative with the amplitudes and offset re-fitted (d a / d theta
        from the window's Gauss–Newton normal equations); the prediction band adds the noise sd."""
        from scipy import stats

        problem = laplace_result.problem
        z = laplace_result.mean
        physical = [n for n in problem.names if n not in problem.noise_names]
        d = len(physical)
        values = problem.from_internal(z)
        fit = self.fit(values)
        x = np.concatenate([z[:d], fit["amplitudes"][0]])
        times = np.asarray(time_s, dtype=float)
        mean, record_columns = self._joint_columns(problem, x, d, times)
        where = np.clip(np.searchsorted(times, self.fit_time_s), 0, times.size - 1)
        if np.array_equal(times[where], self.fit_time_s):  # the window's samples are among the band's times
            window_columns = record_columns[:, where]
        else:
            _, window_columns = self._joint_columns(problem, x, d, self.fit_time_s)
        theta_w, nuisance_w = window_columns[:d], window_columns[d:]
        sensitivity, *_ = np.linalg.lstsq(nuisance_w.T, theta_w.T, rcond=None)  # d a / d theta = -sensitivity
        derivative = record_columns[:d] - sensitivity.T @ record_columns[d:]
        cov = laplace_result.cov[:d, :d]
        model_sd = np.sqrt(np.maximum(np.einsum("it,ij,jt->t", derivative, cov, derivative), 0.0))
        noise_sd = float(np.atleast_1d(values[NOISE_SD])[0])
        quantile = float(stats.norm.ppf(0.5 + 0.5 * level))
        spread = np.sqrt(model_sd**2 + noise_sd**2)
        return PredictiveBands(time_s=times, mean=mean, credible_lower=mean - quantile * model_sd,
                               credible_upper=mean + quantile * model_sd, prediction_lower=mean - quantile * spread,
                               prediction_upper=mean + quantile * spread, level=float(level), n_draws=0)

    def _record_response(self, problem: Problem, points: np.ndarray, d: int, time_s: np.ndarray) -> np.ndarray:
        """f(theta, a) + offset (P, n) at ``time_s`` of joint points (P, d + k) (internal theta,
        amplitudes, offset), one batched integration."""
        m = self.modes
        values = self._joint_values(problem, points, d)
        states = np.empty((points.shape[0], 2 * m))
        transforms: dict[bytes, np.ndarray] = {}  # the points of a Jacobian share their theta along the state
        for i in range(points.shape[0]):
            key = points[i, :d].tobytes()
            if key not in transforms:
                transforms[key] = self.state_matrix({name: float(v[i]) for name, v in values.items()})
            states[i] = transforms[key] @ points[i, d : d + 2 * m]
        out = self.response(values, states, time_s)
        return out + points[:, -1:] if self.offset else out
