"""``beam study DATA...``: a calibration-window study (many calibrations) on Dask, with resume."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

from beam.cli.arguments import HelpFormatter, effects_epilog, measurement_path, modes_choice, non_negative_int, positive_int

#: Output prefix when ``--out`` is not given (in the current folder).
DEFAULT_OUT = "beam-study"


def window_spec(text: str):
    """argparse type of ``--windows`` (see :mod:`beam.study.windows`)."""
    from beam.errors import BeamInputError
    from beam.study.windows import parse_windows

    try:
        return parse_windows(text)
    except BeamInputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``study`` subcommand."""
    parser = subparsers.add_parser(
        "study",
        help="calibration-window study: one calibration per record, window, effect set and likelihood",
        description="Calibrate every (record, window, effect set, likelihood) cell with the engine of `beam calibrate` "
        "(the same numbers with the same options and seed) and score its prediction of the rest of the record: "
        "held-out RMSE, coverage of the 95 % band, interval width, posterior summaries, ESS, R-hat, seconds. Cells "
        "run as tasks on Dask (a local cluster of single-threaded worker processes, or --scheduler); each finished "
        "cell is stored under PREFIX.cells/ and reused by a later run with the same record content, options, seed "
        "and code (an interrupted study resumes). Writes PREFIX.csv (one row per cell), PREFIX.summary.csv (across "
        "records) and PREFIX.nc (posterior draws, ArviZ). Exit status 1 when a cell failed (its error is in the table).",
        epilog=effects_epilog(),
        formatter_class=HelpFormatter,
    )
    parser.add_argument("data", metavar="DATA", nargs="+", type=measurement_path,
                        help="measurements: NAME.csv, NAME.toml or NAME; a bundled run (e.g. lab_run_1) by its name")
    parser.add_argument("--windows", type=window_spec, default=None, metavar="SPEC",
                        help="calibration windows (s): a list 0:0.5,0:1,1:2; grow:START:STEP:END (0-0.25, 0-0.5, ... "
                        "with grow:0:0.25:4); slide:LENGTH:START:STEP:END (windows of LENGTH s every STEP s, ending "
                        "by END). Default: windows from the record's start ending at 10, 20, ..., 60 %% of it")
    parser.add_argument("--effects", default="air_damping,kelvin_voigt", metavar="SETS",
                        help="effect sets separated by ';', each as `beam calibrate --effects` takes it "
                        "(default air_damping,kelvin_voigt)")
    parser.add_argument("--likelihood", default="iid", metavar="iid,ar1",
                        help="iid, ar1 or both comma-separated (default iid)")
    parser.add_argument("--modes", type=modes_choice, default="auto", metavar="N",
                        help="retained modes, or auto (default: chosen per window from the record's excited band)")
    parser.add_argument("--seed", type=non_negative_int, default=0, metavar="S", help="random seed of every cell (default 0)")
    parser.add_argument("--steps", type=positive_int, default=None, metavar="S",
                        help="as `beam calibrate --steps` (default: sample until every parameter has ESS >= 1000)")
    parser.add_argument("--walkers", type=positive_int, default=None, metavar="W", help="as `beam calibrate --walkers`")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="a running Dask scheduler, tcp://HOST:PORT (default: $DASK_SCHEDULER_ADDRESS, else a "
                        "local cluster)")
    parser.add_argument("--workers", type=positive_int, default=None, metavar="N",
                        help="worker processes of the local cluster (default: the machine's cores)")
    parser.add_argument("--out", default=DEFAULT_OUT, metavar="PREFIX",
                        help=f"output prefix: PREFIX.csv, PREFIX.summary.csv, PREFIX.nc, PREFIX.cells/ (default {DEFAULT_OUT})")
    parser.add_argument("--json", action="store_true", help='print {"cells": [...]} as one JSON object')
    parser.add_argument("--report", default=None, metavar="FILE.html",
                        help="also write a one-page report (self-contained HTML: error and coverage against the "
                        "window, credible intervals against the window, the table)")
    parser.set_defaults(func=run)


