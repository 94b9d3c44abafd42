"""Amplitude-resolved identification of free decays (:func:`beam.residuals.record_backbone`) on
the stand-in record families (``tests/record_families.py``): per family, the share of records
whose backbone and damping curve agree with their truth, mode by mode, and the CPU seconds per
record (median and slowest), with their ratio to the linear preview
(:func:`beam.calibration.calibration_preview`, the default spec) on the same record in the same
run. Run on demand:

    python tests/benchmarks/bench_backbone.py [--families accelerometer,phone,...,shared]
        [--seeds 0-4] [--no-preview] [--hilbert] [--scaling]

CPU time is ``time.process_time`` (the machine is shared: wall time would measure the others'
load); the 1-minute load average is printed with each family. ``--hilbert`` adds, for mode 1 of
every simulated record, the band-pass + Hilbert envelope of :mod:`beam.residuals.envelope` (the
record put on a uniform grid first) judged by the same truth: its damping ratio per amplitude
bin within 3 of the spread of its bin plus the tolerance, on at least 80 % of the bins — the
figure behind the method's choice (``docs/decisions.md``). ``--scaling`` first times a linear
decay of the 50 cm strip (three modes, an accelerometer at 4 kHz, 50 Hz hum) of 5, 20 and 60 s,
and the 20 s one at 100, 500 and 1000 Hz: CPU against the number of samples.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import numpy as np  # noqa: E402

import record_families as families  # noqa: E402
from beam.errors import BeamInputError  # noqa: E402
from beam.residuals import record_backbone  # noqa: E402


def cpu(function):
    """(result, CPU seconds) of ``function()``."""
    start = time.process_time()
    result = function()
    return result, time.process_time() - start


def hilbert_agrees(record) -> bool | None:
    """Mode 1 by :func:`beam.residuals.analyse_mode` (band-pass + Hilbert) on the record put on a
    uniform grid at its median step (clipped samples interpolated over), its damping ratio per
    amplitude bin against the describing function at the bin's mean amplitude."""
    from beam.residuals import analyse_mode
    from beam.residuals.amplitude_id import FreeDecayBackbone, ModeBackbone

    m = record.measurement
    keep = ~m.clipped
    step = float(np.median(np.diff(m.time_s)))
    grid = np.arange(m.time_s[0], m.time_s[-1], step)
    values = np.interp(grid, m.time_s[keep], m.output[keep])
    f1 = float(record.frequencies_Hz()[0])
    try:
        analysis = analyse_mode(grid, values - np.median(values), f1, start_s=float(grid[0]), bins=8)
    except BeamInputError:
        return False
    decay = analysis.decay
    order = {"acceleration": 2, "velocity": 1}.get(m.output_kind, 0)
    a = np.asarray(decay.amplitude_m)
    zeta = np.asarray(decay.damping_ratio_by_amplitude)
    if a.size < 3:
        return False
    # the truth at the bins' amplitudes, through a stand-in identification holding them
    n = a.size
    stand_in = ModeBackbone(1, f1, True, "", np.arange(float(n)), a * (2 * np.pi * f1) ** order, np.full(n, np.nan),
                            np.full(n, f1), np.full(n, np.nan), zeta, np.full(n, np.nan), np.zeros(n),
                            np.zeros(n, dtype=int), order)
    truth = record.expected(FreeDecayBackbone((stand_in,), (), m.output_kind, (), 0, 0, 1 / step, 1 / step, 0.0))
    if truth.get(1) is None:
        return None
    _, expected, _, tolerance = truth[1]
    spread = np.std(zeta) / np.sqrt(n)  # no per-bin error is given: the bins' own scatter
    return bool(np.mean(np.abs(zeta - expected) <= 3 * spread + tolerance * expected) >= 0.8)


