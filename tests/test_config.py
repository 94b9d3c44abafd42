"""Simulation configs (the bundled B1TAPIH one included) and the tiny TOML writer."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beam.errors import BeamInputError
from beam.io.config import DEFAULT_INTERVALS, Sampling, SimulationConfig, load_config
from beam.io.measurement import write_measurement
from beam.io.text import dump_toml
from beam.physics.geometry import BeamGeometry

ASSET = Path(__file__).resolve().parents[1] / "assets" / "b1tapih.toml"

GEOMETRY_TOML = """title = "uniform test beam"
[beam]
length_m = 0.5
linear_density_kg_m = 0.1
[patch]
start_m = 0.1
end_m = 0.2
[sensor]
position_m = 0.5
"""
PARAMETERS_TOML = """[parameters]
bending_stiffness_Nm2 = 0.5
patch_coupling_NmV = 0.01
air_damping_Ns_m2 = 0.01
"""
EXCITATION_TOML = """[excitation]
kind = "pulse"
amplitude_V = 5.0
width_s = 0.01
"""
SAMPLING_TOML = """[sampling]
rate_Hz = 1000.0
duration_s = 0.5
noise_m = 1e-6
seed = 7
"""
CONFIG = GEOMETRY_TOML + PARAMETERS_TOML + EXCITATION_TOML + SAMPLING_TOML


def _load(tmp_path: Path, text: str) -> SimulationConfig:
    path = tmp_path / "sim.toml"
    path.write_text(text, encoding="utf-8")
    return load_config(path)


def test_bundled_b1tapih_config():
    config = load_config(ASSET)
    assert config.title == "Smith B1TAPIH cantilever (published values)"
    assert config.geometry == BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
    assert config.geometry.sensor_position_m == pytest.approx(3 * 0.4573 / 5, abs=1e-12)
    assert config.parameters == {
        "bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2, "air_damping_Ns_m2": 0.013,
        "kelvin_voigt_Nm2s": 0.649e-5, "patch_added_density_kg_m": 0.433, "patch_added_stiffness_Nm2": 0.793,
        "patch_added_kelvin_voigt_Nm2s": 1.255e-5,
    }
    assert config.effects == ("air_damping", "kelvin_voigt", "patch_stiffening", "patch_damping")
    assert set(config.nominal) == {"bending_stiffness_Nm2", "patch_coupling_NmV", "air_damping_Ns_m2",
                                   "kelvin_voigt_Nm2s"}
    assert all(config.nominal[name] == config.parameters[name] for name in config.nominal)
    excitation, sampling = config.require_simulation()
    assert excitation.to_table() == {"kind": "chirp", "amplitude_V": 10.0, "start_Hz": 2.0, "stop_Hz": 250.0,
                                     "duration_s": 1.5}
    assert (sampling.rate_Hz, sampling.sample_count, sampling.seed) == (1000.0, 4700, 1)
    assert int(0.3 * sampling.sample_count) == 1410  # the default calibration window
    assert 0 < sampling.noise_m < 1e-4
    assert (config.intervals, config.knots) == (40, "patch")


def test_a_small_config_parses_to_numbers(tmp_path):
    config = _load(tmp_path, CONFIG)
    assert config.title == "uniform test beam"
    assert config.effects == ("air_damping",)
    assert config.intervals == DEFAULT_INTERVALS and config.knots == "patch" and config.nominal == {}
    excitation, sampling = config.require_simulation()
    assert (excitation.kind, excitation.amplitude_V, excitation.width_s) == ("pulse", 5.0, 0.01)
    assert sampling == Sampling(rate_Hz=1000.0, duration_s=0.5, noise_m=1e-6, seed=7)
    time_s = sampling.time_s()
    assert time_s.size == 500 and time_s[0] == 0.0 and time_s[-1] == 499 / 1000.0
    np.testing.assert_array_equal(time_s, np.arange(500) / 1000.0)
    assert np.count_nonzero(excitation.voltage(time_s)) == 10


def test_parameters_alone_are_enough_for_modes(tmp_path):
    config = _load(tmp_path, GEOMETRY_TOML + PARAMETERS_TOML)
    assert config.excitation is None and config.sampling is None
    with pytest.raises(BeamInputError, match=r"sim.toml: \[excitation\]: missing table"):
        config.require_simulation()


def test_optional_sampling_keys_default_to_zero(tmp_path):
    config = _load(tmp_path, GEOMETRY_TOML + PARAMETERS_TOML + EXCITATION_TOML
                   + "[sampling]\nrate_Hz = 2000\nduration_s = 1\n[model]\nintervals = 8\nknots = \"uniform\"\n")
    assert (config.sampling.noise_m, config.sampling.seed, config.sampling.sample_count) == (0.0, 0, 2000)
    assert (config.intervals, config.knots) == (8, "uniform")


def test_file_excitation_replays_a_recorded_voltage(tmp_path):
    recorded = np.array([0.0, 1.0, -1.0, 2.0, 0.5])
    (tmp_path / "lab").mkdir()
    write_measurement(tmp_path / "lab" / "drive", (np.arange(5) / 500.0, recorded, np.zeros(5)),
                      geometry=BeamGeometry(0.5, 0.1, 0.1, 0.2, 0.5))
    text = CONFIG.replace(EXCITATION_TOML, '[excitation]\nkind = "file"\nfile = "lab/drive.csv"\n')
    config = _load(tmp_path, text)
    voltage = config.excitation.voltage(config.sampling.time_s())
    # recorded at 500 Hz, simulated at 1000 Hz: every value held for two samples, then 0
    np.testing.assert_array_equal(voltage[:12], [0, 0, 1, 1, -1, -1, 2, 2, 0.5, 0.5, 0, 0])
    assert config.excitation.file == str(tmp_path / "lab" / "drive.csv")


BAD_CONFIGS = [
    # (id, text, fragment the message must contain)
    ("unknown table", CONFIG + "[sampling_extra]\nx = 1\n", "[sampling_extra]: unknown table"),
    ("typo in table", CONFIG.replace("[parameters]", "[parameter]"), "[parameter]: unknown table (did you mean 'parameters'?)"),
    ("typo in key", CONFIG.replace("rate_Hz", "rate_hz"), "[sampling] rate_hz: unknown key (did you mean 'rate_Hz'?)"),
    ("no parameters", GEOMETRY_TOML + EXCITATION_TOML + SAMPLING_TOML, "[parameters]: missing table"),
    ("no stiffness", CONFIG.replace("bending_stiffness_Nm2 = 0.5\n", ""),
     "[parameters] bending_stiffness_Nm2: missing"),
    ("no coupling", CONFIG.replace("patch_coupling_NmV = 0.01\n", ""), "[parameters] patch_coupling_NmV: missing"),
    ("unknown parameter", CONFIG.replace("air_damping_Ns_m2", "air_damping"),
     "[parameters] air_damping: unknown parameter (did you mean 'air_damping_Ns_m2'?)"),
    ("negative parameter", CONFIG.replace("air_damping_Ns_m2 = 0.01", "air_damping_Ns_m2 = -0.01"),
     "[parameters] air_damping_Ns_m2: must be a positive finite number"),
    ("zero parameter", CONFIG.replace("patch_coupling_NmV = 0.01", "patch_coupling_NmV = 0"),
     "[parameters] patch_coupling_NmV: must be a positive finite number"),
    ("string parameter", CONFIG.replace("bending_stiffness_Nm2 = 0.5", 'bending_stiffness_Nm2 = "0.5"'),
     "[parameters] bending_stiffness_Nm2: must be a number"),
    ("incomplete effect", CONFIG.replace("[excitation]", "[excitation]").replace(
        "air_damping_Ns_m2 = 0.01\n", "air_damping_Ns_m2 = 0.01\npatch_added_density_kg_m = 0.4\n"),
     "[parameters] patch_added_stiffness_Nm2: missing; patch_added_density_kg_m switches on effect patch_stiffening"),
    ("unknown kind", CONFIG.replace('kind = "pulse"', 'kind = "step"'), "[excitation] kind: unknown kind 'step'"),
    ("no kind", CONFIG.replace('kind = "pulse"\n', ""), "[excitation] kind: missing key"),
    ("key of another kind", CONFIG.replace("width_s = 0.01", "width_s = 0.01\nfrequency_Hz = 5.0"),
     "[excitation] frequency_Hz: not used by a 'pulse' excitation (it takes amplitude_V, width_s)"),
    ("missing kind key", CONFIG.replace("width_s = 0.01\n", ""), "[excitation] width_s: missing key"),
    ("string amplitude", CONFIG.replace("amplitude_V = 5.0", 'amplitude_V = "5 V"'),
     "[excitation] amplitude_V: must be a number, got string '5 V'"),
    ("negative width", CONFIG.replace("width_s = 0.01", "width_s = -0.01"), "[excitation] width_s: must be > 0"),
    ("missing recording", CONFIG.replace(EXCITATION_TOML, '[excitation]\nkind = "file"\nfile = "nope.csv"\n'),
     "nope.csv: measurement CSV not found"),
    ("zero rate", CONFIG.replace("rate_Hz = 1000.0", "rate_Hz = 0"), "[sampling] rate_Hz: must be > 0"),
    ("no duration", CONFIG.replace("duration_s = 0.5\n", ""), "[sampling] duration_s: missing key"),
    ("negative noise", CONFIG.replace("noise_m = 1e-6", "noise_m = -1e-6"), "[sampling] noise_m: must be >= 0"),
    ("float seed", CONFIG.replace("seed = 7", "seed = 7.5"), "[sampling] seed: must be an integer, got float 7.5"),
    ("negative seed", CONFIG.replace("seed = 7", "seed = -1"), "[sampling] seed: must be >= 0"),
    ("too few samples", CONFIG.replace("duration_s = 0.5", "duration_s = 0.001"), "[sampling]: rate_Hz x duration_s = 1"),
    ("too many samples", CONFIG.replace("duration_s = 0.5", "duration_s = 1e6"), "the limit is 1,000,000"),
    ("intervals too small", CONFIG + "[model]\nintervals = 1\n", "[model] intervals: must be >= 2"),
    ("intervals float", CONFIG + "[model]\nintervals = 16.0\n", "[model] intervals: must be an integer"),
    ("unknown model key", CONFIG + "[model]\nelements = 16\n", "[model] elements: unknown key"),
    ("unknown knots", CONFIG + "[model]\nknots = \"chebyshev\"\n",
     "[model] knots: unknown knot layout 'chebyshev'; expected one of patch, uniform"),
    ("knots not a string", CONFIG + "[model]\nknots = 2\n", "[model] knots: must be a string"),
    ("fewer elements than segments", CONFIG + "[model]\nintervals = 2\n",
     "[model] intervals: must be >= 3 with knots = \"patch\""),
    ("excitation not a table", CONFIG.replace(EXCITATION_TOML, "") .replace("[beam]", 'excitation = "chirp"\n[beam]'),
     "excitation: must be a table [excitation]"),
    ("syntax", CONFIG.replace("seed = 7", "seed = = 7"), "TOML syntax error"),
    ("bad geometry", CONFIG.replace("position_m = 0.5", "position_m = 0.6"), "[sensor]: sensor position_m"),
]


@pytest.mark.parametrize("text, fragment", [case[1:] for case in BAD_CONFIGS], ids=[case[0] for case in BAD_CONFIGS])
def test_malformed_config_gives_one_line_naming_file_and_key(tmp_path, text, fragment):
    with pytest.raises(BeamInputError) as info:
        _load(tmp_path, text)
    message = str(info.value)
    assert message.startswith(str(tmp_path)), message
    assert "\n" not in message
    assert fragment in message, message


def test_missing_config_file(tmp_path):
    with pytest.raises(BeamInputError, match="nothing.toml: config not found"):
        load_config(tmp_path / "nothing.toml")


# ---------------------------------------------------------------------------------------------
# the TOML writer
# ---------------------------------------------------------------------------------------------

_scalars = st.one_of(
    st.text(max_size=20),
    st.booleans(),
    st.integers(-(2**63), 2**63 - 1),
    st.floats(allow_nan=False),
)
_values = st.one_of(_scalars, st.lists(st.floats(allow_nan=False), max_size=5),
                    st.lists(st.text(max_size=5), max_size=5))
_keys = st.text(min_size=1, max_size=12)


@settings(max_examples=200, deadline=None)
@given(top=st.dictionaries(_keys, _values, max_size=5), tables=st.dictionaries(
    _keys, st.dictionaries(_keys, _values, max_size=5), max_size=4))
def test_dump_toml_round_trips_through_tomllib(top, tables):
    document = {**top, **{k: v for k, v in tables.items() if k not in top}}
    assert tomllib.loads(dump_toml(document, header_comment="a comment\nover two lines")) == document


def test_dump_toml_writes_floats_exactly_and_readably():
    text = dump_toml({"x": 0.1 + 0.2, "big": 1e300, "tiny": 5e-324, "inf": math.inf, "n": 3, "t": {"a b": "q\"\n"}})
    assert "x = 0.30000000000000004\n" in text and 'big = 1e+300' in text and 'inf = inf' in text
    assert '"a b" = "q\\"\\n"' in text
    assert tomllib.loads(text)["tiny"] == 5e-324
