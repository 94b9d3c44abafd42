"""The diagnosis's climb, screened against full (run on demand: ``python tests/benchmarks/bench_climb.py``).

``beam diagnose`` (:func:`beam.discovery.report.diagnose`) on each record twice: as it runs (the
climb's candidates screened by the engine's first stage, the rung it adds fitted by both stages:
:func:`beam.discovery.report.climb_on`) and with both stages for every candidate of the climb.
Prints, per record and window, whether the two ladders are the same (effects, held-out RMSE and
log evidence of every rung) and the process CPU of each.

Records: the bundled teaching records at the default window (30 % of the record), lab_run_1 and
lab_run_2 at 20 % and 45 %, and records with two hidden effects simulated here from the bundled
runs' configs (``assets/answers``) with a second effect added (``--no-pairs`` skips them).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration.engine import forget_maps  # noqa: E402
from beam.discovery import report  # noqa: E402
from beam.io.config import load_config  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402
from beam.io.simulation import simulate, write_simulation  # noqa: E402

#: Records with two hidden effects: (bundled run whose config is used, the effect's parameters added).
PAIRS = {
    "tip_mass+clamp": ("lab_run_2", {"clamp_stiffness_Nm_rad": 25.0}),
    "clamp+tip_mass": ("lab_run_3", {"tip_mass_kg": 0.002}),
    "tip_mass+patch": ("lab_run_2", {"patch_added_density_kg_m": 0.25, "patch_added_stiffness_Nm2": 0.4}),
    "spring+tip_mass": ("lab_run_4", {"tip_mass_kg": 0.004}),
    "tip_mass+clamp (no patch effect)": ("lab_run_5", {"tip_mass_kg": 0.004, "clamp_stiffness_Nm_rad": 30.0}),
}


def pair_record(folder: Path, name: str, run: str, extra: dict[str, float]) -> Path:
    """Simulate the config of ``run`` with ``extra`` parameters added; the record's CSV path."""
    text = (ROOT / "assets" / "answers" / f"{run}.config.toml").read_text()
    added = "".join(f"{key} = {value}\n" for key, value in extra.items())
    config_path = folder / f"{len(list(folder.glob('*.config.toml')))}.config.toml"
    config_path.write_text(text.replace("[parameters]\n", "[parameters]\n" + added, 1))
    prefix = config_path.with_suffix("").with_suffix("")
    write_simulation(prefix, simulate(load_config(config_path)))
    return prefix.with_suffix(".csv")


def ladder_of(measurement, window, full_climb: bool) -> tuple[list, float]:
    """The ladder of :func:`beam.discovery.report.diagnose` and its process CPU (s), from nothing
    remembered; ``full_climb``: the climb's candidates fitted by both stages (``screen=False``)."""
    forget_maps()
    t0 = time.process_time()
    diagnosis = report.diagnose(measurement, window=window, screen=not full_climb)
    cpu = time.process_time() - t0
    return [(s.added, round(s.rmse_prediction * 1e6, 2), round(s.log_evidence, 2)) for s in diagnosis.ladder], cpu


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--no-pairs", action="store_true", help="skip the records with two hidden effects")
    args = parser.parse_args(argv)
    cases = [(path.stem, read_measurement(path), 0.3) for path in sorted((ROOT / "assets" / "measurements").glob("*.csv"))]
    cases += [(name, read_measurement(ROOT / "assets" / "measurements" / f"{name}.csv"), fraction)
              for name in ("lab_run_1", "lab_run_2") for fraction in (0.2, 0.45)]
    with tempfile.TemporaryDirectory() as folder:
        if not args.no_pairs:
            cases += [(name, read_measurement(pair_record(Path(folder), name, run, extra)), 0.3)
                      for name, (run, extra) in PAIRS.items()]
        same = 0
        for name, measurement, fraction in cases:
            t = measurement.time_s
            window = (float(t[0]), float(t[0] + fraction * (t[-1] - t[0])))
            screened, cpu_screened = ladder_of(measurement, window, full_climb=False)
            full, cpu_full = ladder_of(measurement, window, full_climb=True)
            same += screened == full
            print(f"{name:34s} {fraction:4.2f}  {'same' if screened == full else 'DIFFERENT'}  "
                  f"CPU screened {cpu_screened:5.1f} s, full {cpu_full:5.1f} s  "
                  f"ladder: {' -> '.join(str(added or 'base') for added, _, _ in screened)}", flush=True)
            if screened != full:
                print(f"    screened {screened}\n    full     {full}")
    print(f"same ladder in {same} of {len(cases)} cases")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
