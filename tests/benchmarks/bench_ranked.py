"""Benchmark of a free decay's diagnosis ranked on the averaged forms first (#40 item 3; run on demand:
``python tests/benchmarks/bench_ranked.py [--families phone,node] [--seeds 0-4] [--complete 2] [--scaling]``).

For each record of the families (``tests/record_families.py``, 20 s, every hidden effect × the
seeds; base ``modal_damping``, the default window and modes), in one warm process, CPU seconds
(``time.process_time``; every request run here, one after the other):

- ``preview``: the base model's linear preview alone (the baseline of the ratios);
- ``ranked``: the diagnosis stream from its start to the Step that carries the averaged ranking
  and its verdict (base preview, residual report, every candidate scored on the curves);
- ``complete`` (the first ``--complete`` seeds of each effect): the whole diagnosis (the full fits
  of the linear candidates and of the nonlinear ones named missing on the curves, the ladder,
  the distance to the noise, the climb).

It prints, per record, whether the averaged ranking names the hidden effect (its leader, or one
the curves cannot tell from it) and whether the complete report names the same one; then the
median and slowest of each figure and their ratio to the preview. ``--scaling``: the ranked
verdict of one 4 kHz record of 5, 20 and 60 s (the accelerometer family, no hidden effect).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from record_families import EFFECTS, _draws, make_record  # noqa: E402

from beam.calibration import CalibrationSpec, Engine, calibration_preview  # noqa: E402
from beam.discovery.findings import DiagnosisReport, indistinguishable  # noqa: E402
from beam.discovery.stream import WAIT, BaseRequest, CheckRequest, CurveRequest, FitRequest, Step  # noqa: E402
from beam.discovery.stream import diagnosis_stream, run_request  # noqa: E402

BASE = ("modal_damping",)


def named(report: DiagnosisReport) -> set[str]:
    """What a report names missing: its leader and the candidates the data cannot tell from it ({"none"}: nothing)."""
    missing = report.ranking.missing
    return {"none"} if missing is None else {missing, *indistinguishable(report.ranking)}


def run(measurement, complete: bool) -> dict:
    """Drive the stream here, every request run inline; the CPU at the averaged Step and at the end."""
    engine = Engine()
    t0 = time.process_time()
    stream = diagnosis_stream(engine, measurement, CalibrationSpec(effects=BASE))
    out: dict = {"full_before_averaged": 0}
    asked: list = []
    ready: list = []
    try:
        event = next(stream)
        while True:
            if event is WAIT:
                if not ready:
                    ready.extend(run_request(r, measurement, engine) for r in asked)
                    asked.clear()
                event = stream.send(ready.pop(0))
                continue
            if isinstance(event, (BaseRequest, FitRequest, CheckRequest, CurveRequest)):
                if isinstance(event, FitRequest) and "ranked" not in out:
                    out["full_before_averaged"] += 1
                asked.append(event)
            elif isinstance(event, Step) and event.report is not None and event.report.source == "averaged":
                out["ranked"] = time.process_time() - t0
                out["averaged"] = named(event.report)
                out["verdict"] = event.report.verdict
                if not complete:
                    return out
            elif isinstance(event, DiagnosisReport):
                out["complete"] = time.process_time() - t0
                out["full"] = named(event)
            event = next(stream)
    except StopIteration:
        pass
    finally:
        stream.close()
    return out


def preview_cpu(measurement) -> float:
    t0 = time.process_time()
    calibration_preview(measurement, CalibrationSpec(effects=BASE))
    return time.process_time() - t0


def summary(label: str, values: list[float], previews: list[float]) -> None:
    if not values:
        return
    ratios = [v / p for v, p in zip(values, previews)]
    print(f"{label:10s} median {statistics.median(values):6.2f} s, slowest {max(values):6.2f} s "
          f"(slowest / median {max(values) / statistics.median(values):.2f}); ratio to the preview median "
          f"{statistics.median(ratios):.1f}, slowest {max(ratios):.1f}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--families", default="phone,node")
    parser.add_argument("--seeds", default="0-4")
    parser.add_argument("--complete", type=int, default=1, help="seeds of each effect diagnosed to the end")
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--scaling", action="store_true")
    args = parser.parse_args()
    low, _, high = args.seeds.partition("-")
    seeds = range(int(low), int(high or low) + 1)
    warm = make_record("phone", "none", 0, duration=args.duration).measurement
    run(warm, complete=False)  # imports and compiled kernels
    rows = []
    print(f"{'record':48s} {'samples':>7s} {'preview':>7s} {'ranked':>7s} {'complete':>8s}  averaged names / full names")
    for family in args.families.split(","):
        for effect in EFFECTS:
            for seed in seeds:
                record = make_record(family, effect, seed, duration=args.duration)
                m = record.measurement
                p = preview_cpu(m)
                out = run(m, complete=seed - seeds[0] < args.complete)
                out.update(preview=p, truth=effect, name=record.name)
                rows.append(out)
                print(f"{record.name:48s} {m.sample_count:7d} {p:7.2f} {out.get('ranked', float('nan')):7.2f} "
                      f"{out.get('complete', float('nan')):8.2f}  {'+' if effect in out.get('averaged', ()) else '-'}"
                      f"{sorted(out.get('averaged', ()))} / {sorted(out.get('full', ())) if 'full' in out else ''}",
                      flush=True)
    ranked = [r for r in rows if "ranked" in r]
    hits = sum(r["truth"] in r["averaged"] for r in ranked)
    print(f"\naveraged ranking names the truth: {hits}/{len(ranked)} ({100 * hits / max(len(ranked), 1):.0f} %)")
    both = [r for r in ranked if "full" in r]
    same = sum(bool(r["averaged"] & r["full"]) for r in both)
    print(f"same leader as the complete report: {same}/{len(both)}; full fits before the averaged ranking: "
          f"{sum(r['full_before_averaged'] for r in rows)}")
    summary("preview", [r["preview"] for r in ranked], [r["preview"] for r in ranked])
    summary("ranked", [r["ranked"] for r in ranked], [r["preview"] for r in ranked])
    summary("complete", [r["complete"] for r in both], [r["preview"] for r in both])
    if args.scaling:
        seed = next(s for s in range(100) if _draws("accelerometer", "none", s)["rate_acc"] == 4000.0)
        print(f"\nscaling (accelerometer/none/{seed}, 4 kHz):")
        for duration in (5.0, 20.0, 60.0):
            m = make_record("accelerometer", "none", seed, duration=duration).measurement
            p = preview_cpu(m)
            out = run(m, complete=False)
            print(f"  {duration:4.0f} s, {m.sample_count:6d} samples: preview {p:6.2f} s, ranked verdict "
                  f"{out['ranked']:6.2f} s ({1e6 * out['ranked'] / m.sample_count:.1f} µs a sample)", flush=True)


if __name__ == "__main__":
    main()
