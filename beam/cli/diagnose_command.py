"""``beam diagnose DATA [DATA ...]``: where the model fails, which effect is missing, and the error ladder.

Several records of one beam are diagnosed jointly (:func:`beam.discovery.joint.joint_diagnose`): each
candidate's evidence is the joint one, with each record's own beside it.
"""

from __future__ import annotations

import argparse
import json
import sys

from beam.cli.arguments import HelpFormatter, effect_list, effects_epilog, non_negative_int
from beam.calibration.spec import CalibrationSpec
from beam.cli.progress_line import TerminalProgress, wants_progress  # noqa: F401 - wants_progress: the rule, re-exported
from beam.cli.calibrate_command import (
    add_joint_arguments,
    add_model_arguments,
    format_window,
    in_unit as _in_unit,
    percent as _percent,
    print_joint,
    taps_summary,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``diagnose`` subcommand."""
    parser = subparsers.add_parser(
        "diagnose",
        help="find which physical effect the model is missing",
        description="Calibrate the base model on the window (MAP + Laplace), examine its residuals (band exceedances, "
        "spectrum, whiteness, identified modes, amplitude dependence), rank every catalogue effect not in the model "
        "by Laplace evidence and held-out error, and climb the error ladder.",
        epilog=effects_epilog("--base"),
        formatter_class=HelpFormatter,
    )
    add_model_arguments(parser)
    defaults = ",".join(CalibrationSpec().effects)
    parser.add_argument("--base", default=defaults, type=effect_list, metavar="A,B",
                        help=f"effects of the current model (default {defaults}; '+A,B' adds A and B to it; '' for the "
                        "bare beam)")
    parser.add_argument("--mcmc", action="store_true", help="re-calibrate every ladder step with full MCMC (slower)")
    parser.add_argument("--seed", type=non_negative_int, default=0, metavar="S", help="random seed of the MCMC (default 0)")
    add_joint_arguments(parser)
    which = parser.add_argument_group("which record to take next (--suggest)")
    which.add_argument("--suggest", action="store_true",
                       help="when the top two explanations are not separated (Δ log evidence < 3 nats), say where a new "
                       "record would separate them most: a free length or a sensor position, with the predicted f1 "
                       "difference against the frequency resolution 1/T of a record as long as the first")
    which.add_argument("--length-range", type=metre_range, default=None, metavar="A:B",
                       help="free lengths the rig allows, m (default 0.6 to 1.2 times the first record's length)")
    which.add_argument("--position-range", type=metre_range, default=None, metavar="A:B",
                       help="sensor positions the rig allows, m from the clamp (default 0.4 times the length to the tip)")
    parser.add_argument("--json", action="store_true",
                        help="print the report as one JSON object (SI units; no progress line)")
    parser.add_argument("--report", default=None, metavar="FILE.html",
                        help="also write a one-page printable summary (self-contained HTML: the error ladder, the "
                        "residual plots, the ranked candidates, the modes)")
    parser.set_defaults(func=run)


def metre_range(text: str) -> tuple[float, float]:
    """``A:B`` in metres, 0 < A < B."""
    from beam.cli.arguments import finite_float

    parts = text.split(":")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected A:B in metres, got {text!r}")
    lo, hi = (finite_float(p) for p in parts)
    if not 0.0 < lo < hi:
        raise argparse.ArgumentTypeError(f"expected 0 < A < B (m), got {text!r}")
    return lo, hi


def check_suggest_arguments(args: argparse.Namespace) -> None:
    """--length-range and --position-range need --suggest (BeamInputError)."""
    for flag, value in (("--length-range", args.length_range), ("--position-range", args.position_range)):
        if value is not None and not args.suggest:
            from beam.errors import BeamInputError

            raise BeamInputError(f"{flag} needs --suggest")


def suggestion_of(args: argparse.Namespace, ranked: list[tuple[str, float]], fits_of) -> dict:
    """The ``suggestion`` of ``--suggest`` (:func:`beam.discovery.suggest.next_record`) with the
    command's ranges."""
    from beam.discovery.suggest import next_record

    return next_record(ranked, fits_of, length_range=args.length_range, position_range=args.position_range)


def run(args: argparse.Namespace) -> int:
    from beam.cli.record_arguments import check_joint_arguments, measurement_from_args, several_records

    check_suggest_arguments(args)
    if several_records(args):
        return run_joint(args)
    measurement = measurement_from_args(args, effects=args.base)  # a bad file fails before the heavy imports
    check_joint_arguments(args, 1)  # the diagnosis reads one tap
    progress = TerminalProgress(sys.stderr) if wants_progress(args) else None
    if progress is not None:
        progress(f"loading the calibration engine ({measurement.name})")
    from beam.calibration.spec import CalibrationSpec
    from beam.discovery.report import diagnose

    try:
        spec = CalibrationSpec(window=args.window, effects=args.base, modes=args.modes, seed=args.seed)
        report = diagnose(measurement, spec, ladder_mcmc=args.mcmc, progress=progress)
        if args.report:
            if progress is not None:
                progress(f"writing {args.report}")
            from beam.discovery.handout import report_handout
            from beam.io.text import atomic_write_texts

            written = str(atomic_write_texts({args.report: report_handout(report)})[0])
    finally:
        if progress is not None:
            progress.close()
    summary = report.to_json()
    if len(measurement.taps) > 1 and args.segment is None:
        summary.update(taps_summary(measurement, diagnosis=True))
    if args.report:
        summary["report"] = written
    if args.suggest:
        summary["suggestion"] = suggestion_of(
            args, sorted(((c["effect"], c["delta_log_evidence"]) for c in summary["candidates"]),
                         key=lambda c: -float("inf") if c[1] is None else -c[1]),
            lambda a, b: _single_fits(measurement, summary, a, b))
    if args.json:
        json.dump(summary, sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_report(summary))
    return 0


def run_joint(args: argparse.Namespace) -> int:
    """``beam diagnose A B ...``: the joint diagnosis (:func:`beam.discovery.joint.joint_diagnose`)."""
    from beam.cli.record_arguments import measurements_from_args

    if args.mcmc:
        from beam.errors import BeamInputError

        raise BeamInputError("--mcmc takes one record; a joint diagnosis ranks by the joint Laplace evidence")
    measurements = measurements_from_args(args, effects=args.base)  # bad files fail before the heavy imports
    from beam.discovery.joint import joint_diagnose

    from beam.cli.progress_line import progress_line

    with progress_line(args, f"joint diagnosis ({len(measurements)} records)"):
        report = joint_diagnose(measurements, window=args.window, modes=args.modes, base=args.base,
                                per_record=args.per_record, shared=args.shared)
    summary = report.to_json()
    if args.suggest:
        summary["suggestion"] = suggestion_of(args, [(c.effect, c.delta_log_evidence) for c in report.candidates],
                                              lambda a, b: [report.fits[a], report.fits[b]])
    return print_joint(args, summary, format_joint_report)


def _single_fits(measurement, summary: dict, a: str, b: str) -> list:
    """The one-record joint fits (the single calibrations, :func:`beam.calibration.joint.joint_preview`)
    of the diagnosis's base model plus ``a`` and plus ``b``, on its window and modes."""
    from beam.calibration.joint import joint_preview
    from beam.calibration.spec import CalibrationSpec
    from beam.discovery.ranking import with_effect

    spec = CalibrationSpec(window=tuple(summary["window_s"]), modes=summary["modes"])
    return [joint_preview([measurement], spec.with_effects(with_effect(summary["base"], e))) for e in (a, b)]


def format_suggestion(suggestion: dict) -> list[str]:
    """The lines of ``--suggest`` in a readable report."""
    return ["", "which record to take next: " + suggestion["words"]]


def format_joint_report(summary: dict) -> str:
    """A readable report of a joint diagnosis: the joint ladder and the candidates judged on each
    rung in one table, the joint figures beside each record's (``table`` of the JSON)."""
    from beam.discovery.judgement import ORDER_WORDS, STATUS_WORDS

    names = [r["record"] for r in summary["records"]]
    unit = summary.get("output_unit", "")
    lines = [f"joint diagnosis of {len(names)} records ({', '.join(names)}), base model: "
             f"{', '.join(summary['base']) or 'bare beam'}", "",
             f"the joint ladder, and the candidates judged on each rung (best first: {ORDER_WORDS}; * missing)",
             "  per record: a rung's error in the window / after it (the error a candidate is judged on; the MAP's"
             f"{', ' + unit if unit else ''}); a candidate's own Δ log evidence alone, then its errors under the joint fit",
             "  " + f"{'row':26s} {'joint Δ log Z':>14s}  {'judged':31s}"
             + "".join(f" {f'{k + 1}: {n}':>29s}" for k, n in enumerate(names))]
    rows = summary.get("table") or []
    for row in rows:
        cells = []
        for r in row["records"]:
            errors = f"{_m(r.get('rmse_calibration'))} / {_m(r.get('held_out_judged'))}"
            if row["kind"] == "candidate":
                errors = f"{_nats(r.get('delta_log_evidence_alone'))}, {errors}"
            cells.append(f" {errors:>29s}")
        if row["kind"] == "rung":
            label = "base" if row["added"] is None else f"+ {row['added']}"
            lines.append(f"  {label:26s} {_nats(row['delta_log_evidence']) if row['delta_log_evidence'] is not None else '—':>14s}"
                         f"  {'':31s}" + "".join(cells))
        else:
            mark = "*" if row["status"] == "missing" else " "
            lines.append(f"{mark}   {row['effect']:24s} {_nats(row['delta_log_evidence']):>14s}  "
                         f"{STATUS_WORDS.get(row['status'], ''):31s}" + "".join(cells))
    if not rows:  # a summary without the table (an older JSON): the candidates alone
        for c in summary["candidates"]:
            mark = "*" if c["material"] else " "
            alone = ", ".join(_nats(v) for v in c["records_delta_log_evidence"]) or c.get("error") or ""
            lines.append(f"{mark} {c['effect']:18s} {_nats(c['delta_log_evidence']):>21s}  {alone}")
    lines += ["", summary["verdict"]]
    lines += format_suggestion(summary["suggestion"]) if "suggestion" in summary else []
    lines.append(f"({summary['seconds']:.1f} s)")
    return "\n".join(lines) + "\n"


def _m(value) -> str:
    return "n/a" if value is None else f"{value:.3g}"


def _nats(value) -> str:
    return "failed" if value is None else f"{value:+.1f}"


def format_report(summary: dict) -> str:
    """A readable report of a diagnosis, in the units ``beam calibrate`` prints (lengths in µm, a
    velocity or acceleration in its SI unit, coverage in %; the JSON keeps SI units)."""
    from beam.discovery.judgement import ORDER_WORDS, STATUS_WORDS
    from beam.residuals.modal_id import DIFFERENCE_CONVENTION

    unit = summary.get("output_unit", "m")
    lines = [
        f"{summary['measurement']}: calibration window {format_window(summary['window_s'])}, {summary['modes']} modes, "
        f"base model: {', '.join(summary['base']) or 'bare beam'}",
        *([f"modes: {summary['modes']}, chosen: {summary['modes_reason']}"] if summary.get("modes_reason") else []),
        *([summary["taps_words"]] if summary.get("taps_words") else []),
        f"held-out RMSE of the base model {_in_unit(summary['rmse_prediction_base'], unit)}, held-out data inside its "
        f"95 % prediction band: {_percent(summary['coverage95_prediction_base'])}",
        "",
        f"modes (data vs model; data vs model %: {DIFFERENCE_CONVENTION})",
        f"  {'mode':>4s} {'f data (Hz)':>12s} {'f model (Hz)':>13s} {'data vs model %':>16s} {'zeta data':>10s} {'zeta model':>11s}",
    ]
    for row in summary["modes_table"]:
        lines.append(f"  {row['mode']:>4d} {_m(row['frequency_data_Hz']):>12s} {_m(row['frequency_model_Hz']):>13s} "
                     f"{_m(row['frequency_error_pct']):>16s} {_m(row['damping_data']):>10s} {_m(row['damping_model']):>11s}"
                     + (f"  {row['note']}" if row.get("resolved") is False else
                        f"  not seen: {row['note']}" if row.get("note") else ""))
    lines += ["", f"candidate effects on the base model, best first ({ORDER_WORDS}; * missing; the ladder judges "
              "the rest again on top of each rung)",
              f"  {'effect':18s} {'Δ log evidence':>15s} {'held-out RMSE':>18s}  {'judged':31s} why"]
    if any(c.get("source") == "averaged" for c in summary["candidates"]):
        lines.append("  [averaged]: figures of the averaged forms fitted to the record's backbone and damping curves "
                     "(evidence of the curves, no RMSE); the others: the full time-domain fits")
    for c in summary["candidates"]:
        mark = "*" if c["material"] else " "
        judged = STATUS_WORDS.get(c.get("status"), "")
        source = "[averaged] " if c.get("source") == "averaged" else ""
        lines.append(f"{mark} {c['effect']:18s} {_nats(c['delta_log_evidence']):>15s} {_in_unit(c['rmse_prediction'], unit):>18s}"
                     f"  {judged:31s} {source}{c['explanation']}")
    lines += ["", "error ladder"]
    for step in summary["ladder"]:
        name = "base" if step["added"] is None else f"+ {step['added']}"
        lines.append(f"  {name:22s} RMSE calibration {_in_unit(step['rmse_calibration'], unit)}, held-out "
                     f"{_in_unit(step['rmse_prediction'], unit)}, held-out inside the 95 % band "
                     f"{_percent(step['coverage95_prediction'])}")
    lines += ["", summary["verdict"]]
    repair = summary.get("repair")
    if repair:  # the full effect list: the base's damping stays in the repaired model
        lines.append(f"to calibrate the repaired model: {repair['command']}")
    lines += [f"note: {n}" for n in summary["notes"]]
    lines += [f"written: {summary['report']}"] if "report" in summary else []
    lines += format_suggestion(summary["suggestion"]) if "suggestion" in summary else []
    lines.append(f"({summary['seconds']:.1f} s)")
    return "\n".join(lines) + "\n"
