"""The start strategy against a brute-force reference (a seeded subset of tests/benchmarks/bench_starts.py)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from beam.calibration import (
    calibration_preview,  # noqa: E402
    prepare,  # noqa: E402
)
from beam.calibration.starts import design_points, starting_points  # noqa: E402
from tests.benchmarks.bench_starts import reference_log_posterior  # noqa: E402
from tests.simulated_data import TRUE_BASE, simulated_measurement  # noqa: E402

ASSETS = Path(__file__).resolve().parents[1] / "assets" / "measurements"


@pytest.fixture(scope="module")
def patch_record():
    """Base + damping + a stiff, heavy patch (as lab_run_1), 15 µm noise, seed 7."""
    truth = dict(TRUE_BASE, patch_added_density_kg_m=0.433, patch_added_stiffness_Nm2=0.793)
    return simulated_measurement(truth, noise_m=1.5e-5, seed=7, name="patch")


@pytest.mark.slow
@pytest.mark.parametrize("effects", [
    ("air_damping", "kelvin_voigt", "patch_stiffening"),            # the true set
    ("air_damping", "kelvin_voigt", "patch_stiffening", "tip_mass"),  # a superset
    ("patch_stiffening",),                                            # damping left out
])
def test_engine_map_is_within_one_nat_of_a_256_start_reference(patch_record, effects):
    window = (0.0, 1.0)
    engine = float(calibration_preview(patch_record, window=window, effects=effects).laplace.map.log_posterior)
    reference = reference_log_posterior(patch_record, window, effects, 4, starts=256)
    assert engine >= reference - 1.0


def test_design_covers_each_effect_barely_on_and_the_ranges(patch_record):
    setup, problem = prepare(patch_record, window=(0.0, 1.0), effects=("tip_mass", "clamp_compliance"))
    design = design_points(problem, setup)
    mass, clamp = design["tip_mass_kg"], design["clamp_stiffness_Nm_rad"]
    lo_m, hi_m = problem.parameter("tip_mass_kg").prior.lower, problem.parameter("tip_mass_kg").prior.upper
    lo_c, hi_c = (problem.parameter("clamp_stiffness_Nm_rad").prior.lower,
                  problem.parameter("clamp_stiffness_Nm_rad").prior.upper)
    barely_mass = np.isclose(np.log(mass / lo_m) / np.log(hi_m / lo_m), 0.02)
    barely_clamp = np.isclose(np.log(clamp / lo_c) / np.log(hi_c / lo_c), 0.98)  # a clamp vanishes when stiff
    assert barely_mass.sum() >= 8 and barely_clamp.sum() >= 8
    # the Sobol part spans each log range (every tenth of it holds a point)
    sobol = ~(barely_mass | barely_clamp)
    tenths = np.floor(10 * np.log(mass[sobol] / lo_m) / np.log(hi_m / lo_m))
    assert set(tenths.astype(int)) == set(range(10))
    starts = starting_points(problem, setup)
    assert len(starts) >= 3 and all(set(s) == set(setup.physical_names) for s in starts)
