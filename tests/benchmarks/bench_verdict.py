"""The one rule's verdicts on records made to stand in for other labs (run on demand:
``python tests/benchmarks/bench_verdict.py [phone] [steel48] [steel32] [joint] [shared]``).

- ``phone``: a phone (170 g, stated approximately) taped 3 cm from the tip of a 30 cm strip, 400 Hz
  with jittered stamps, a clamp that slips (``tests/stand_ins.phone_strip``);
- ``steel48``, ``steel32``: steel bars 4.8 and 3.2 mm thick, a strain gauge 2 cm from the clamp, a
  clamp that slips (``tests/stand_ins.steel_bar``);
- ``joint``: one strip at 30/40/50/60 cm with a 4 g sensor and a 233 N m/rad clamp
  (``tests/stand_ins.joint_strip``), jointly;
- ``shared``: the five shared 50 cm runs (``../shared/real-data``), windows 0-2 and 0-6 s: the
  base (air + Kelvin-Voigt, and modal damping) and each linear frequency candidate, their errors in
  the window, after it forward and re-anchored (``beam.discovery.held_out``).

Prints each diagnosis's candidates with their judgement, the verdict, and its CPU time
(``time.process_time``, the process's own: the machine is shared).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests import stand_ins as si  # noqa: E402


def single(name: str, record) -> None:
    from beam.discovery.report import diagnose

    t0 = time.process_time()
    report = diagnose(record)
    cpu = time.process_time() - t0
    print(f"== {name}: {cpu:.1f} s of CPU")
    for c in report.candidates:
        print(f"  {c.effect:18s} {c.delta_log_evidence:+10.1f}  {c.status:18s} {c.judgement.reason()}")
    print("  verdict:", report.verdict)
    print("  repair:", report.repair_command())
    for note in report.bound_notes:
        print("  note:", note)


def joint() -> None:
    from beam.discovery.joint import joint_diagnose

    records = [si.joint_strip(length, seed=k) for k, length in enumerate(si.JOINT_LENGTHS)]
    t0 = time.process_time()
    diagnosis = joint_diagnose(records, window=(0.0, 2.0), modes=2, base="modal_damping")
    print(f"== joint strip, four lengths: {time.process_time() - t0:.1f} s of CPU")
    print("  ladder:", [r.added for r in diagnosis.ladder])
    print("  verdict:", diagnosis.verdict())


def shared() -> None:
    from beam.calibration import calibration_preview
    from beam.discovery.held_out import reanchored_rmse
    from beam.io.measurement import read_measurement

    runs = sorted((ROOT.parent / "shared" / "real-data").glob("*.csv")) or sorted((ROOT / "assets" / "real").glob("*.csv"))
    for path in runs:
        record = read_measurement(path)
        for window in ((0.0, 2.0), (0.0, 6.0)):
            for base in (("air_damping", "kelvin_voigt"), ("modal_damping",)):
                rows = []
                for extra in ((), ("sensor_mass",), ("clamp_compliance",), ("tip_mass",)):
                    r = calibration_preview(record, window=window, effects=base + extra, modes=4)
                    rows.append((extra[0] if extra else "base", r.rmse_calibration_map, r.rmse_prediction_map,
                                 reanchored_rmse(r)))
                change = ", ".join(f"{e} {100 * (h / rows[0][3] - 1):+.1f} %" for e, _, _, h in rows[1:])
                print(f"{path.stem} {window} {'+'.join(base)}: re-anchored after the window: base "
                      f"{rows[0][3]:.4f} ({rows[0][2]:.4f} forward); {change}")


if __name__ == "__main__":
    wanted = sys.argv[1:] or ["phone", "steel48", "steel32", "joint", "shared"]
    if "phone" in wanted:
        single("phone on a 30 cm strip", si.phone_strip())
    if "steel48" in wanted:
        single("4.8 mm steel bar, strain gauge", si.steel_bar(0.0048))
    if "steel32" in wanted:
        single("3.2 mm steel bar, strain gauge", si.steel_bar(0.0032))
    if "joint" in wanted:
        joint()
    if "shared" in wanted:
        shared()
