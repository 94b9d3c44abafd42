"""``beam diagnose DATA``: where the model fails, which effect is missing, and the error ladder."""

from __future__ import annotations

import argparse
import json
import sys

from beam.cli.arguments import HelpFormatter, effects_epilog, non_negative_int
from beam.cli.calibrate_command import add_model_arguments


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``diagnose`` subcommand."""
    parser = subparsers.add_parser(
        "diagnose",
        help="find which physical effect the model is missing",
        description="Calibrate the base model on the window (MAP + Laplace), examine its residuals (band exceedances, "
        "spectrum, whiteness, identified modes, amplitude dependence), rank every catalogue effect not in the model "
        "by Laplace evidence and held-out error, and climb the error ladder.",
        epilog=effects_epilog(),
        formatter_class=HelpFormatter,
    )
    add_model_arguments(parser)
    parser.add_argument("--base", default="air_damping,kelvin_voigt", metavar="A,B",
                        help="effects of the current model (default air_damping,kelvin_voigt; '' for the bare beam)")
    parser.add_argument("--mcmc", action="store_true", help="re-calibrate every ladder step with full MCMC (slower)")
    parser.add_argument("--seed", type=non_negative_int, default=0, metavar="S", help="random seed of the MCMC (default 0)")
    parser.add_argument("--json", action="store_true", help="print the report as one JSON object")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from beam.cli.record_arguments import measurement_from_args

    measurement = measurement_from_args(args)  # a bad file fails before the heavy imports
    from beam.discovery.report import diagnose

    report = diagnose(measurement, window=args.window, modes=args.modes, base=args.base, ladder_mcmc=args.mcmc,
                      seed=args.seed)
    summary = report.to_json()
    if args.json:
        json.dump(summary, sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_report(summary))
    return 0


def _m(value) -> str:
    return "n/a" if value is None else f"{value:.3g}"


def format_report(summary: dict) -> str:
    """A readable report of a diagnosis."""
    from beam.residuals.modal_id import DIFFERENCE_CONVENTION

    lines = [
        f"{summary['measurement']}: window {summary['window_s'][0]:g}-{summary['window_s'][1]:g} s, {summary['modes']} modes, "
        f"base model: {', '.join(summary['base']) or 'bare beam'}",
        *([f"modes: {summary['modes']}, chosen: {summary['modes_reason']}"] if summary.get("modes_reason") else []),
        f"held-out RMSE of the base model {_m(summary['rmse_prediction_base'])} {summary.get('output_unit', 'm')}, coverage of its 95% band "
        f"{_m(summary['coverage95_prediction_base'])}",
        "",
        f"modes (data vs model; data vs model %: {DIFFERENCE_CONVENTION})",
        f"  {'mode':>4s} {'f data (Hz)':>12s} {'f model (Hz)':>13s} {'data vs model %':>16s} {'zeta data':>10s} {'zeta model':>11s}",
    ]
    for row in summary["modes_table"]:
        lines.append(f"  {row['mode']:>4d} {_m(row['frequency_data_Hz']):>12s} {_m(row['frequency_model_Hz']):>13s} "
                     f"{_m(row['frequency_error_pct']):>16s} {_m(row['damping_data']):>10s} {_m(row['damping_model']):>11s}"
                     + (f"  not seen: {row['note']}" if row.get("note") else ""))
    lines += ["", "candidate effects, best first",
              f"  {'effect':18s} {'Δ log evidence':>15s} {'held-out RMSE':>18s}  why"]
    for c in summary["candidates"]:
        mark = "*" if c["material"] else " "
        lines.append(f"{mark} {c['effect']:18s} {_m(c['delta_log_evidence']):>15s} {_m(c['rmse_prediction']):>18s}  {c['explanation']}")
    lines += ["", "error ladder"]
    for step in summary["ladder"]:
        name = "base" if step["added"] is None else f"+ {step['added']}"
        unit = summary.get("output_unit", "m")
        lines.append(f"  {name:22s} RMSE calibration {_m(step['rmse_calibration'])} {unit}, prediction {_m(step['rmse_prediction'])} {unit}, "
                     f"coverage {_m(step['coverage95_prediction'])}")
    lines += ["", summary["verdict"]] + [f"note: {n}" for n in summary["notes"]]
    lines.append(f"({summary['seconds']:.1f} s)")
    return "\n".join(lines) + "\n"
