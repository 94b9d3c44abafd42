"""``beam simulate`` and ``beam modes`` run as a user runs them: ``python -m beam ...``."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from beam.io.config import load_config
from beam.io.measurement import read_measurement
from beam.io.simulation import read_truth

ASSET = Path(__file__).resolve().parents[1] / "assets" / "b1tapih.toml"

UNIFORM_CONFIG = """title = "uniform beam"
[beam]
length_m = 0.5
linear_density_kg_m = 0.1
[patch]
start_m = 0.1
end_m = 0.2
[sensor]
position_m = 0.5
[parameters]
bending_stiffness_Nm2 = 0.5
patch_coupling_NmV = 0.01
kelvin_voigt_Nm2s = 1e-5
[model]
intervals = 8
"""


def run_beam(*arguments: str | Path, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "beam", *map(str, arguments)], capture_output=True, text=True,
                          cwd=cwd, timeout=120)


def clean_response(config_path: Path, modes: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Time-grid voltage and noise-free displacement computed in-process from the config."""
    from beam.physics.model import BeamModel

    config = load_config(config_path)
    excitation, sampling = config.require_simulation()
    voltage = excitation.voltage(sampling.time_s())
    model = BeamModel(config.geometry, config.effects, config.intervals, config.knots)
    response = model.response(config.parameters, voltage, sampling.sample_interval_s, modes=modes)
    return voltage, np.asarray(response).reshape(-1)