class _Progress:
    """A bar on a terminal (cells done / total, time left), else one line per cell, on stderr."""

    def __init__(self, total: int, stream=None):
        self.stream = stream or sys.stderr
        self.total = total
        self.bar = None
        self.t0 = time.monotonic()
        if self.stream.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit="cell", file=self.stream, dynamic_ncols=True,
                            bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} cells [{elapsed}<{remaining}]")

    def __call__(self, entry: dict, done: int, total: int) -> None:
        if self.bar is not None:
            if entry["reused"]:
                self.bar.n = done  # not timed: the rate is that of computed cells
                self.bar.last_print_n = done
                self.bar.refresh()
            else:
                self.bar.update(done - self.bar.n)
            return
        self.stream.write(f"[{done}/{total}] {describe(entry)}\n")
        self.stream.flush()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def describe(entry: dict) -> str:
    """One line for a cell: identity, then its held-out numbers, reuse, or its error."""
    row, extra = entry["row"], entry["extra"]
    lo, hi = row["window"]
    head = f"{row['record']} {lo:g}–{hi:g} s {'+'.join(row['effects']) or 'none'} {row['likelihood']}"
    if row["error"]:
        return f"{head}: failed: {row['error']}"
    factor, unit = (1e3, "mm") if extra.get("output_unit", "m") == "m" else (1.0, extra.get("output_unit", ""))
    rmse = row["rmse_prediction"]
    rmse_text = "n/a" if rmse is None else f"{rmse * factor:.3g} {unit}"
    cover = row["coverage95_prediction"]
    cover_text = "n/a" if cover is None else f"{100 * cover:.0f} %"
    when = "reused" if entry["reused"] else f"{row['seconds']:.1f} s"
    return f"{head}: held-out RMSE {rmse_text}, coverage {cover_text} ({when})"


def run(args: argparse.Namespace) -> int:
    from beam.errors import BeamInputError
    from beam.io.measurement import read_measurement

    if args.report is not None and not str(args.report).lower().endswith((".html", ".htm")):
        raise BeamInputError(f"--report must name an .html file, got {args.report!r}")
    measurements = [(path, read_measurement(path)) for path in args.data]  # a bad file fails before the heavy imports
    from beam.study.engine import scheduler_address
    from beam.study.run import parse_effect_sets, parse_likelihoods, run_study, study_cells

    if args.workers is not None and scheduler_address(args.scheduler) is not None:
        raise BeamInputError("--workers sizes a local cluster; with a scheduler the cluster has its own workers")
    effect_sets = parse_effect_sets(args.effects)
    likelihoods = parse_likelihoods(args.likelihood)
    names = [m.name for _, m in measurements]
    records = [(m.name if names.count(m.name) == 1 else path, m) for path, m in measurements]
    cells = study_cells(records, args.windows, effect_sets, likelihoods, modes=args.modes, seed=args.seed,
                        steps=args.steps, walkers=args.walkers)
    progress = _Progress(len(cells))
    try:
        result = run_study(records, cells, out=args.out, scheduler=args.scheduler, workers=args.workers,
                           on_cell=progress)
    finally:
        progress.close()
    written = [str(p) for p in result.written]
    if args.report:
        from beam.io.text import atomic_write_texts
        from beam.study.report import study_handout
        from beam.study.store import cell_table, summary_table

        table = cell_table(result.entries)
        html = study_handout(table, summary_table(table), result.computed, result.reused)
        written.append(str(atomic_write_texts({args.report: html})[0]))
    failed = sum(row["error"] is not None for row in result.rows)
    if args.json:
        json.dump({"cells": [_nan_to_none(row) for row in result.rows]}, sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        lines = [describe(entry) for entry in result.entries]
        lines += ["", f"{len(result.entries)} cells: {result.computed} computed, {result.reused} reused, {failed} failed"]
        lines += [f"written: {path}" for path in written]
        sys.stdout.write("\n".join(lines) + "\n")
    return 1 if failed else 0


def _nan_to_none(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _nan_to_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_nan_to_none(v) for v in value]
    return value
