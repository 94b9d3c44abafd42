"""Joint calibration of several records of one beam: one set of physical parameters for all.

Records of the same strip at several free lengths, with the sensor at several positions, plucked
and driven, each with its own sidecar (geometry, sensor position, input), are calibrated together:

- the **physical parameters** of the model (EI, the effects' parameters: masses, clamp stiffness,
  damping, drag) are shared by default: one value explains every record;
- **per record**: the noise parameters (``noise_sd``; ``ar1_coefficient``), the free response's
  initial state and the sensor's offset (profiled/marginalised by each record's own
  :class:`~beam.calibration.free.ProjectedFreeModel`, as in a single calibration), and the
  physical parameters named in ``per_record`` (e.g. ``clamp_stiffness_Nm_rad`` when the strip
  was re-clamped between the records).

The joint log posterior is the sum of the records' log likelihoods, each on its own window
(each record's prepared :class:`~beam.inference.Problem`, built by
:func:`beam.calibration.run.prepare` exactly as for a single calibration, is evaluated as it is),
plus **one** log prior over the joint parameters. A shared parameter takes the prior of the first
record that has it. A joint calibration of one record is therefore the single calibration: same
log posterior at every point, same MAP (to the optimiser's precision), same Laplace evidence.

Per-record parameters are named ``NAME@K`` in the joint problem (``K`` the record's position,
from 0); :meth:`JointCalibrationResult.record_results` gives each record's
:class:`~beam.calibration.run.CalibrationResult` under its own names (its predictive bands, RMSE
and coverage from the joint posterior's draws).

A joint calibration runs the one pipeline (:mod:`beam.calibration.pipeline`) with its own
calibration model, :class:`JointModel`: each record's single preview first (the pipeline itself,
:func:`~beam.calibration.pipeline.preview_map`, the engine's two-stage search; remembered by the
:class:`~beam.calibration.engine.Engine` like every single calibration), whose MAPs are its
starts; its search combines them into joint starting points, then climbs the joint log posterior
by the Newton iteration of every calibration (:func:`beam.calibration.fit.newton_polish`), whose
final Hessian is the one the Laplace approximation uses; its posterior is emcee, sampled as every
calibration's (:func:`~beam.calibration.pipeline.sample_posterior`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from beam.calibration.engine import Engine, default_engine
from beam.calibration.pipeline import BAND_DRAWS, CalibrationModel, preview_map, record_bands, sample_posterior
from beam.calibration.run import CalibrationResult
from beam.calibration.setup import BeamCalibrationSetup
from beam.calibration.spec import CalibrationSpec
from beam.errors import BeamInputError
from beam.inference import LIKELIHOODS, LaplaceResult, MapResult, Parameter, PosteriorResult, Problem, laplace
from beam.inference.likelihood import log_likelihood
from beam.inference.progress import report, reporting
from beam.io.artifacts import record_warnings
from beam.physics import modal
from beam.physics.effects import EFFECTS

__all__ = [
    "JointCalibrationResult",
    "JointModel",
    "JointProblem",
    "joint_calibrate",
    "joint_name",
    "joint_preview",
    "resolve_per_record",
]

#: Separator of a per-record parameter's joint name: ``noise_sd@2`` is record 2's noise sd.
SEPARATOR = "@"
#: Newton iterations of the joint MAP search from each start.
JOINT_NEWTON_ITERATIONS = 60
#: Joint starts fitted in the time domain and polished by Newton (the best by their log posterior
#: after the modal match; the others are dropped).
JOINT_POLISHED_STARTS = 2


def joint_name(name: str, record: int) -> str:
    """The joint problem's name of record ``record``'s own parameter ``name`` (``noise_sd@0``)."""
    return f"{name}{SEPARATOR}{int(record)}"


def resolve_per_record(names: Iterable[str] | str | None, physical: Sequence[str],
                       shared: Iterable[str] | str | None = None) -> tuple[str, ...]:
    """The physical parameters calibrated per record, in ``physical``'s order.

    Parameters
    ----------
    names : iterable of str or comma-separated str, optional
        Parameters to calibrate per record: a parameter name (``clamp_stiffness_Nm_rad``), the
        unambiguous start of one (``clamp_stiffness``) or an effect's name (``clamp_compliance``:
        all its parameters).
    physical : sequence of str
        The model's physical parameters (the union over the records).
    shared : iterable of str or comma-separated str, optional
        When given, only these are shared: every other physical parameter is per record.

    Raises
    ------
    BeamInputError
        A name that is no parameter of the model, or one both shared and per record.
    """
    per = _match_names(names, physical)
    if shared is None:
        return tuple(n for n in physical if n in per)
    kept = _match_names(shared, physical)
    both = sorted(per & kept)
    if both:
        raise BeamInputError(f"{both[0]} is both shared and per record")
    return tuple(n for n in physical if n in per or n not in kept)


def _match_names(names: Iterable[str] | str | None, physical: Sequence[str]) -> set[str]:
    if names is None:
        return set()
    if isinstance(names, str):
        names = [n for n in (part.strip() for part in names.split(",")) if n]
    out: set[str] = set()
    for name in names:
        if name in physical:
            out.add(name)
            continue
        if name in EFFECTS:
            found = [p.name for p in EFFECTS[name].parameters if p.name in physical]
        else:
            found = [n for n in physical if n.startswith(name)]
        if len(found) != 1 and not (found and name in EFFECTS):
            known = ", ".join(physical)
            why = "is ambiguous" if found else "is not a parameter of the model"
            raise BeamInputError(f"{name!r} {why} (the model's parameters: {known})")
        out.update(found)
    return out


class JointProblem(Problem):
    """The joint posterior of several records' problems (a :class:`~beam.inference.Problem`).

    Parameters
    ----------
    problems : sequence of Problem
        Each record's prepared problem (:func:`beam.calibration.run.prepare`), all with the same
        likelihood kind.
    per_record : sequence of str
        Physical parameters calibrated per record (the others are shared).
    setups : sequence of BeamCalibrationSetup, optional
        Each record's setup (its model, modes, geometry), which the joint MAP search reads
        (:func:`modal_match`); required there.

    Notes
    -----
    ``log_posterior(z)`` = joint log prior(z) + sum over records of the record's log likelihood
    (profiled free-response correction included) at its parameters taken from ``z``. The data
    and time grid of the :class:`Problem` are the records' calibration data one after another
    (what :meth:`predict` and :meth:`residuals` return, and what a saved posterior stores).
    """

    def __init__(self, problems: Sequence[Problem], per_record: Sequence[str] = (),
                 setups: Sequence[BeamCalibrationSetup] | None = None) -> None:
        problems = tuple(problems)
        self.setups = None if setups is None else tuple(setups)
        if not problems:
            raise BeamInputError("a joint calibration needs at least one record")
        likelihoods = {p.likelihood for p in problems}
        if len(likelihoods) != 1:
            raise BeamInputError("the records of a joint calibration must share their likelihood kind")
        self.problems = problems
        self.per_record = tuple(per_record)
        likelihood = problems[0].likelihood
        self._noise = LIKELIHOODS[likelihood]
        parameters: list[Parameter] = []
        seen: set[str] = set()
        for problem in problems:  # shared physical parameters: the first record's prior
            for p in problem.parameters:
                if p.name in self._noise or p.name in self.per_record or p.name in seen:
                    continue
                seen.add(p.name)
                parameters.append(p)
        for k, problem in enumerate(problems):
            for p in problem.parameters:
                if p.name in self._noise or p.name in self.per_record:
                    parameters.append(replace(p, name=joint_name(p.name, k)))
        self._maps = [{name: (joint_name(name, k) if name in self._noise or name in self.per_record else name)
                       for name in problem.names} for k, problem in enumerate(problems)]
        self._offsets = np.cumsum([0] + [p.data.size for p in problems])
        super().__init__(
            parameters=parameters, model=self._joint_model, time_s=np.concatenate([p.time_s for p in problems]),
            data=np.concatenate([p.data for p in problems]), likelihood=likelihood,
            fixed={name: 1.0 for name in self._noise},  # per record instead: dropped just below
            name="joint:" + ",".join(p.name.removeprefix("beam:") for p in problems),
            data_unit=problems[0].data_unit,
        )
        self.fixed = {}  # the noise parameters are per record (NAME@K), never fixed

    # -- names ------------------------------------------------------------------------------------
    @property
    def noise_names(self) -> tuple[str, ...]:
        """The per-record noise parameters (``noise_sd@K``, ...)."""
        return tuple(joint_name(n, k) for k in range(len(self.problems)) for n in self._noise)

    def record_names(self, record: int) -> dict[str, str]:
        """``{record's own name: joint name}`` of every parameter of record ``record``'s problem."""
        return dict(self._maps[record])

    def record_values(self, values: Mapping[str, np.ndarray], record: int) -> dict[str, np.ndarray]:
        """Record ``record``'s parameter values, under its own names, out of joint ``values``."""
        problem = self.problems[record]
        out = {name: values[joint] for name, joint in self._maps[record].items()}
        batch = np.atleast_1d(next(iter(out.values()))).shape[0]
        for name, v in problem.fixed.items():
            out.setdefault(name, np.full(batch, v))
        return out

    def joint_values(self, values: Sequence[Mapping[str, float]]) -> dict[str, float]:
        """Joint natural values from each record's values (a shared parameter from the first record
        that has it)."""
        out: dict[str, float] = {}
        for k, record in enumerate(values):
            for name, joint in self._maps[k].items():
                if name in record and (joint not in out):
                    out[joint] = float(record[name])
        return out

    # -- densities --------------------------------------------------------------------------------
    def _joint_model(self, values: Mapping[str, np.ndarray], time_s: np.ndarray) -> np.ndarray:
        """Each record's prediction on its calibration grid, one after another (only on
        :attr:`time_s`: the records' grids are not one time axis)."""
        if time_s is not self.time_s and not np.array_equal(time_s, self.time_s):
            raise ValueError("a joint problem predicts on its records' calibration grids only")
        return np.concatenate([problem.model(self.record_values(values, k), problem.time_s)
                               for k, problem in enumerate(self.problems)], axis=1)

    def record_log_likelihoods(self, values: Mapping[str, np.ndarray]) -> np.ndarray:
        """Log likelihood of each record at joint natural ``values``, shape (records, B)."""
        rows = []
        for k, problem in enumerate(self.problems):
            own = self.record_values(values, k)
            prediction = np.asarray(problem.model(own, problem.time_s), dtype=float)
            problem.n_model_rows += prediction.shape[0]
            correction = problem.likelihood_correction
            ll = log_likelihood(problem.likelihood, problem.data - prediction, own)
            rows.append(ll + (0.0 if correction is None else np.asarray(correction(own), dtype=float)))
        return np.array(rows)

    def log_likelihood(self, z: np.ndarray) -> np.ndarray:
        """Joint log likelihood (sum over records) of internal vectors, shape (B,)."""
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            return self.record_log_likelihoods(self.from_internal(np.atleast_2d(z))).sum(axis=0)

    def log_posterior(self, z: np.ndarray) -> np.ndarray:
        """Joint log prior + the records' log likelihoods, shape (B,); -inf outside the support."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        ok = self.in_support(z)
        out = np.full(z.shape[0], -np.inf)
        if not ok.any():
            return out
        zz = z[ok]
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            lp = self._log_prior_inside(zz) + self.record_log_likelihoods(self.from_internal(zz)).sum(axis=0)
        self.n_model_rows += zz.shape[0]
        lp[~np.isfinite(lp)] = -np.inf
        out[ok] = lp
        return out

    def noise_estimate(self, values: Mapping[str, float]) -> dict[str, float]:
        """Each record's moment estimate of its noise parameters (joint names)."""
        out = {}
        for k, problem in enumerate(self.problems):
            own = {name: values[joint] for name, joint in self._maps[k].items() if joint in values}
            out.update({joint_name(n, k): v for n, v in problem.noise_estimate(own).items()})
        return out


@dataclass(frozen=True)
class RecordFit:
    """One record's own calibration preview without its bands (:func:`beam.calibration.run.preview_map`):
    its setup, problem and MAP + Laplace (the joint search's starts; its own evidence)."""

    setup: BeamCalibrationSetup
    problem: Problem
    laplace: LaplaceResult


@dataclass
class JointCalibrationResult:
    """A joint calibration: the joint posterior and each record's view of it.

    Attributes
    ----------
    records : tuple of RecordFit
        Each record's own calibration preview (its own MAP and evidence: the joint search's starts).
    problem : JointProblem
        The joint problem.
    laplace : LaplaceResult
        Joint MAP and Laplace approximation (``log_evidence``: the joint Laplace evidence, nats).
    posterior : PosteriorResult or None
        The joint emcee run (None for a preview).
    seconds : float
        Wall time (s).
    """

    records: tuple[RecordFit, ...]
    problem: JointProblem
    laplace: LaplaceResult
    posterior: PosteriorResult | None
    seconds: float
    seed: int = 0
    _views: tuple[CalibrationResult, ...] | None = field(default=None, repr=False)
    _draws: dict[str, np.ndarray] | None = field(default=None, repr=False)

    @property
    def is_preview(self) -> bool:
        return self.posterior is None

    @property
    def per_record(self) -> tuple[str, ...]:
        """Physical parameters calibrated per record."""
        return self.problem.per_record

    @property
    def shared_names(self) -> tuple[str, ...]:
        """Shared physical parameters (joint names = their own)."""
        return tuple(n for n in self.problem.names if SEPARATOR not in n)

    #: Joint posterior draws (natural units, joint names): MCMC, or Laplace draws for a preview.
    draws = CalibrationResult.draws
    #: ``{joint name: {"mean", "sd", "q025", "q975"}}`` of every sampled parameter.
    summary = CalibrationResult.summary

    def record_results(self) -> tuple[CalibrationResult, ...]:
        """Each record's :class:`CalibrationResult` under the joint posterior: its parameters (own
        names), the joint MAP, the joint posterior's marginal covariance of its parameters (Laplace,
        the log coordinates of the joint problem), the predictive bands of the joint draws over
        the record (hence its RMSE and coverage), ``posterior`` None (the draws are the joint
        ones: :meth:`CalibrationResult.draws` returns them)."""
        if self._views is None:
            self._views = tuple(self._view(k) for k in range(len(self.records)))
        return self._views

    def _view(self, k: int) -> CalibrationResult:
        problem = self.problem
        single = self.records[k]
        names = problem.record_names(k)
        own = single.problem
        index = [problem.index(names[n]) for n in own.names]
        values = {n: float(self.laplace.map.values[names[n]]) for n in own.names}
        z = own.to_internal(values)
        hessian = self.laplace.map.hessian[np.ix_(index, index)]
        found = MapResult(z=z, values=values, log_posterior=float(own.log_posterior(z)[0]),
                          gradient=self.laplace.map.gradient[index], hessian=hessian, hessian_point=z,
                          converged=self.laplace.map.converged, message=self.laplace.map.message, n_starts=1,
                          at_bound=tuple(n for n in own.names if names[n] in self.laplace.map.at_bound))
        cov = self.laplace.cov[np.ix_(index, index)]
        view = LaplaceResult(own, found, z, cov, math.nan, self.laplace.ok, list(self.laplace.warnings))
        draws = {n: self.draws()[names[n]] for n in own.names}
        thinned = _thinned(draws, BAND_DRAWS, self.seed)
        bands = record_bands(own, single.setup, thinned)
        return CalibrationResult(single.setup, own, view, None, bands, self.seconds, _draws=draws)

    def record_json(self, k: int) -> dict:
        """Record ``k``'s entry of the JSON: ``record`` (its name), ``output_unit``, ``parameters``
        (its own physical parameters), ``noise_sd``, ``rmse_calibration``, ``rmse_prediction``,
        ``coverage95_prediction`` and ``frequencies_Hz`` (the joint MAP model's natural
        frequencies of its retained modes, Hz)."""
        view = self.record_results()[k]
        summary = view.summary()
        physical = {n: summary[n] for n in view.setup.physical_names if n in self.per_record}
        values = {n: float(v) for n, v in view.laplace.map.values.items() if n in view.setup.physical_names}
        frequencies = view.setup.model.natural_modes(values, view.setup.modes)[0]
        return {
            "record": view.setup.measurement.name,
            "output_unit": view.setup.measurement.output_unit,
            "parameters": physical,
            "noise_sd": summary.get("noise_sd"),
            "window_s": list(view.setup.window),
            "modes": view.setup.modes,
            "rmse_calibration": view.rmse_calibration,
            "rmse_prediction": view.rmse_prediction,
            "coverage95_prediction": view.coverage95_prediction,
            "frequencies_Hz": [float(f) for f in frequencies],
        }

    def to_json(self) -> dict:
        """The summary of ``beam calibrate A B ... --json``: the shared ``parameters`` (as a single
        calibration's), ``per_record`` and ``records`` (:meth:`record_json`), the joint MAP, Laplace
        evidence and convergence."""
        summary = self.summary()
        diagnostics = self.posterior.diagnostics if self.posterior is not None else None
        spec = self.records[0].setup
        return {
            "measurements": [r.setup.measurement.name for r in self.records],
            "effects": list(spec.effects),
            "likelihood": spec.likelihood,
            "per_record": list(self.per_record),
            "parameters": {name: summary[name] for name in self.shared_names},
            "records": [self.record_json(k) for k in range(len(self.records))],
            "ess_min": diagnostics.ess_min if diagnostics is not None else None,
            "rhat_max": diagnostics.rhat_max if diagnostics is not None else None,
            "converged": bool(diagnostics.converged) if diagnostics is not None else False,
            "warnings": [*(diagnostics.warnings if diagnostics is not None else self.laplace.warnings),
                         *(f"{r.setup.measurement.name}: {w}" for r in self.records
                           for w in record_warnings(r.setup.measurement))],
            "log_evidence_laplace": float(self.laplace.log_evidence),
            "map": {name: float(v) for name, v in self.laplace.map.values.items()},
            "log_posterior_map": float(self.laplace.map.log_posterior),
            "seconds": self.seconds,
            "preview": self.is_preview,
        }


#: Half the 95 % quantile of chi-squared with one degree of freedom (nats): the drop of the profile
#: log posterior at the ends of a 95 % profile interval.
PROFILE_DROP_95 = 0.5 * 3.841458820694124


@dataclass(frozen=True)
class ProfileInterval:
    """A profile interval of one parameter (:func:`profile_interval`).

    Attributes
    ----------
    name : str
        The parameter (joint name).
    lower, upper : float
        Ends of the interval (natural units): where the profile log posterior has dropped by
        :data:`PROFILE_DROP_95` nats below its highest value on the grid (linear between grid
        points in the internal coordinate; an end at the grid's edge means the interval reaches at
        least that far).
    best : float
        The grid value of the highest profile log posterior.
    grid, profile : tuple of float
        The values scanned (natural units) and the profile log posterior at each (nats).
    """

    name: str
    lower: float
    upper: float
    best: float
    grid: tuple[float, ...]
    profile: tuple[float, ...]


def profile_interval(result: JointCalibrationResult, name: str, *, span: float = 1.0, points: int = 21) -> ProfileInterval:
    """The 95 % profile interval of a physical parameter: the joint log posterior maximised over the
    other physical parameters (least squares on the whitened residuals from the neighbouring grid
    point, each record's noise sd re-estimated) on a grid of ``points`` values of ``name`` spanning
    ±``span`` in its internal coordinate (natural log for a positive parameter) around the MAP.

    Where one mode per record leaves EI, a mass and the clamp stiffness on a thin curved ridge, the
    Laplace approximation at the MAP (and an ensemble sampler started there) sees only the ridge's
    local width; the profile follows the ridge (docs/joint-calibration.md).
    """
    problem = result.problem
    i = problem.index(name)
    if name in problem.noise_names:
        raise BeamInputError(f"{name} is a noise parameter: profile a physical parameter")
    centre = result.laplace.map.z
    lo, hi = problem.internal_bounds
    grid = np.clip(centre[i] + np.linspace(-span, span, points), lo[i] + 1e-9, hi[i] - 1e-9)
    columns = np.array([c for c in _physical_columns(problem) if c != i], dtype=int)
    profile = np.full(points, -np.inf)
    middle = points // 2
    for order in (range(middle, points), range(middle, -1, -1)):  # outwards from the MAP
        z = centre.copy()
        for j in order:
            z[i] = grid[j]
            for _ in range(2):  # the whitening follows the noise sd
                values = problem.from_internal(z[None, :])
                sigma = np.concatenate([np.full(p.data.size, float(values[problem.noise_names[k]][0]))
                                        for k, p in enumerate(problem.problems)])

                def rows(zz: np.ndarray, sigma=sigma) -> np.ndarray:
                    whitened = (problem.data - problem.predict(problem.from_internal(zz))) / sigma
                    return np.hstack([whitened, _prior_residuals(problem, zz, columns)])

                z, _ = _batched_least_squares(problem, rows, z, columns)
                values = problem.from_internal(z[None, :])
                estimate = problem.noise_estimate({n: float(a[0]) for n, a in values.items()})
                for n, v in estimate.items():
                    k = problem.index(n)
                    z[k] = float(np.clip(problem.parameters[k].prior.to_internal(v), lo[k], hi[k]))
            profile[j] = max(profile[j], float(problem.log_posterior(z)[0]))
    prior = problem.parameters[i].prior
    natural = prior.from_internal(grid)
    top = float(np.max(profile))
    level = top - PROFILE_DROP_95
    inside = np.flatnonzero(profile >= level)

    def crossing(a: int, b: int) -> float:  # linear in the internal coordinate between grid points a (out), b (in)
        if not np.isfinite(profile[a]):
            return float(grid[b])
        return float(grid[a] + (level - profile[a]) / (profile[b] - profile[a]) * (grid[b] - grid[a]))

    first, last = int(inside[0]), int(inside[-1])
    lower = grid[first] if first == 0 else crossing(first - 1, first)
    upper = grid[last] if last == points - 1 else crossing(last + 1, last)
    return ProfileInterval(name, float(prior.from_internal(lower)), float(prior.from_internal(upper)),
                           float(natural[int(np.argmax(profile))]), tuple(float(v) for v in natural),
                           tuple(float(v) for v in profile))


def _thinned(draws: Mapping[str, np.ndarray], n: int, seed: int) -> dict[str, np.ndarray]:
    """At most ``n`` of ``draws`` (a seeded choice without replacement when there are more)."""
    size = next(iter(draws.values())).shape[0]
    if size <= n:
        return dict(draws)
    pick = np.sort(np.random.default_rng(seed).choice(size, n, replace=False))
    return {name: v[pick] for name, v in draws.items()}


def _records_and_spec(measurements, spec, options):
    measurements = tuple(measurements)
    if not measurements:
        raise BeamInputError("a joint calibration needs at least one record")
    return measurements, CalibrationSpec.of(spec, **options)


def joint_preview(
    measurements: Sequence,
    spec: CalibrationSpec | None = None,
    *,
    per_record: Iterable[str] | str | None = None,
    shared: Iterable[str] | str | None = None,
    engine: Engine | None = None,
    starts: Iterable[Mapping[str, float]] = (),
    **options,
) -> JointCalibrationResult:
    """Joint MAP + Laplace of several records of one beam (see the module notes).

    Parameters
    ----------
    measurements : sequence of Measurement
        The records, each with its own geometry (length, sensor position) and input.
    spec : CalibrationSpec, optional
        Window, effects, modes, likelihood, seed for every record; the default window and
        ``"auto"`` modes are resolved on each record.
    per_record, shared : iterable of str or comma-separated str, optional
        Physical parameters calibrated per record (:func:`resolve_per_record`).
    engine : Engine, optional
        The engine of the records' single MAP searches (default: the process's).
    starts : iterable of mapping, optional
        More starting points of the joint search (joint names, natural units; see :func:`joint_map`).
    **options
        Fields of :class:`CalibrationSpec`, which replace the spec's.

    Returns
    -------
    JointCalibrationResult
        ``posterior`` None.
    """
    t0 = time.perf_counter()
    measurements, spec = _records_and_spec(measurements, spec, options)
    engine = default_engine() if engine is None else engine
    singles = []
    for k, m in enumerate(measurements, 1):
        with reporting(None, f"record {k} of {len(measurements)} ({m.name}) alone"):
            singles.append(RecordFit(*preview_map(m, spec, engine=engine)[:3]))
    singles = tuple(singles)
    physical: list[str] = []
    for single in singles:
        physical += [n for n in single.setup.physical_names if n not in physical]
    chosen = resolve_per_record(per_record, physical, shared)
    problem = JointProblem([s.problem for s in singles], chosen, setups=[s.setup for s in singles])
    found = JointModel(singles).search(problem, list(starts))
    approximation = laplace(problem, found)
    approximation.seconds = time.perf_counter() - t0
    return JointCalibrationResult(singles, problem, approximation, None, time.perf_counter() - t0, seed=spec.seed)


def joint_calibrate(
    measurements: Sequence,
    spec: CalibrationSpec | None = None,
    *,
    per_record: Iterable[str] | str | None = None,
    shared: Iterable[str] | str | None = None,
    engine: Engine | None = None,
    **options,
) -> JointCalibrationResult:
    """Joint calibration: :func:`joint_preview`, then emcee over the joint posterior to
    ``spec.target_ess`` (or exactly ``spec.steps`` steps), as :func:`beam.calibration.calibrate`.

    Takes the arguments of :func:`joint_preview`.
    """
    t0 = time.perf_counter()
    measurements, spec = _records_and_spec(measurements, spec, options)
    preview = joint_preview(measurements, spec, per_record=per_record, shared=shared, engine=engine)
    sampling = sample_posterior(preview.problem, preview.laplace, spec)  # the sampler of every calibration
    while True:
        try:
            next(sampling)
        except StopIteration as stop:
            posterior = stop.value
            break
    return replace(preview, posterior=posterior, seconds=time.perf_counter() - t0, _views=None, _draws=None)


class JointModel(CalibrationModel):
    """The calibration model of several records of one beam (the pipeline's, :mod:`beam.calibration.pipeline`):
    its starts are the records' own previews (``singles``, each from the single pipeline), its
    search :func:`joint_map` (a caller's ``guesses``, joint names, joining at its least-squares
    stage), its posterior emcee (:func:`~beam.calibration.pipeline.sample_posterior`), its bands
    each record's (:meth:`JointCalibrationResult.record_results`)."""

    name = "several records of one beam"

    def __init__(self, singles: Sequence[RecordFit]) -> None:
        self.singles = tuple(singles)

    def starts(self, problem, setup, engine, warm, search):
        return [dict(s.laplace.map.values) for s in self.singles]

    def search(self, problem, guesses):
        return joint_map(problem, [s.laplace for s in self.singles], tuple(guesses))


def joint_starts(problem: JointProblem, singles: Sequence[LaplaceResult]) -> np.ndarray:
    """Internal starting points of the joint MAP search, shape (m, ndim): for each record, its
    single MAP's values of the shared parameters (a parameter it lacks from the first record that
    has it), and every record's own MAP for its per-record parameters and noise; then the shared
    parameters at the records' median (internal coordinates) when there are several records."""
    own = [s.map.values for s in singles]
    base = problem.joint_values(own)
    rows = []
    for k in range(len(singles)):
        values = dict(base)
        for name, joint in problem.record_names(k).items():
            if SEPARATOR not in joint and name in own[k]:
                values[joint] = float(own[k][name])
        rows.append(problem.to_internal(values))
    rows = np.array(rows, dtype=float)
    if len(singles) > 1:
        shared = np.array([SEPARATOR not in n for n in problem.names])
        median = rows[0].copy()
        median[shared] = np.median(rows[:, shared], axis=0)
        rows = np.vstack([rows, median])
    lo, hi = problem.internal_bounds
    scale = np.array([p.prior.internal_scale for p in problem.parameters])
    return np.clip(rows, lo + 1e-6 * scale, hi - 1e-6 * scale)


def _extra_starts(problem: JointProblem, template: np.ndarray, extra: Sequence[Mapping[str, float]]) -> np.ndarray:
    """Internal vectors of caller's starts (joint names, natural units; a missing name from
    ``template``, a value outside the prior's support clipped just inside it)."""
    lo, hi = problem.internal_bounds
    scale = np.array([p.prior.internal_scale for p in problem.parameters])
    rows = []
    for guess in extra:
        z = template.copy()
        for i, p in enumerate(problem.parameters):
            if p.name in guess and np.isfinite(guess[p.name]) and guess[p.name] > 0:
                z[i] = p.prior.to_internal(float(guess[p.name]))
        rows.append(np.clip(z, lo + 1e-6 * scale, hi - 1e-6 * scale))
    return np.array(rows)


def joint_map(problem: JointProblem, singles: Sequence[LaplaceResult],
              extra: Sequence[Mapping[str, float]] = ()) -> MapResult:
    """The joint MAP from the records' single MAPs, in three stages.

    1. **Modal match** (:func:`modal_match`): from each start of :func:`joint_starts`, the joint
       parameters whose model reproduces every record's single-MAP natural frequencies and
       damping ratios (cheap: no time response). One record's MAP lies anywhere along the ridge of
       parameter sets that give its frequencies; in the time domain another record, predicted from
       it, is off by whole cycles, where a local search from it would stall.
    2. **Least squares** on the records' whitened residuals together (each record's noise sd at
       its single MAP's), :func:`scipy.optimize.least_squares` with a batched finite-difference
       Jacobian (one call of every record's model per iteration).
    ``extra`` starts (joint names, natural units: e.g. a smaller model's joint MAP with the new
    parameters at their null values, :func:`beam.discovery.joint.joint_diagnose`) skip the modal
    match and join at stage 2.

    3. **Newton** iterations on the joint log posterior (:func:`beam.calibration.fit.newton_polish`)
       from the best of them: the MAP and the Hessian the Laplace approximation uses.
    """
    from beam.calibration.fit import newton_polish

    starts = joint_starts(problem, singles)
    report(f"joint MAP: modal match from {len(starts)} starts")
    matched = _distinct(problem, np.array([modal_match(problem, singles, z) for z in starts]))
    matched = matched[np.argsort(-problem.log_posterior(matched))[:JOINT_POLISHED_STARTS]]
    if extra:
        matched = np.vstack([matched, _extra_starts(problem, starts[0], extra)])
    fitted, steps = [], []
    for k, z in enumerate(matched, 1):
        report(f"joint MAP: least squares from start {k} of {len(matched)}")
        found_z, step = _least_squares(problem, singles, z)
        fitted.append(found_z)
        steps.append(step)
    fitted = np.array(fitted)
    start_lp = problem.log_posterior(fitted)
    if not np.any(np.isfinite(start_lp)):
        raise BeamInputError("no joint starting point has a finite log posterior (do the records describe one beam?)")
    best = None
    for i in np.argsort(-start_lp)[:JOINT_POLISHED_STARTS]:
        if not np.isfinite(start_lp[i]):
            continue
        with reporting(None, "joint MAP"):
            found = newton_polish(problem, fitted[i], steps[i], max_iterations=JOINT_NEWTON_ITERATIONS)
        if best is None or found.log_posterior > best.log_posterior:
            best = found
    return replace(best, n_starts=len(fitted), start_log_posteriors=[float(v) for v in start_lp])


#: Tolerances of the modal match (:func:`modal_match`): relative frequency and damping-ratio
#: differences weighted as 1 / these (a single record's frequency is known far better than 0.1 %,
#: its damping ratio to a few percent).
MATCH_FREQUENCY = 1e-3
MATCH_DAMPING = 0.05


def _distinct(problem: JointProblem, rows: np.ndarray) -> np.ndarray:
    """``rows`` without those within 1e-3 prior scales (every coordinate) of an earlier one."""
    scale = np.array([p.prior.internal_scale for p in problem.parameters])
    kept: list[np.ndarray] = []
    for row in rows:
        if all(np.any(np.abs(row - other) > 1e-3 * scale) for other in kept):
            kept.append(row)
    return np.array(kept)


def _physical_columns(problem: JointProblem) -> np.ndarray:
    return np.array([i for i, n in enumerate(problem.names) if n not in problem.noise_names], dtype=int)


def _prior_residuals(problem: JointProblem, z: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """One pseudo-residual per Gaussian prior (internal coordinates) of ``columns``, rows of ``z``
    (B, ndim) -> (B, number of Gaussian priors)."""
    out = []
    for i in columns:
        quadratic = problem.parameters[i].prior.internal_quadratic()
        if quadratic is not None and np.isfinite(quadratic[2]):
            out.append((z[:, i] - quadratic[1]) / quadratic[2])
    return np.column_stack(out) if out else np.zeros((z.shape[0], 0))


def _modes_of(setup, values: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies (Hz) and damping ratios, each (B, modes), of the retained modes of
    ``setup``'s model at ``values`` (arrays of B): the poles of its reduced system."""
    return model_modes(setup.model, values, setup.modes)


def model_modes(model, values: Mapping[str, np.ndarray], modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies (Hz) and damping ratios, each (B, modes), of the lowest ``modes`` modes
    of a :class:`~beam.physics.model.BeamModel` at ``values`` (arrays of B), batched: the poles
    of its reduced system."""
    reduced, _, _ = model.reduced_system(values, modes)
    poles, _ = modal.modal_decomposition(reduced["omega2"], reduced["damping"])
    upper = poles[:, ::2]  # conjugate pairs adjacent, Im > 0 first
    magnitude = np.abs(upper)
    return magnitude / (2.0 * np.pi), -upper.real / np.where(magnitude > 0, magnitude, 1.0)


def modal_match(problem: JointProblem, singles: Sequence[LaplaceResult], z0: np.ndarray) -> np.ndarray:
    """Joint internal vector near ``z0`` whose model gives each record's single-MAP natural
    frequencies and damping ratios of its retained modes (log differences over
    :data:`MATCH_FREQUENCY` and :data:`MATCH_DAMPING`, plus the Gaussian priors' pseudo-residuals),
    by :func:`_batched_least_squares` on the physical parameters (noise kept)."""
    targets = []
    for setup, single in zip(problem.setups, singles):
        f, zeta = _modes_of(setup, {n: np.atleast_1d(single.map.values[n]) for n in setup.physical_names})
        targets.append((setup, np.log(f[0]), np.log(np.maximum(zeta[0], 1e-12))))
    columns = _physical_columns(problem)

    def rows(z: np.ndarray) -> np.ndarray:
        values = problem.from_internal(z)
        out = [_prior_residuals(problem, z, columns)]
        for k, (setup, log_f, log_zeta) in enumerate(targets):
            names = problem.record_names(k)
            f, zeta = _modes_of(setup, {n: values[names[n]] for n in setup.physical_names})
            out.append((np.log(f) - log_f) / MATCH_FREQUENCY)
            out.append((np.log(np.maximum(zeta, 1e-12)) - log_zeta) / MATCH_DAMPING)
        return np.hstack(out)

    z, _ = _batched_least_squares(problem, rows, z0, columns)
    return z


def _batched_least_squares(problem: JointProblem, rows, z0: np.ndarray, columns: np.ndarray,
                           max_nfev: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """:func:`scipy.optimize.least_squares` (trust-region reflective, bounds) over the internal
    coordinates ``columns`` of ``z0`` (the others held) of the residual rows ``rows(z) -> (B, N)``,
    whose forward-difference Jacobian is one call of ``rows`` on the point and its stencil.
    Returns the point (all coordinates) and the Jacobian there ((N, len(columns)))."""
    from scipy import optimize

    lo, hi = problem.internal_bounds
    scale = np.array([p.prior.internal_scale for p in problem.parameters])[columns]
    lo, hi = lo[columns], hi[columns]
    cache: dict[bytes, np.ndarray] = {}

    def evaluate(x: np.ndarray) -> np.ndarray:
        z = np.repeat(z0[None, :], x.shape[0], axis=0)
        z[:, columns] = x
        with np.errstate(all="ignore"):
            out = rows(z)
        return np.where(np.isfinite(out), out, 1e6)

    def residuals(x: np.ndarray) -> np.ndarray:
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = evaluate(x[None, :])[0]
        return cache[key]

    def jacobian(x: np.ndarray) -> np.ndarray:
        h = 1e-6 * np.maximum(np.abs(x), scale)
        h = np.where(x + h > hi, -h, h)
        stencil = np.repeat(x[None, :], 1 + x.size, axis=0)
        stencil[1 + np.arange(x.size), np.arange(x.size)] += h
        out = evaluate(stencil)
        cache.clear()
        cache[x.tobytes()] = out[0]
        return ((out[1:] - out[0]) / h[:, None]).T

    x0 = np.clip(z0[columns], lo + 1e-9 * scale, hi - 1e-9 * scale)
    try:
        fit = optimize.least_squares(residuals, x0, jac=jacobian, bounds=(lo, hi), method="trf", x_scale="jac",
                                     max_nfev=max_nfev, ftol=1e-10, xtol=1e-10, gtol=1e-10)
        x, jac = fit.x, fit.jac
    except (ValueError, np.linalg.LinAlgError):
        x, jac = x0, jacobian(x0)
    z = z0.copy()
    z[columns] = x
    return z, jac


def _least_squares(problem: JointProblem, singles: Sequence[LaplaceResult],
                   z0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The physical parameters near ``z0`` minimising the records' residuals, each whitened by its
    single MAP's noise sd (plus the Gaussian priors' pseudo-residuals); the noise coordinates then
    set to each record's residual RMS. Returns the point and finite-difference steps for the
    Newton iteration from it (internal): a tenth of each coordinate's conditional sd under the
    Gauss–Newton curvature (noise: of the log sd, 1/sqrt(2 n))."""
    columns = _physical_columns(problem)
    lo, hi = problem.internal_bounds
    scale = np.array([p.prior.internal_scale for p in problem.parameters])
    sigma = np.concatenate([np.full(p.data.size, float(s.map.values["noise_sd"]) if "noise_sd" in s.map.values
                                    else float(np.std(p.data)))
                            for p, s in zip(problem.problems, singles)])

    def rows(z: np.ndarray) -> np.ndarray:
        whitened = (problem.data - problem.predict(problem.from_internal(z))) / sigma
        return np.hstack([whitened, _prior_residuals(problem, z, columns)])

    z, jac = _batched_least_squares(problem, rows, z0, columns)
    steps = 1e-3 * scale.copy()
    curvature = np.sum(jac**2, axis=0)
    steps[columns] = np.where(curvature > 0, 0.1 / np.sqrt(np.maximum(curvature, 1e-300)), 1e-3 * scale[columns])
    for k, p in enumerate(problem.problems):
        for name in problem._noise:
            steps[problem.index(joint_name(name, k))] = 0.1 / math.sqrt(2.0 * p.data.size)
    steps = np.minimum(steps, 0.1 * scale)
    values = problem.from_internal(z[None, :])
    for name, v in problem.noise_estimate({n: float(a[0]) for n, a in values.items()}).items():
        i = problem.index(name)
        z[i] = float(np.clip(problem.parameters[i].prior.to_internal(v), lo[i], hi[i]))
    return z, steps
