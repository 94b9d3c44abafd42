"""Window specifications of ``beam study`` and its command-line errors (no calibration runs here)."""

from __future__ import annotations

import pytest

from beam.cli.main import main
from beam.errors import BeamInputError
from beam.study.windows import DEFAULT_FRACTIONS, MAX_WINDOWS, default_windows, parse_windows


def test_a_list_keeps_its_order_and_drops_repeats():
    assert parse_windows("0:0.5,0:1,1:2") == ((0.0, 0.5), (0.0, 1.0), (1.0, 2.0))
    assert parse_windows(" 1:2 , 0:0.5,1:2") == ((1.0, 2.0), (0.0, 0.5))


def test_a_growing_family_ends_at_every_step_up_to_its_end():
    windows = parse_windows("grow:0:0.25:4")
    assert len(windows) == 16
    assert all(start == 0.0 for start, _ in windows)
    assert [end for _, end in windows] == [0.25 * k for k in range(1, 17)]


def test_a_sliding_family_keeps_its_length_and_stays_before_its_end():
    windows = parse_windows("slide:1:0:0.5:4")
    assert windows == tuple((0.5 * k, 0.5 * k + 1) for k in range(7))  # 0-1, 0.5-1.5, ..., 3-4 s


def test_decimal_steps_give_the_decimal_windows():
    """0.1 * 3 is 0.30000000000000004 in floating point: the family gives 0.3, the window a list names."""
    assert parse_windows("grow:0:0.1:1")[2] == (0.0, 0.3) == parse_windows("0:0.3")[0]
    assert len(parse_windows("grow:0:0.1:1")) == 10
    assert parse_windows("slide:0.2:0.1:0.1:0.7")[-1] == (0.5, 0.7)


@pytest.mark.parametrize("spec", [
    "", "0", "0:1:2", "a:1", "1:1", "2:1", "-1:1", "0:inf", "0:1,", "grow:0:0.5", "grow:0:0:4", "grow:0:-1:4",
    "grow:0:5:4", "slide:1:0:0.5", "slide:0:0:0.5:4", "slide:5:0:1:4", f"grow:0:{4 / (MAX_WINDOWS + 1)}:4.5",
])
def test_a_bad_specification_is_an_input_error(spec):
    with pytest.raises(BeamInputError):
        parse_windows(spec)


def test_the_default_family_grows_over_the_record():
    windows = default_windows(0.0, 3.5)
    assert len(windows) == len(DEFAULT_FRACTIONS)
    assert [w[0] for w in windows] == [0.0] * len(windows)
    assert [w[1] for w in windows] == pytest.approx([f * 3.5 for f in DEFAULT_FRACTIONS], abs=1e-7)
    assert default_windows(2.0, 4.0)[0] == (2.0, 2.2)


@pytest.mark.parametrize("argv, message", [
    (["lab_run_1", "--windows", "0:1:2"], "--windows"),
    (["lab_run_1", "--windows", "grow:0:0:4"], "step"),
    (["lab_run_1", "--effects", "air_damping;no_such_effect"], "no_such_effect"),
    (["lab_run_1", "--likelihood", "iid,gauss"], "gauss"),
    (["lab_run_1", "--modes", "0"], "--modes"),
    (["lab_run_1", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "--workers"),
    (["lab_run_1", "--report", "out.pdf"], "--report"),
    (["no_such_record_anywhere.csv"], "no_such_record_anywhere"),
])
def test_command_line_errors_are_one_line_and_status_2(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    try:
        status = main(["study", *argv])
    except SystemExit as exc:  # argparse's errors
        status = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert len(err) == 1 and err[0].startswith("error:") and message in err[0]
    assert list(tmp_path.iterdir()) == []  # nothing started, nothing written


def test_workers_with_a_scheduler_from_the_environment_is_an_error(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", "tcp://127.0.0.1:1")
    assert main(["study", "lab_run_1", "--workers", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "--workers" in err[0]
