"""``beam toy``: calibrate the toy periodic model with a chosen model discrepancy.

Simulates ``y = A sin(2π f t + φ) + δ d(t) + noise``, calibrates ``A sin(2π f t + φ)`` on the
window with an i.i.d. or AR(1) Gaussian likelihood (MAP, Laplace preview, emcee) and scores the
predictions on the held-out rest of the record. ``--sweep`` adds the held-out RMSE and 95 %
prediction-band coverage against the window length (MAP + Laplace, no MCMC).
"""

from __future__ import annotations

import argparse
import json
import math

_ORDER = ("amplitude", "frequency_Hz", "phase_rad", "noise_sd", "ar1_coefficient")


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    return value


def register(subparsers) -> None:
    """Add the ``toy`` subcommand."""
    p = subparsers.add_parser(
        "toy",
        help="toy periodic model with model discrepancy (calibration, prediction, window sweep)",
        description=__doc__.replace("``", ""),  # the docstring without its reST markup
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--window", type=_number, default=5.0, metavar="T", help="calibration window [0, T] in s (default 5)")
    p.add_argument("--discrepancy", type=_number, default=0.0, metavar="DELTA", help="discrepancy amplitude δ in data units (default 0)")
    p.add_argument("--kind", default="harmonic", metavar="KIND", help="discrepancy shape: harmonic (sin 4πft+φ), tone (sin 2π·1.37ft) or drift (t / 5 s, a fixed time constant: the truth does not depend on --window) (default harmonic)")
    p.add_argument("--noise", type=_number, default=0.1, metavar="SD", help="noise standard deviation in data units (default 0.1)")
    p.add_argument("--horizon", type=_number, default=20.0, metavar="T", help="end of the record in s; (window, horizon] is held out (default 20)")
    p.add_argument("--likelihood", default="iid", metavar="KIND", help="noise model of the calibration: iid or ar1 (default iid)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed of the data and the sampler (default 0)")
    p.add_argument("--target-ess", type=_number, default=1000.0, metavar="N", help="bulk ESS per parameter for the MCMC (default 1000)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.add_argument("--sweep", action="store_true", help="also sweep the calibration window (1 to 15 s) with the Laplace preview")
    p.set_defaults(func=run)


def _scenario(args):
    from beam.toy import ToyScenario

    scenario = ToyScenario(
        window_s=args.window,
        discrepancy=args.discrepancy,
        kind=str(args.kind).strip().lower(),
        noise_sd=args.noise,
        horizon_s=args.horizon,
        likelihood=str(args.likelihood).strip().lower(),
        seed=args.seed,
        target_ess=args.target_ess,
    )
    return scenario.validate()


def _jsonable(obj):
    """Replace non-finite floats (not valid JSON) by None, recursively."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    return obj


def _table(report: dict) -> str:
    from beam.toy import UNITS

    sc = report["scenario"]
    lines = [
        f"toy model: A sin(2 pi f t + phi) calibrated on [0, {sc['window_s']:g}] s, held out ({sc['window_s']:g}, {sc['horizon_s']:g}] s",
        (
            f"truth: discrepancy {sc['kind']} delta = {sc['discrepancy']:g} du, noise sd {sc['noise_sd']:g} du; "
            f"likelihood {report['likelihood']}; seed {sc['seed']}"
        ),
        "",
        f"{'parameter':22s} {'truth':>10s} {'mean':>10s} {'sd':>10s} {'q2.5%':>10s} {'q97.5%':>10s}  in 95%?",
    ]
    for name in _ORDER:
        if name not in report["posterior"]:
            continue
        s = report["posterior"][name]
        truth = report["truth"].get(name)
        inside = "" if truth is None else ("yes" if s["q025"] <= truth <= s["q975"] else "NO")
        label = f"{name} [{UNITS[name]}]"
        t = f"{truth:10.4f}" if truth is not None else f"{'-':>10s}"
        lines.append(f"{label:22s} {t} {s['mean']:10.4f} {s['sd']:10.4f} {s['q025']:10.4f} {s['q975']:10.4f}  {inside}")
    lines += [
        "",
        f"held-out RMSE of the posterior mean [du]       {report['rmse_prediction']:.4f}",
        f"held-out coverage of the 95% prediction band   {report['coverage95_prediction']:.3f}",
        (
            f"MCMC: ESS min {report['ess_min']:.0f}, R-hat max {report['rhat_max']:.4f}, "
            f"{report['n_walkers']} walkers x {report['n_steps']} steps (burn-in {report['n_burn']}), "
            f"acceptance {report['acceptance_fraction']:.2f}, converged: {'yes' if report['converged'] else 'NO'}"
        ),
    ]
    for w in report.get("warnings", []):
        lines.append(f"warning: {w}")
    lines.append(f"time [s]                                       {report['seconds']:.2f}")
    if "sweep" in report:
        lines += ["", "window sweep (MAP + Laplace preview):", f"{'window [s]':>10s} {'RMSE [du]':>10s} {'coverage95':>11s} {'f mean [Hz]':>12s} {'f sd [Hz]':>10s}"]
        for row in report["sweep"]:
            lines.append(
                f"{row['window_s']:10.1f} {row['rmse_prediction']:10.4f} {row['coverage95_prediction']:11.3f} "
                f"{row['frequency_Hz_mean']:12.5f} {row['frequency_Hz_sd']:10.5f}"
            )
    return "\n".join(lines)


def run(args) -> int:
    """Run ``beam toy``; returns the exit status.

    Invalid options raise :class:`beam.errors.BeamInputError` (from
    :meth:`beam.toy.ToyScenario.validate`), which the entry point turns into one ``error:``
    line and exit status 2.
    """
    scenario = _scenario(args)
    from beam.toy import run_toy

    result = run_toy(scenario, sweep=args.sweep)
    report = _jsonable(result.to_json())
    if args.json:
        print(json.dumps(report))
    else:
        print(_table(report))
    return 0


__all__ = ["register", "run"]
