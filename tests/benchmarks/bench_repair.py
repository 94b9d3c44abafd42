"""Posterior speed and convergence for every repair and every catalogue effect (run on demand:
``python tests/benchmarks/bench_repair.py [--quick]``).

What a class does after **Add** or **Reveal**: a full posterior (MAP + Laplace, then emcee until
every parameter has bulk ESS >= 1000 and R-hat <= 1.01 over the independent ensembles) of

1. each bundled teaching record (``assets/measurements/lab_run_N``) with the effects it was
   simulated with (read from ``assets/answers``), at the dashboard's default window and modes for
   that record (``dashboard.state.beam.BeamState``): the cases of ``tests/test_repair_reaches_noise.py``;
2. the dashboard's default model (air damping + Kelvin-Voigt) plus each catalogue effect in turn
   on the record simulated with it (the nonlinear hardening tip spring included), at that
   record's defaults.

Targets (issue 13): <= 3 s for a linear model, <= 15 s for the nonlinear spring, on the 2-core
machine, in a warm process (imports, numba compilation and a first call done before timing).
Printed per case: wall time of :func:`beam.calibration.calibrate` (posterior and the
predictive bands the dashboard draws) from cold (no MAP remembered: the MAP search included; the
target applies to it), its CPU time, the wall time again with the model's MAP remembered (as
**Add** after a diagnosis that fitted the model: sampling and bands only), its CPU time (:func:`time.process_time`: on a shared,
loaded machine the wall time overstates it), minimum bulk ESS, maximum R-hat, held-out RMSE
over the true noise. The load average is printed: the machine is shared.
``--quick``: the repair cases only.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: single-threaded BLAS

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import calibrate  # noqa: E402
from beam.calibration.engine import forget_maps  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402
from beam.io.simulation import read_truth  # noqa: E402
from beam.physics.effects import EFFECTS  # noqa: E402
from dashboard.state.beam import BeamState  # noqa: E402

RECORDS = ("lab_run_1", "lab_run_2", "lab_run_3", "lab_run_4", "lab_run_5")
BASE = ("air_damping", "kelvin_voigt")
LINEAR_TARGET_S, NONLINEAR_TARGET_S = 3.0, 15.0


def _case(name: str, effects: tuple[str, ...]) -> tuple[tuple[float, float], object, object]:
    measurement = read_measurement(ROOT / "assets" / "measurements" / f"{name}.csv")
    truth = read_truth(ROOT / "assets" / "answers" / f"{name}.truth.toml")
    state = BeamState(dataset=name)
    kwargs = dict(window=tuple(state.window_s), effects=list(effects), modes=int(state.modes))
    calibrate(measurement, max_steps=100, **kwargs)  # warm: compilation and caches of this model
    forget_maps()  # ... but not its MAP: the timed calibration searches from cold, as a first calibration does
    t0, c0 = time.perf_counter(), time.process_time()
    result = calibrate(measurement, **kwargs)
    cold = (time.perf_counter() - t0, time.process_time() - c0)
    t0 = time.perf_counter()
    calibrate(measurement, **kwargs)  # again, its MAP remembered: as Add after a diagnosis that fitted it
    return (*cold, time.perf_counter() - t0), result, (truth, int(state.modes))


def _row(label: str, effects: tuple[str, ...], times: tuple[float, float], result, truth, modes: int) -> bool:
    d = result.posterior.diagnostics
    nonlinear = any(EFFECTS[e].nonlinear for e in effects)
    target = NONLINEAR_TARGET_S if nonlinear else LINEAR_TARGET_S
    seconds, cpu, remembered = times
    ok = seconds <= target and d.ess_min >= 1000 and d.rhat_max <= 1.01
    print(f"{label:64s} {modes:5d} {seconds:8.2f} {cpu:7.2f} {remembered:8.2f} {target:6.0f} {d.ess_min:8.0f} {d.rhat_max:7.4f} "
          f"{result.rmse_prediction / truth.noise_m:9.2f}  {'ok' if ok else 'MISSED'}")
    return ok


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="only the repair cases")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}; {os.cpu_count()} cores")
    header = f"{'case':64s} {'modes':>5s} {'wall s':>8s} {'CPU s':>7s} {'MAP known':>8s} {'target':>6s} {'ESS min':>8s} {'R-hat':>7s} {'RMSE/noise':>9s}"
    print("1. the revealed effects of each bundled record (dashboard defaults)")
    print(header)
    missed = 0
    for name in RECORDS:
        truth = read_truth(ROOT / "assets" / "answers" / f"{name}.truth.toml")
        seconds, result, (truth, modes) = _case(name, tuple(truth.effects))
        missed += not _row(f"{name}: {'+'.join(truth.effects)}", tuple(truth.effects), seconds, result, truth, modes)
    if not args.quick:
        print("\n2. base (air damping + Kelvin-Voigt) + each catalogue effect, on the record simulated with it")
        print(header)
        for name in RECORDS:
            truth = read_truth(ROOT / "assets" / "answers" / f"{name}.truth.toml")
            for effect in truth.effects:
                effects = BASE + (effect,)
                if effect in BASE or set(effects) == set(truth.effects):
                    continue  # the base itself, or the same case as in part 1
                seconds, result, (truth, modes) = _case(name, effects)
                missed += not _row(f"{name}: base + {effect}", effects, seconds, result, truth, modes)
    print(f"\n{'all within target' if not missed else f'{missed} case(s) missed the target'} "
          f"(load average now {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
