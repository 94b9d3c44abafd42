"""Why the dashboard keeps its own worker processes (run on demand: ``python tests/benchmarks/bench_dashboard_runs.py``).

Not collected by pytest (file name ``bench_*.py``). Two measurements, each against the standard
library's :class:`concurrent.futures.ProcessPoolExecutor` doing the same work:

* **A superseded calibration.** lab_run_1 with the tip mass ticked (the teacher's slowest
  calibration, 0-1.05 s, 7 modes) starts; once its sampler reports progress the teacher moves the
  window's end by 0.05 s. Measured: seconds from that second request to its first result (the
  preview) on one worker process, (a) with :class:`dashboard.runtime.scheduler.RunSlot` over
  :class:`dashboard.runtime.workers.WorkerProcesses` (the old run is stopped at its next stage:
  every 25 ensemble steps) and (b) with a one-process ``ProcessPoolExecutor`` (``Future.cancel``
  cannot stop a running call: the new one waits for the old to end; and the preview only comes
  with the call's one return value, so a calibration split in a preview call and a sampling call).
* **The record sent back with each result.** The bytes pickled for a final calibration result of
  a 31 MB upload (lab_run_1's beam and chirp at 180 kHz: 630,000 samples), with the worker's
  pickler (the record is one of the call's arguments: sent back as a reference) and with plain
  the record pickled again (what any other pool sends back with every result). Plain pickle (a
  ``ProcessPoolExecutor``'s) refuses the result: its problem holds closures (the MAP's starting
  points), which the worker's pickler replaces.

Wall-clock seconds (the latencies a user waits); the machine's load average is printed with them.
Options: ``--repeats N`` (default 3).
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import sys
import tempfile
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

WINDOW = (0.0, 1.05)
EFFECTS = ("air_damping", "kelvin_voigt", "tip_mass")
MODES = 7


def _key(end: float):
    from beam.calibration import CalibrationSpec
    from dashboard.jobs.beam import CalibrationKey, load_bundled, record_key

    m = load_bundled("lab_run_1")
    return CalibrationKey(record_key(m), CalibrationSpec(window=(0.0, end), effects=EFFECTS, modes=MODES)), m


def _preview_only(end: float):
    """A ``ProcessPoolExecutor`` call: the preview of the calibration (its one return value)."""
    from dashboard.jobs.beam import calibration_stages

    key, m = _key(end)
    stages = calibration_stages(key, m)
    try:
        return next(s for s in stages if s.kind == "preview").value.rmse_prediction
    finally:
        stages.close()


def _whole(end: float):
    """A ``ProcessPoolExecutor`` call: the whole calibration (preview and MCMC), its final value."""
    from dashboard.jobs.beam import calibration_stages
    from dashboard.runtime.scheduler import final_value

    key, m = _key(end)
    return final_value(calibration_stages(key, m)).rmse_prediction


def _warm() -> None:
    from dashboard.jobs.beam import warm_worker

    warm_worker()


def superseded_ours() -> float:
    """Seconds from the second request to its preview, RunSlot over one worker process."""
    from dashboard.jobs.beam import calibration_stages
    from dashboard.runtime import scheduler as sch

    pool = sch.RunPool(max_workers=1, processes=True, warm=_warm)
    pool.start_processes()
    try:
        seen: dict[str, float] = {}
        progressed, previewed = threading.Event(), threading.Event()

        def on_update(update):
            if update.request == 1 and update.kind == "progress":
                progressed.set()
            if update.request == 2 and update.kind == "preview":
                seen["preview"] = time.perf_counter()
                previewed.set()

        slot = sch.RunSlot(on_update, pool=pool, debounce_s=0.0, progress_interval_s=0.0)
        slot.request(lambda: sch.offload(calibration_stages, *_key(WINDOW[1])))
        progressed.wait(600)
        t0 = time.perf_counter()
        slot.request(lambda: sch.offload(calibration_stages, *_key(WINDOW[1] + 0.05)))
        previewed.wait(600)
        slot.wait(600)
        return seen["preview"] - t0
    finally:
        pool.shutdown()


def superseded_executor(sampling_starts_s: float) -> float:
    """Seconds from the second request to its preview, one-process ``ProcessPoolExecutor`` (the
    second request arrives ``sampling_starts_s`` after the first: when its sampler has started)."""
    with ProcessPoolExecutor(max_workers=1, mp_context=get_context("spawn"), initializer=_warm) as executor:
        executor.submit(int, 0).result()  # the process started and warm
        first = executor.submit(_whole, WINDOW[1])
        time.sleep(sampling_starts_s)
        t0 = time.perf_counter()
        cancelled = first.cancel()  # False: it runs
        preview = executor.submit(_preview_only, WINDOW[1] + 0.05)
        preview.result()
        assert not cancelled
        return time.perf_counter() - t0


def sampling_starts_s() -> float:
    """Seconds from a request of the slow calibration to its sampler's first progress (in this process)."""
    from dashboard.jobs.beam import calibration_stages
    from dashboard.jobs.warm import warm_up

    warm_up()
    t0 = time.perf_counter()
    stages = calibration_stages(*_key(WINDOW[1] - 0.05))
    try:
        for stage in stages:
            if stage.kind == "progress":
                return time.perf_counter() - t0
    finally:
        stages.close()
    return 0.0