def scaling() -> None:
    """CPU of the identification against the record's duration and rate (module notes)."""
    from beam.io.release import simulate_release
    from beam.physics.geometry import BeamGeometry
    from beam.physics.model import BeamModel

    model = BeamModel(BeamGeometry(0.5, 0.27, None, None, 0.44, width_m=0.05), ["modal_damping"], input_kind=None)
    values = {"bending_stiffness_Nm2": 2.333, "damping_ratio_mode_1": 0.002, "damping_ratio_mode_2": 0.003,
              "damping_ratio_mode_3": 0.004}
    rng = np.random.default_rng(0)
    print("duration_s  rate_Hz  samples  cpu_s  cpu_us_per_sample  resolved_modes")
    for duration, rate in ((5, 4000), (20, 4000), (60, 4000), (20, 100), (20, 500), (20, 1000)):
        t = np.arange(0.0, duration, 1.0 / rate)
        y = simulate_release(model, values, t, 0.02, modes=3 if rate > 300 else 2)
        y = y + 0.03 * rng.standard_normal(t.size) + 0.05 * np.cos(2 * np.pi * 50.02 * t)
        from beam.residuals import identify_backbone

        identify_backbone(t, y, output="acceleration")
        result, seconds = cpu(lambda: identify_backbone(t, y, output="acceleration"))
        print(f"{duration}  {rate}  {t.size}  {seconds:.3f}  {1e6 * seconds / t.size:.2f}  {len(result.resolved)}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", default=",".join(families.FAMILIES + ("shared",)))
    parser.add_argument("--seeds", default="0-4")
    parser.add_argument("--no-preview", action="store_true")
    parser.add_argument("--hilbert", action="store_true")
    parser.add_argument("--scaling", action="store_true")
    args = parser.parse_args()
    if args.scaling:
        scaling()
    lo, _, hi = args.seeds.partition("-")
    seeds = range(int(lo), int(hi or lo) + 1)
    from beam.calibration import calibration_preview

    warm = families.make_record("accelerometer", "none", 0)
    record_backbone(warm.measurement, frequencies_Hz=warm.frequencies_Hz())  # imports, first calls
    if not args.no_preview:
        calibration_preview(warm.measurement)
    summary = []
    for name in args.families.split(","):
        records = families.family(name, seeds=seeds)
        print(f"\n## {name} ({len(records)} records; load {os.getloadavg()[0]:.1f})", flush=True)
        print("record  samples  rate_Hz  cpu_s  preview_cpu_s  ratio  agreement (mode: True/False/None)  "
              "resolved  hilbert_mode1", flush=True)
        times, ratios, agreed, hilbert, unresolved = [], [], {}, [], {}
        for record in records:
            m = record.measurement
            identified, seconds = cpu(lambda: record_backbone(m, frequencies_Hz=record.frequencies_Hz()))
            times.append(seconds)
            preview = float("nan")
            if not args.no_preview:
                try:
                    _, preview = cpu(lambda: calibration_preview(m))
                    ratios.append(seconds / preview)
                except BeamInputError as error:
                    print(f"  (preview refused: {error})")
            agreement = record.agreement(identified)
            for number, ok in agreement.items():
                agreed.setdefault(number, []).append(ok)
            for mode in identified.modes:
                if not mode.resolved:
                    unresolved.setdefault(mode.number, []).append(mode.note)
            h = hilbert_agrees(record) if args.hilbert and record.model is not None else None
            if h is not None:
                hilbert.append(h)
            rate = (m.time_s.size - 1) / (m.time_s[-1] - m.time_s[0])
            print(f"{record.name}  {m.time_s.size}  {rate:.0f}  {seconds:.3f}  {preview:.2f}  "
                  f"{seconds / preview if preview == preview else float('nan'):.3f}  {agreement}  "
                  f"{[md.resolved for md in identified.modes]}  {h}", flush=True)
        shares = {n: (sum(1 for v in vals if v is True), sum(1 for v in vals if v is not None)) for n, vals in agreed.items()}
        line = (f"{name}: CPU median {statistics.median(times):.3f} s, slowest {max(times):.3f} s; "
                + (f"ratio to the preview median {statistics.median(ratios):.3f}, slowest {max(ratios):.3f}; "
                   if ratios else "")
                + "agree " + ", ".join(f"mode {n} {a}/{b}" for n, (a, b) in sorted(shares.items()) if b)
                + (f"; Hilbert mode 1 {sum(hilbert)}/{len(hilbert)}" if hilbert else "")
                + "; not resolved " + ", ".join(f"mode {n} {len(notes)}/{len(records)}"
                                                for n, notes in sorted(unresolved.items())))
        print(line, flush=True)
        summary.append(line)
    print("\n# summary")
    for line in summary:
        print(line)


if __name__ == "__main__":
    main()