@pytest.fixture(scope="module")
def default_run(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    prefix = tmp_path_factory.mktemp("sim") / "nested" / "folder" / "b1"
    return prefix, run_beam("simulate", ASSET, "--out", prefix)


def test_simulate_writes_the_measurement_and_a_separate_truth_file(default_run):
    prefix, result = default_run
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    assert result.stdout.count("\n") == 1 and result.stdout.startswith("wrote ")
    csv_path, sidecar, truth = (prefix.with_name("b1" + suffix) for suffix in (".csv", ".toml", ".truth.toml"))
    assert all(str(path) in result.stdout for path in (csv_path, sidecar, truth))
    assert sorted(p.name for p in prefix.parent.iterdir()) == ["b1.csv", "b1.toml", "b1.truth.toml"]

    # the sidecar holds what a lab knows: nothing that reveals the hidden patch stiffening
    lab = tomllib.loads(sidecar.read_text())
    assert set(lab) == {"title", "beam", "patch", "sensor", "nominal"}
    assert lab["beam"] == {"length_m": 0.4573, "linear_density_kg_m": 0.093}
    assert lab["sensor"] == {"position_m": 0.27438}
    assert set(lab["nominal"]) == {"bending_stiffness_Nm2", "patch_coupling_NmV", "air_damping_Ns_m2",
                                   "kelvin_voigt_Nm2s"}
    for revealing in ("patch_added", "patch_stiffening", "effects", "seed", "noise", "parameters", "excitation"):
        assert revealing not in sidecar.read_text()

    truth_document = tomllib.loads(truth.read_text())
    assert truth_document["effects"] == ["air_damping", "kelvin_voigt", "patch_stiffening", "patch_damping"]
    assert truth_document["parameters"]["patch_added_stiffness_Nm2"] == 0.793
    assert truth_document["parameters"]["patch_added_kelvin_voigt_Nm2s"] == 1.255e-5
    assert (truth_document["modes"], truth_document["seed"], truth_document["noise_m"]) == ("all", 1, 1.2e-5)
    assert truth_document["excitation"] == {"kind": "chirp", "amplitude_V": 10.0, "start_Hz": 2.0,
                                            "stop_Hz": 250.0, "duration_s": 1.5}
    assert (truth_document["intervals"], truth_document["knots"]) == (40, "patch")
    parsed = read_truth(csv_path)
    assert parsed.modes is None and parsed.parameters == load_config(ASSET).parameters
    assert (parsed.intervals, parsed.knots) == (40, "patch")
    # a truth file written before the patch knots has no "knots": it was Smith's uniform mesh
    older = truth.with_name("older.truth.toml")
    older.write_text(truth.read_text().replace('knots = "patch"\n', ""))
    assert (read_truth(older).intervals, read_truth(older).knots) == (40, "uniform")


def test_simulated_record_is_the_model_response_plus_seeded_noise(default_run):
    prefix, result = default_run
    assert result.returncode == 0, result.stderr
    measurement = read_measurement(prefix.with_suffix(".csv"))
    assert measurement.sample_count == 4700
    np.testing.assert_array_equal(measurement.time_s, np.arange(4700) / 1000.0)
    voltage, clean = clean_response(ASSET, modes=None)
    np.testing.assert_array_equal(measurement.voltage_V, voltage)
    noise = measurement.displacement_m - clean
    expected = np.random.default_rng(1).normal(0.0, 1.2e-5, 4700)
    np.testing.assert_allclose(noise, expected, rtol=0, atol=1e-15)  # the documented seed and generator
    assert np.std(noise) == pytest.approx(1.2e-5, rel=0.05)
    assert np.std(noise) / np.sqrt(np.mean(clean**2)) == pytest.approx(0.01, rel=0.1)  # about 1 % of the RMS


def test_noise_modes_and_seed_options_override_the_config(tmp_path):
    prefix = tmp_path / "run"
    result = run_beam("simulate", ASSET, "--out", prefix, "--noise", "3e-5", "--seed", "5", "--modes", "4")
    assert result.returncode == 0, result.stderr
    measurement = read_measurement(tmp_path / "run.toml")
    _, clean = clean_response(ASSET, modes=4)
    noise = measurement.displacement_m - clean
    assert np.std(noise) == pytest.approx(3e-5, rel=0.05)
    assert abs(np.mean(noise)) < 4 * 3e-5 / np.sqrt(noise.size)
    truth = read_truth(tmp_path / "run.truth.toml")
    assert (truth.modes, truth.noise_m, truth.seed) == (4, 3e-5, 5)


def test_modes_json_matches_the_model(tmp_path):
    result = run_beam("modes", ASSET, "--json", "--count", "4")
    assert result.returncode == 0, result.stderr
    document = json.loads(result.stdout)
    assert set(document) == {"frequencies_Hz", "damping_ratios", "resolved", "refinement_change", "refined_intervals"}
    assert len(document["frequencies_Hz"]) == len(document["damping_ratios"]) == 4
    from beam.physics.model import BeamModel

    config = load_config(ASSET)
    frequencies, ratios = BeamModel(config.geometry, config.effects, config.intervals, config.knots).natural_modes(
        config.parameters, 4)
    np.testing.assert_allclose(document["frequencies_Hz"], frequencies, rtol=1e-12)
    np.testing.assert_allclose(document["damping_ratios"], ratios, rtol=1e-12)
    assert 4 < document["frequencies_Hz"][0] < document["frequencies_Hz"][3] < 250  # the chirp's 2 -> 250 Hz


def test_modes_table_of_a_uniform_beam(tmp_path):
    config_path = tmp_path / "uniform.toml"
    config_path.write_text(UNIFORM_CONFIG)
    table = run_beam("modes", config_path)
    assert table.returncode == 0, table.stderr
    lines = table.stdout.splitlines()
    assert lines[0].startswith("uniform beam (effects: kelvin_voigt; 8 intervals, knots 'patch')")
    assert lines[1].split() == ["mode", "frequency", "(Hz)", "damping", "ratio", "resolved"]
    from beam.physics.model import BeamModel

    config = load_config(config_path)
    frequencies, ratios = BeamModel(config.geometry, config.effects, 8, "patch").natural_modes(config.parameters)
    rows = [line.split() for line in lines[2:2 + len(frequencies)]]
    assert lines[2 + len(frequencies)].startswith("resolved: the frequency changes by less than 0.1 % on a mesh of 16")
    assert len(rows) == len(frequencies) > 4
    assert [int(row[0]) for row in rows] == list(range(1, len(rows) + 1))
    np.testing.assert_allclose([float(row[1]) for row in rows], frequencies, rtol=1e-5)  # 6 digits printed
    np.testing.assert_allclose([float(row[2]) for row in rows], ratios, rtol=1e-3)  # 4 digits printed
    # Euler–Bernoulli cantilever: f1 = (1.8751² / 2 pi) sqrt(EI / (rho L⁴)), Kelvin–Voigt ratio = cI omega / (2 EI)
    f1 = 1.875104068711961**2 / (2 * np.pi) * np.sqrt(0.5 / (0.1 * 0.5**4))
    assert float(rows[0][1]) == pytest.approx(f1, rel=1e-4)
    assert float(rows[0][2]) == pytest.approx(1e-5 * 2 * np.pi * f1 / (2 * 0.5), rel=1e-3)


CANTILEVER_BETA_L = [1.875104068711961, 4.694091132974175, 7.854757438237613, 10.995540734875467]


def test_modes_marks_the_modes_the_mesh_does_not_resolve(tmp_path):
    """Against the closed form of a uniform cantilever: modes marked resolved are within 0.1 % of
    it, modes marked not resolved are off by more (8 intervals resolve the first two or three)."""
    config_path = tmp_path / "uniform.toml"
    config_path.write_text(UNIFORM_CONFIG)
    result = run_beam("modes", config_path, "--json")
    assert result.returncode == 0, result.stderr
    document = json.loads(result.stdout)
    assert document["refined_intervals"] == 16
    frequencies = np.array(document["frequencies_Hz"])
    n = frequencies.size
    beta_l = np.array(CANTILEVER_BETA_L + [(2 * k - 1) * np.pi / 2 for k in range(5, n + 1)])  # (2k-1)pi/2 beyond
    exact = beta_l**2 / (2 * np.pi) * np.sqrt(0.5 / (0.1 * 0.5**4))
    error = np.abs(frequencies - exact) / exact
    resolved = np.array(document["resolved"])
    assert resolved[:2].all() and not resolved.all()  # the low modes are resolved, the high ones not
    assert np.all(error[resolved] < 1e-3) and np.all(error[~resolved] > 1e-3)
    table = run_beam("modes", config_path, "--count", "5")
    marks = [line.split()[-1] for line in table.stdout.splitlines()[2:7]]
    assert marks == ["yes" if r else "NO" for r in resolved[:5]]
    assert "NO: refine the mesh" in table.stdout.splitlines()[-1]


BAD_INVOCATIONS = [
    # (id, config text or None for the bundled asset, extra arguments, fragment of the error line)
    ("missing config", None, ["modes", "{tmp}/absent.toml"], "absent.toml: config not found"),
    ("typo in config", UNIFORM_CONFIG.replace("[model]", "[modle]"), ["modes", "{config}"],
     "[modle]: unknown table (did you mean 'model'?)"),
    ("binary config", "\x00\x01", ["modes", "{config}"], "binary content"),
    ("zero count", UNIFORM_CONFIG, ["modes", "{config}", "--count", "0"], "expected a positive integer"),
    ("count not a number", UNIFORM_CONFIG, ["modes", "{config}", "--count", "many"], "expected a positive integer"),
    ("no --out", None, ["simulate", "{asset}"], "the following arguments are required: --out"),
    ("nothing to simulate", UNIFORM_CONFIG, ["simulate", "{config}", "--out", "{tmp}/x"],
     "[excitation]: missing table (needed to simulate)"),
    ("negative noise", None, ["simulate", "{asset}", "--out", "{tmp}/x", "--noise", "-1"], "--noise"),
    ("negative seed", None, ["simulate", "{asset}", "--out", "{tmp}/x", "--seed", "-3"], "--seed"),
    ("too many modes", None, ["simulate", "{asset}", "--out", "{tmp}/x", "--modes", "99"], "modes must be between 1"),
    ("out under a file", None, ["simulate", "{asset}", "--out", "{config}/sub/x"], "cannot create the folder"),
    ("unknown command", None, ["simulat", "{asset}"], "invalid choice"),
]


@pytest.mark.parametrize("config_text, arguments, fragment", [case[1:] for case in BAD_INVOCATIONS],
                         ids=[case[0] for case in BAD_INVOCATIONS])
def test_bad_input_exits_2_with_one_error_line(tmp_path, config_text, arguments, fragment):
    config_path = tmp_path / "config.toml"
    config_path.write_text(config_text if config_text is not None else "")
    arguments = [a.format(tmp=tmp_path, config=config_path, asset=ASSET) for a in arguments]
    result = run_beam(*arguments)
    assert result.returncode == 2, (result.stdout, result.stderr)
    assert "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("error:"), result.stderr
    assert fragment in result.stderr, result.stderr
    assert result.stdout == ""
    assert not (tmp_path / "x.csv").exists() and not (tmp_path / "x.toml").exists()