def pickled_bytes() -> tuple[int, int, str]:
    """Bytes of a calibration result of a 31 MB upload pickled by the worker's pickler with the record
    sent back as a reference and without, and why plain pickle refuses it ('' if it does not)."""
    from beam.calibration import CalibrationSpec, calibration_preview
    from beam.io.config import load_config
    from beam.io.simulation import simulate, write_simulation
    from dashboard.jobs.beam import load_upload
    from dashboard.runtime.workers import _StagePickler

    config = Path(__file__).resolve().parents[2] / "assets" / "answers" / "lab_run_1.config.toml"
    folder = Path(tempfile.mkdtemp(prefix="bench-runs-"))
    (folder / "long.config.toml").write_text(config.read_text().replace("rate_Hz = 1000.0", "rate_Hz = 180000.0"))
    csv, toml, _ = write_simulation(folder / "long", simulate(load_config(folder / "long.config.toml")))
    m = load_upload(csv.name, csv.read_bytes(), toml.name, toml.read_bytes())
    result = calibration_preview(m, CalibrationSpec(window=(0.0, 1.05), effects=EFFECTS[:2], modes=4))
    import io

    sizes = []
    for anchors in ({id(m): 0}, {}):
        buffer = io.BytesIO()
        _StagePickler(buffer, anchors).dump(("stage", 1, result))
        sizes.append(buffer.getbuffer().nbytes)
    try:
        pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)
        refused = ""
    except (pickle.PicklingError, AttributeError, TypeError) as exc:
        refused = f"{type(exc).__name__}: {exc}"
    return sizes[0], sizes[1], refused


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    load = os.getloadavg()[0]
    starts = sampling_starts_s()
    ours, theirs = [], []
    for _ in range(args.repeats):  # interleaved
        ours.append(superseded_ours())
        theirs.append(superseded_executor(starts))
    anchored, whole, refused = pickled_bytes()
    print(f"load average {load:.1f} before, {os.getloadavg()[0]:.1f} after; {os.cpu_count()} cores")
    print(f"superseded calibration (lab_run_1 + tip mass, 7 modes): second request -> its preview, s "
          f"(median, slowest of {args.repeats})")
    print(f"  RunSlot + worker process          {statistics.median(ours):7.2f} {max(ours):7.2f}")
    print(f"  ProcessPoolExecutor (1 process)   {statistics.median(theirs):7.2f} {max(theirs):7.2f}")
    print(f"a result of a 630,000-sample upload: {anchored / 1e6:.2f} MB pickled with the record sent back as a "
          f"reference, {whole / 1e6:.2f} MB with the record; plain pickle: {refused or 'accepted'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
