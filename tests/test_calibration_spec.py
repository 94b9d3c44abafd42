"""One settings object: :class:`beam.calibration.CalibrationSpec` is the one source of the
defaults of the Python API, the command line and the dashboard, and resolves a record once."""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
import pytest

from beam.calibration import CalibrationSpec
from beam.calibration.spec import AUTO_MODES, DEFAULT_MODES
from beam.errors import BeamInputError
from tests.simulated_data import TRUE_BASE, simulated_measurement


def _calibrate_parser() -> argparse.ArgumentParser:
    from beam.cli import calibrate_command

    parser = argparse.ArgumentParser()
    calibrate_command.register(parser.add_subparsers())
    return parser


def _cli_defaults() -> argparse.Namespace:
    return _calibrate_parser().parse_args(["calibrate", "lab_run_1"])


def test_the_spec_is_frozen_hashable_and_normalised():
    a = CalibrationSpec(effects="tip_mass,air_damping", modes="4", window=[0, 1])
    b = CalibrationSpec(effects=("air_damping", "tip_mass"), modes=4, window=(0.0, 1.0))
    assert a == b and hash(a) == hash(b) and len({a, b}) == 1
    assert a.effects == ("air_damping", "tip_mass")  # catalogue order
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.modes = 3
    with pytest.raises(BeamInputError, match="unknown effect"):
        CalibrationSpec(effects="tip_masss")
    with pytest.raises(TypeError, match="unexpected calibration option"):
        CalibrationSpec.of(modez=3)


def test_cli_api_and_dashboard_defaults_are_the_specs():
    spec = CalibrationSpec()
    args = _cli_defaults()
    assert args.modes == spec.modes == AUTO_MODES
    assert args.window is spec.window
    assert tuple(e for e in args.effects.split(",") if e) == spec.effects
    assert (args.likelihood, args.seed, args.walkers, args.steps) == (spec.likelihood, spec.seed, spec.walkers, spec.steps)
    # the API's keywords build a spec: none given, the spec's defaults
    from beam.calibration.run import calibration_preview, calibration_stream

    assert CalibrationSpec.of() == spec
    for function in (calibration_preview, calibration_stream):
        import inspect

        parameters = inspect.signature(function).parameters
        assert not {"window", "effects", "modes", "likelihood", "seed"} & set(parameters)  # no second default
    # the dashboard's inputs
    from dashboard.jobs.beam import CalibrationKey
    from dashboard.state import beam as state

    beam_state = state.BeamState.param
    assert tuple(beam_state.effects.default) == spec.effects
    assert (beam_state.likelihood.default, beam_state.seed.default, beam_state.target_ess.default) == (
        spec.likelihood, spec.seed, spec.target_ess)
    assert state.WINDOW_FRACTION == spec.window_fraction
    key = state.BeamState(dataset="lab_run_1", window_s=(0.0, 1.0), modes=4).key()
    assert isinstance(key, CalibrationKey) and key.spec == CalibrationSpec(window=(0.0, 1.0), modes=4)


def test_a_default_changed_in_one_place_is_seen_by_the_cli_the_api_and_the_dashboard(monkeypatch):
    """Change the defaults in :mod:`beam.calibration.defaults` (the one place) and every front end
    sees the change: the spec, the command line, the model builder and the dashboard's inputs."""
    from beam.calibration import defaults

    for name, value in (("DEFAULT_EFFECTS", ("air_damping",)), ("DEFAULT_CALIBRATION_MODES", 3), ("DEFAULT_LIKELIHOOD", "ar1"),
                        ("DEFAULT_SEED", 7), ("DEFAULT_WINDOW_FRACTION", 0.4), ("DEFAULT_TARGET_ESS", 500.0)):
        monkeypatch.setattr(defaults, name, value)
    spec = CalibrationSpec()
    assert (spec.modes, spec.effects, spec.likelihood, spec.seed, spec.window_fraction, spec.target_ess) == (
        3, ("air_damping",), "ar1", 7, 0.4, 500.0)
    args = _cli_defaults()
    assert (args.modes, args.effects, args.likelihood, args.seed) == (3, "air_damping", "ar1", 7)
    assert CalibrationSpec.of() == spec
    record = simulated_measurement(TRUE_BASE, duration_s=2.0)
    from beam.calibration.pipeline import make_setup

    assert make_setup(record, modes=4).window[1] == pytest.approx(0.4 * record.time_s[-1])
    from dashboard.jobs.beam import CalibrationKey
    from dashboard.state import beam as state

    monkeypatch.setattr(state, "DEFAULTS", CalibrationSpec())  # what the dashboard reads when imported
    assert state._default_window(record) == (0.0, round(0.4 * float(record.time_s[-1]), 2))
    key = CalibrationKey("x", CalibrationSpec.of(window=(0.0, 1.0), effects=("air_damping",), modes=4))
    assert key.spec.target_ess == 500.0  # key's default: the spec's


def test_resolve_fills_the_window_and_auto_modes_once():
    record = simulated_measurement(TRUE_BASE, duration_s=2.0)
    spec = CalibrationSpec()
    resolved = spec.resolve(record)
    assert resolved.is_resolved and not spec.is_resolved
    assert resolved.window == (0.0, pytest.approx(0.3 * record.time_s[-1]))
    from beam.calibration.modes import suggest_modes

    assert resolved.modes == suggest_modes(record, resolved.window, spec.effects).modes
    assert resolved.mode_choice is not None and resolved.resolve(record) is resolved
    assert resolved.model_key() == (resolved.window, resolved.modes, "iid", spec.effects)
    fixed = CalibrationSpec(window=(0.0, 0.5), modes=DEFAULT_MODES).resolve(record)
    assert fixed.modes == DEFAULT_MODES and fixed.mode_choice is None
    with pytest.raises(ValueError):
        spec.model_key()


def test_the_spec_checks_every_field_when_made():
    """Every field is checked where the spec is made, the record-dependent bounds (the window in
    the record, the modes the mesh holds) where the setup is; the likelihoods it accepts are the
    inference engine's."""
    from beam.calibration.defaults import LIKELIHOOD_NAMES
    from beam.inference import LIKELIHOODS

    assert set(LIKELIHOOD_NAMES) == set(LIKELIHOODS)
    for bad, words in [(dict(likelihood="gauss"), "unknown likelihood"), (dict(window=(1.0, 0.5)), "start < end"),
                       (dict(window=(0.0, float("nan"))), "start < end"), (dict(modes=0), "modes"),
                       (dict(modes="many"), "modes"), (dict(walkers=1), "walkers"), (dict(steps=5), "steps"),
                       (dict(target_ess=0.0), "target_ess"), (dict(max_steps=0), "max_steps"),
                       (dict(window_fraction=1.5), "window_fraction"), (dict(seed=0.5), "seed"),
                       (dict(effects="tip_masss"), "unknown effect")]:
        with pytest.raises(BeamInputError, match=words):
            CalibrationSpec(**bad)
    assert CalibrationSpec(modes="3", seed=2.0, walkers=np.int64(40)).modes == 3
