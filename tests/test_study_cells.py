"""What names a study cell (resume key), how effect sets and likelihoods are read, the report's abscissa."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

from beam.calibration.spec import CalibrationSpec
from beam.cli.arguments import BUNDLED_MEASUREMENTS
from beam.errors import BeamInputError
from beam.io.measurement import read_measurement
from beam.study.cells import StudyCell, record_fingerprint
from beam.study.report import window_axis
from beam.study.run import parse_effect_sets, parse_likelihoods, study_cells


def test_a_records_fingerprint_is_its_content_not_its_name(tmp_path):
    for suffix in (".csv", ".toml"):
        shutil.copy(BUNDLED_MEASUREMENTS / f"lab_run_1{suffix}", tmp_path / f"renamed{suffix}")
    original = read_measurement(BUNDLED_MEASUREMENTS / "lab_run_1.csv")
    copy = read_measurement(tmp_path / "renamed.csv")
    assert copy.name != original.name and record_fingerprint(copy) == record_fingerprint(original)
    changed = dataclasses.replace(original, displacement_m=original.displacement_m + np.where(
        np.arange(original.time_s.size) == 7, 1e-9, 0.0))
    assert record_fingerprint(changed) != record_fingerprint(original)


def test_the_key_changes_with_every_option_and_the_code_but_not_the_shown_name():
    cell = StudyCell("lab_run_1", "abc", CalibrationSpec(window=(0.0, 1.0), effects=("air_damping",), modes="auto",
                                                         likelihood="iid", seed=0))
    key = cell.key("v1")
    assert dataclasses.replace(cell, record="other name").key("v1") == key
    assert cell.key("v2") != key
    for change in [dict(record_hash="abd"), dict(window=(0.0, 1.5)), dict(effects=()), dict(likelihood="ar1"),
                   dict(modes=4), dict(seed=1), dict(steps=100), dict(walkers=32)]:
        changed = (dataclasses.replace(cell, **change) if "record_hash" in change
                   else dataclasses.replace(cell, spec=dataclasses.replace(cell.spec, **change)))
        assert changed.key("v1") != key, change
    assert cell.calibration_options() == dict(window=(0.0, 1.0), effects=("air_damping",), modes="auto",
                                              likelihood="iid", walkers=None, steps=None, seed=0)


def test_effect_sets_are_separated_by_semicolons_each_read_as_calibrate_reads_it():
    assert parse_effect_sets("air_damping,kelvin_voigt;kelvin_voigt, air_damping ,patch_stiffening;") == (
        ("air_damping", "kelvin_voigt"), ("air_damping", "kelvin_voigt", "patch_stiffening"), ())
    assert parse_effect_sets("kelvin_voigt,air_damping;air_damping,kelvin_voigt") == (("air_damping", "kelvin_voigt"),)
    with pytest.raises(BeamInputError, match="nope"):
        parse_effect_sets("air_damping;nope")
    assert parse_likelihoods("ar1, iid,ar1") == ("ar1", "iid")
    for bad in ("", "gauss", "iid;ar1"):
        with pytest.raises(BeamInputError):
            parse_likelihoods(bad)


def test_cells_are_laid_out_record_window_effects_likelihood():
    record = read_measurement(BUNDLED_MEASUREMENTS / "lab_run_1.csv")
    cells = study_cells([("a", record), ("a", record)], [(0.0, 0.5), (0.0, 1.0)], [(), ("air_damping",)],
                        ["iid", "ar1"], modes=3, seed=5)
    assert len(cells) == 8  # the same record given twice counts once
    assert [(i, c.window, c.effects, c.likelihood) for i, c in cells[:4]] == [
        (0, (0.0, 0.5), (), "iid"), (0, (0.0, 0.5), (), "ar1"),
        (0, (0.0, 0.5), ("air_damping",), "iid"), (0, (0.0, 0.5), ("air_damping",), "ar1")]
    default = study_cells([("a", record)], None, [()], ["iid"])
    assert [c.window for _, c in default] == [(0.0, round(f * 3.499, 7)) for f in (0.1, 0.2, 0.3, 0.4, 0.5, 0.6)]


def test_the_reports_abscissa_tells_the_windows_apart():
    label, x = window_axis([(0, 0.5), (0, 1), (0, 2)])
    assert label.endswith("end (s)") and list(x) == [0.5, 1, 2]
    label, x = window_axis([(0, 1), (0.5, 1.5), (1, 2)])
    assert label.endswith("start (s)") and list(x) == [0, 0.5, 1]
    label, x = window_axis([(0, 0.5), (0, 2), (1, 2.5)])
    assert label.endswith("centre (s)") and list(x) == [0.25, 1, 1.75]


def test_the_scheduler_is_the_flag_then_the_environment_then_a_local_cluster(monkeypatch):
    from beam.study.engine import SCHEDULER_ENV, scheduler_address

    monkeypatch.delenv(SCHEDULER_ENV, raising=False)
    assert scheduler_address(None) is None
    monkeypatch.setenv(SCHEDULER_ENV, "tcp://10.0.0.5:8786")
    assert scheduler_address(None) == "tcp://10.0.0.5:8786"
    assert scheduler_address("tcp://127.0.0.1:9000") == "tcp://127.0.0.1:9000"
    monkeypatch.setenv(SCHEDULER_ENV, " ")
    assert scheduler_address(None) is None


def test_warming_up_never_stops_a_study(monkeypatch):
    """A calibration that fails while the kernels are warmed fails again in its cells, which report it."""
    import beam.calibration
    from beam.study.run import warm_kernels

    calls = []

    def failing(record, **options):
        calls.append(options)
        raise KeyError("ar1_coefficient")

    monkeypatch.setattr(beam.calibration, "calibrate", failing)
    record = read_measurement(BUNDLED_MEASUREMENTS / "lab_run_1.csv")
    cells = [c for _, c in study_cells([("a", record)], [(0.0, 1.0), (0.0, 2.0)], [(), ("air_damping",)], ["iid"])]
    warm_kernels(record, cells)
    assert [(c["effects"], c["modes"], c["steps"]) for c in calls] == [((), 2, 10), (("air_damping",), 2, 10)]
    assert calls[0]["window"] == (0.0, pytest.approx(0.3499))


def test_every_line_of_a_records_figure_shares_its_abscissa():
    """A set computed on fewer windows is drawn at those windows' places on the record's axis."""
    import re

    import pandas as pd

    from beam.study.report import _record_figures

    rows = [dict(record="r", window_start_s=a, window_end_s=b, effects=e, likelihood="iid", output_unit="m",
                 rmse_prediction=rmse, coverage95_prediction=0.9, error="")
            for e, windows, rmse in [("a", [(0, 0.5), (0, 2), (1, 2.5)], 1e-3), ("b", [(0, 1), (0, 1.5)], 2e-3)]
            for a, b in windows]
    figures, _ = _record_figures(pd.DataFrame(rows))
    lines = [[float(p.split(",")[0]) for p in pts.split()] for pts in re.findall(r'<polyline[^>]*points="([^"]*)"',
                                                                               figures[0])]
    (a0, a1, a2), (b0, b1) = lines[0], lines[1]  # centres 0.25, 1, 1.75 and 0.5, 0.75 (s)
    assert a1 - a0 == pytest.approx((a2 - a0) * 0.75 / 1.5, abs=0.15)
    assert (b0, b1) == (pytest.approx(a0 + (a2 - a0) * 0.25 / 1.5, abs=0.15),
                        pytest.approx(a0 + (a2 - a0) * 0.5 / 1.5, abs=0.15))
