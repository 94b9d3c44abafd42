"""Hardening-spring calibrations on records no tuning saw (run on demand:
``python tests/benchmarks/bench_spring_unseen.py [count] [--preview]``).

Each record is simulated afresh from ``lab_run_4``'s beam with random parameters and a random
noise seed (EI, k_p, air damping, k3 and the pulse's amplitude and width drawn around the
bundled record's, 4 s at 1 kHz, every Galerkin mode), then calibrated on its first second with
the default effects + ``tip_cubic_spring`` and the record's own choice of modes, as
``beam calibrate X.csv --effects air_damping,kelvin_voigt,tip_cubic_spring --window 0:1`` does;
``lab_run_4`` itself is run first, in the same process, as the baseline. Reported: wall and CPU
time of each calibration, its modes, the relative error of the MAP's EI and k3, and whether the
sampler reached the spec's ESS target (with the smallest ESS).

The first call of a process compiles the numba kernels unless their on-disk cache is valid
(it is invalidated when their source file changes): run the script twice and read the second.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import calibrate, calibration_preview  # noqa: E402
from beam.io.config import load_config  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402
from beam.io.simulation import simulate, write_simulation  # noqa: E402

EFFECTS = "air_damping,kelvin_voigt,tip_cubic_spring"
CONFIG = ROOT / "assets" / "answers" / "lab_run_4.config.toml"
#: (key, low, high): log-uniform draws for the [parameters] and [excitation] keys.
DRAWS = (("bending_stiffness_Nm2", 0.35, 0.7), ("patch_coupling_NmV", 0.01, 0.025),
         ("air_damping_Ns_m2", 0.01, 0.04), ("tip_cubic_stiffness_N_m3", 3e3, 8e4),
         ("amplitude_V", 20.0, 50.0), ("width_s", 0.05, 0.1))


def fresh_config(text: str, rng: np.random.Generator) -> tuple[str, dict[str, float]]:
    """The config with new true values and seed (the [nominal] prior centres kept)."""
    drawn = {}
    cut = text.index("[parameters]")
    head, tail = text[:cut], text[cut:]
    for key, low, high in DRAWS:
        value = float(np.exp(rng.uniform(np.log(low), np.log(high))))
        tail, count = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value:.6g}", tail)
        assert count == 1, key
        drawn[key] = float(f"{value:.6g}")
    tail = re.sub(r"(?m)^seed = .*$", f"seed = {int(rng.integers(1, 10**6))}", tail)
    return head + tail, drawn


def run(path: Path, preview: bool) -> tuple[float, float, object]:
    record = read_measurement(path)
    wall, cpu = time.perf_counter(), time.process_time()
    options = {"window": (0.0, 1.0), "effects": EFFECTS, "modes": "auto"}
    result = calibration_preview(record, **options) if preview else calibrate(record, **options)
    return time.perf_counter() - wall, time.process_time() - cpu, result


def sampled(result) -> str:
    """Whether the sampler reached its ESS target, and its smallest ESS ("preview" without one)."""
    diagnostics = result.posterior.diagnostics if result.posterior is not None else None
    return "preview" if diagnostics is None else f"{bool(diagnostics.converged)}  {diagnostics.ess_min:.0f}"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("count", nargs="?", type=int, default=3)
    parser.add_argument("--preview", action="store_true", help="MAP + Laplace only (no sampling)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    text = CONFIG.read_text()
    print("record          wall_s  cpu_s  modes  EI_err   k3_err   converged  ess_min")
    wall, cpu, result = run(ROOT / "assets" / "measurements" / "lab_run_4.csv", args.preview)
    print(f"lab_run_4       {wall:6.1f}  {cpu:5.1f}  {result.setup.modes:5d}                     {sampled(result)}")
    with tempfile.TemporaryDirectory() as folder:
        for i in range(args.count):
            config_text, drawn = fresh_config(text, rng)
            config_path = Path(folder) / f"unseen_{i}.config.toml"
            config_path.write_text(config_text)
            csv, _, _ = write_simulation(Path(folder) / f"unseen_{i}", simulate(load_config(config_path)))
            wall, cpu, result = run(csv, args.preview)
            fitted = result.laplace.map.values
            ei = fitted["bending_stiffness_Nm2"] / drawn["bending_stiffness_Nm2"] - 1
            k3 = fitted["tip_cubic_stiffness_N_m3"] / drawn["tip_cubic_stiffness_N_m3"] - 1
            print(f"unseen_{i}        {wall:6.1f}  {cpu:5.1f}  {result.setup.modes:5d}  {ei:+.1e}  {k3:+.1e}  "
                  f"{sampled(result)}", flush=True)


if __name__ == "__main__":
    main()
