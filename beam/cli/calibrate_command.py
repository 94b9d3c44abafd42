"""``beam calibrate DATA [DATA ...]``: calibrate the beam on a window of a measurement, predict the rest.

Several records of one beam (each with its own sidecar) are calibrated jointly
(:mod:`beam.calibration.joint`): ``--shared`` / ``--per-record`` say which physical parameters
are shared; the JSON adds a ``records`` list. One record keeps the single calibration's output.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from beam.cli.arguments import (
    HelpFormatter,
    effect_list,
    effects_epilog,
    measurement_path,
    modes_choice,
    non_negative_int,
    positive_int,
    time_window,
)
from beam.calibration.defaults import AUTO_MODES
from beam.calibration.spec import CalibrationSpec
from beam.cli.record_arguments import add_record_arguments, check_joint_arguments, measurement_from_args, several_records

LIKELIHOOD_CHOICES = ("iid", "ar1")


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """--window and --modes, shared with ``beam diagnose`` (defaults: :class:`~beam.calibration.spec.CalibrationSpec`'s)."""
    defaults = CalibrationSpec()
    parser.add_argument("data", metavar="DATA", type=measurement_path, nargs="+",
                        help="measurement: NAME.csv, NAME.toml or NAME; a bundled run (e.g. lab_run_1) by its name; or a "
                        "record in another format (phyphox, .lvm, .mat, .npy, ...; see beam import). Several records of "
                        "one beam (each with its own sidecar: length, sensor position, input) are calibrated jointly")
    parser.add_argument("--window", type=time_window, default=defaults.window, metavar="START:END",
                        help=f"calibration window in seconds, e.g. 0:1.5 (default: the first "
                        f"{100 * defaults.window_fraction:g} %% of the record)")
    parser.add_argument("--modes", type=modes_choice, default=defaults.modes, metavar="N",
                        help=f"retained modes, or auto (default: {_modes_text(defaults.modes)})")
    add_record_arguments(parser)


def _modes_text(modes) -> str:
    return "chosen from the record's excited band" if modes == AUTO_MODES else str(modes)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``calibrate`` subcommand."""
    parser = subparsers.add_parser(
        "calibrate",
        help="Bayesian calibration of the beam on a window of a measurement",
        description="Calibrate base (bending_stiffness_Nm2, patch_coupling_NmV) + effects on the window, then predict "
        "the rest of the record: posterior summaries, noise sd, RMSE in the calibration and prediction windows, "
        "coverage of the 95 % prediction band on the held-out samples, ESS, R-hat, correlations.",
        epilog=effects_epilog(),
        formatter_class=HelpFormatter,
    )
    add_model_arguments(parser)
    defaults = CalibrationSpec()
    effects = ",".join(defaults.effects)
    parser.add_argument("--effects", default=effects, type=effect_list, metavar="A,B,...",
                        help=f"effects added to the base model (default {effects or 'none'}; '+A,B' adds A and B to "
                        f"that default, keeping its damping; '' for none)")
    parser.add_argument("--likelihood", choices=LIKELIHOOD_CHOICES, default=defaults.likelihood,
                        help=f"iid Gaussian noise or AR(1) correlated residuals (default {defaults.likelihood})")
    parser.add_argument("--walkers", type=positive_int, default=defaults.walkers, metavar="W",
                        help="emcee walkers (default 2 x 4 ensembles x parameters)")
    parser.add_argument("--steps", type=positive_int, default=defaults.steps, metavar="S",
                        help=f"ensemble steps (default: sample until every parameter has ESS >= {defaults.target_ess:g})")
    parser.add_argument("--seed", type=non_negative_int, default=defaults.seed, metavar="S",
                        help=f"random seed (default {defaults.seed})")
    add_joint_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.add_argument("--save", default=None, metavar="PREFIX",
                        help="also write PREFIX.nc (ArviZ InferenceData) and PREFIX.band.csv (predictive band)")
    parser.add_argument("--report", default=None, metavar="FILE.html",
                        help="also write a one-page printable summary (self-contained HTML: key numbers, the "
                        "record with the model and its bands, the parameters)")
    parser.set_defaults(func=run)


def add_joint_arguments(parser: argparse.ArgumentParser) -> None:
    """--shared and --per-record (several records only), shared with ``beam diagnose``."""
    parser.add_argument("--shared", default=None, metavar="A,B,...",
                        help="several records: only these physical parameters are shared (default: all of them)")
    parser.add_argument("--per-record", default=None, metavar="A,B,...",
                        help="several records: physical parameters calibrated per record, e.g. clamp_stiffness when the "
                        "strip was re-clamped (the noise sd, the offset and a free response's initial state always are)")


def spec_of(args: argparse.Namespace) -> CalibrationSpec:
    """The :class:`~beam.calibration.spec.CalibrationSpec` of the parsed arguments."""
    return CalibrationSpec(window=args.window, effects=args.effects, modes=args.modes, likelihood=args.likelihood,
                           walkers=args.walkers, steps=args.steps, seed=args.seed)


def run(args: argparse.Namespace) -> int:
    if several_records(args):
        return run_joint(args)
    measurement = measurement_from_args(args, effects=args.effects)  # a bad file fails before the heavy imports
    taps = len(measurement.taps) if getattr(args, "segment", None) is None else 1
    check_joint_arguments(args, taps)
    if taps > 1:
        return run_taps(args, measurement)
    from beam.cli.progress_line import progress_line

    spec = spec_of(args)
    with progress_line(args, f"calibrating {' + '.join(spec.effects)} on {measurement.name}"):
        from beam.calibration import calibrate

        result = calibrate(measurement, spec)
    summary = result.to_json()
    if args.save:
        summary["saved"] = [str(p) for p in result.save(args.save)]
    if args.report:
        from beam.calibration.handout import calibration_handout
        from beam.io.text import atomic_write_texts

        summary["report"] = str(atomic_write_texts({args.report: calibration_handout(result)})[0])
    if args.json:
        from beam.residuals.common import jsonable

        json.dump(jsonable(summary), sys.stdout, allow_nan=False)  # NaN (no held-out part) -> null
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_summary(summary))
    return 0


def run_joint(args: argparse.Namespace) -> int:
    """``beam calibrate A B ...``: the joint calibration (:func:`beam.calibration.joint.joint_calibrate`)."""
    from beam.cli.record_arguments import measurements_from_args

    measurements = measurements_from_args(args, effects=args.effects)  # bad files fail before the heavy imports
    from beam.calibration.joint import joint_calibrate
    from beam.io.taps import tap_measurements

    if getattr(args, "segment", None) is None:  # a file of several taps brings every tap
        measurements = [tap for m in measurements for tap in tap_measurements(m)]
    from beam.cli.progress_line import progress_line

    with progress_line(args, f"calibrating {len(measurements)} records together"):
        result = joint_calibrate(measurements, spec_of(args), per_record=args.per_record, shared=args.shared)
    return print_joint(args, result.to_json(), format_joint_summary)


def run_taps(args: argparse.Namespace, measurement) -> int:
    """``beam calibrate FILE`` of a record of several taps: every tap calibrated together
    (:func:`beam.calibration.joint.joint_calibrate` on :func:`beam.io.taps.tap_measurements`;
    ``--per-record air_damping`` gives each tap its own damping, to read it against the tap's
    peak), the taps listed in the summary (``taps``, ``taps_words``)."""
    from beam.errors import BeamInputError

    for flag in ("save", "report"):
        if getattr(args, flag, None) is not None:
            raise BeamInputError(f"--{flag} takes one record; {measurement.name} holds {len(measurement.taps)} taps, "
                                 "calibrated together: give --segment K to calibrate tap K alone")
    from beam.calibration.joint import joint_calibrate
    from beam.io.taps import tap_measurements

    result = joint_calibrate(tap_measurements(measurement), spec_of(args), per_record=args.per_record, shared=args.shared)
    return print_joint(args, {**result.to_json(), **taps_summary(measurement)}, format_joint_summary)


def taps_summary(measurement, diagnosis: bool = False) -> dict:
    """The JSON of a record's taps: ``taps`` (``tap``, ``record``, ``start_s``, ``end_s``, ``peak``
    in the output's SI unit) and ``taps_words`` (:func:`beam.io.taps.taps_words`)."""
    from beam.io.taps import taps_words

    return {"taps": [{"tap": tap.index, "record": tap.measurement.name, "start_s": tap.start_s, "end_s": tap.end_s,
                      "peak": tap.peak} for tap in measurement.taps],
            "taps_words": taps_words(measurement, diagnosis)}


def print_joint(args: argparse.Namespace, summary: dict, readable) -> int:
    """Print a joint command's summary: one JSON object with ``--json`` (NaN as null), else
    ``readable(summary)``; exit status 0."""
    if args.json:
        from beam.residuals.common import jsonable

        json.dump(jsonable(summary), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(readable(summary))
    return 0


def format_joint_summary(summary: dict) -> str:
    """A readable report of a joint calibration: the shared parameters, then one line per record
    (a record's taps: the sentence of :func:`beam.io.taps.taps_words` first, each tap's peak on its line)."""
    from beam.io.artifacts import amount_text

    peaks = {tap["record"]: tap for tap in summary.get("taps", [])}
    lines = [summary["taps_words"], ""] if summary.get("taps_words") else []
    lines += [f"joint calibration of {len(summary['records'])} records, effects: {', '.join(summary['effects']) or 'none'}, "
             f"likelihood {summary['likelihood']}"
             + (f", per record: {', '.join(summary['per_record'])}" if summary["per_record"] else ""), "",
             f"{'shared parameter':32s} {'mean':>12s} {'sd':>11s} {'2.5 %':>12s} {'97.5 %':>12s}"]
    for name, s in summary["parameters"].items():
        lines.append(f"{name:32s} {s['mean']:12.5g} {s['sd']:11.3g} {s['q025']:12.5g} {s['q975']:12.5g}")
    for record in summary["records"]:
        unit = record.get("output_unit", "m")
        own = ", ".join(f"{name} {s['mean']:.5g}" for name, s in record["parameters"].items())
        tap = peaks.get(record["record"])
        where = (f" (tap {tap['tap']}, {tap['start_s']:.3f}-{tap['end_s']:.3f} s of the file, peak "
                 f"{amount_text(tap['peak'], unit)})" if tap else "")
        lines += ["", f"{record['record']}{where}: window {format_window(record['window_s'])}, {record['modes']} modes"
                  + (f"; {own}" if own else ""),
                  f"  f (Hz) {', '.join(f'{f:.4g}' for f in record['frequencies_Hz'])}; noise sd "
                  f"{_in_unit(record['noise_sd']['mean'] if record['noise_sd'] else None, unit)}; RMSE calibration "
                  f"{_in_unit(record['rmse_calibration'], unit)}, held-out {_in_unit(record['rmse_prediction'], unit)}, "
                  f"held-out inside the 95 % band {_percent(record['coverage95_prediction'])}"]
    lines += ["", f"ESS min {_number(summary['ess_min'])}, R-hat max {_number(summary['rhat_max'])}, "
              f"{'converged' if summary['converged'] else 'NOT converged'}; {summary['seconds']:.2f} s"]
    lines += [f"warning: {w}" for w in summary["warnings"]]
    return "\n".join(lines) + "\n"


def format_window(window_s) -> str:
    """``[0, 1.0497]`` -> ``"0–1.05 s"`` (3 significant digits: the sampling step of the bundled runs is 0.2 ms)."""
    return f"{_readable(window_s[0])}–{_readable(window_s[1])} s"


def format_summary(summary: dict) -> str:
    """A readable report of a calibration summary (lengths in µm, coverage in %; the JSON keeps SI units)."""
    lines = [
        f"{summary['measurement']}: calibration window {format_window(summary['window_s'])}, "
        f"{summary['modes']} modes, effects: {', '.join(summary['effects']) or 'none'}, likelihood {summary['likelihood']}",
        *([f"modes: {summary['modes']}, chosen: {summary['modes_reason']}"] if summary.get("modes_reason") else []),
        "",
        f"{'parameter':32s} {'mean':>12s} {'sd':>11s} {'2.5 %':>12s} {'97.5 %':>12s}",
    ]
    rows = dict(summary["parameters"])
    noise = summary["noise_sd"]
    unit = summary.get("output_unit", "m")
    if unit == "m":
        rows["noise_sd_um"] = {k: (v * 1e6 if isinstance(v, (int, float)) else v) for k, v in noise.items()}
    else:
        rows[f"noise_sd ({unit})"] = noise
    if "ar1_coefficient" in summary:
        rows["ar1_coefficient"] = summary["ar1_coefficient"]
    for name, s in rows.items():
        lines.append(f"{name:32s} {s['mean']:12.5g} {s['sd']:11.3g} {s['q025']:12.5g} {s['q975']:12.5g}")
    if "output_offset" in summary:
        lines.append(f"{'output_offset (' + unit + ')':32s} {summary['output_offset']:12.5g} "
                     f"{summary['output_offset_sd']:11.3g}   (profiled: the sensor's constant offset)")
    lines += [
        "",
        f"RMSE, calibration window   {_in_unit(summary['rmse_calibration'], unit)}",
        f"RMSE, held-out part        {_in_unit(summary['rmse_prediction'], unit)}",
        f"held-out data inside the 95 % prediction band: {_percent(summary['coverage95_prediction'])}",
        f"ESS min {_number(summary['ess_min'])}, R-hat max {_number(summary['rhat_max'])}, "
        f"{'converged' if summary['converged'] else 'NOT converged'}; {summary['seconds']:.2f} s",
    ]
    lines += [f"warning: {w}" for w in summary["warnings"]]
    lines += [f"written: {path}" for path in [*summary.get("saved", []), *([summary["report"]] if "report" in summary else [])]]
    return "\n".join(lines) + "\n"


def _missing(value) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value))


def _readable(x: float) -> str:
    """Three significant digits, never an exponent below 10⁶ (1271.4 -> "1271", 0.0123 -> "0.0123")."""
    return f"{x:.0f}" if abs(x) >= 1000 else f"{x:.3g}"


def _micrometres(value_m) -> str:
    return "n/a" if _missing(value_m) else f"{_readable(value_m * 1e6)} µm"


def _in_unit(value, unit: str) -> str:
    """A length in µm; another quantity in its own unit (4 significant digits)."""
    if unit == "m":
        return _micrometres(value)
    return "n/a" if _missing(value) else f"{value:.4g} {unit}"


def _percent(fraction) -> str:
    return "n/a" if _missing(fraction) else f"{100 * fraction:.1f} %"


in_unit, percent = _in_unit, _percent  # public: the diagnosis's report prints its figures so too


def _number(value) -> str:
    return "n/a" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.4g}"
