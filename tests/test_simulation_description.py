"""Simulation configs take the beam in a student's words and a strain output, as sidecars do.

References: the measurement sidecar reader on the same ``[beam]``/``[sensor]`` tables (one
derivation, :func:`beam.io.measurement.read_description`), the closed forms rho b h and
E b h³ / 12, and the model's own strain response.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from beam.errors import BeamInputError
from beam.io.config import load_config
from beam.io.measurement import read_measurement, sidecar_from_document
from beam.io.simulation import simulate, write_simulation
from beam.physics.model import BeamModel

DESCRIBED = """title = "aluminium strip with a gauge"
[beam]
length_m = 0.3
width_m = 0.02
thickness_m = 0.001
material = "aluminium"
[patch]
start_m = 0.01
end_m = 0.04
[sensor]
position_m = 0.05
mass_kg = 0.002
output = "strain"
[parameters]
patch_coupling_NmV = 0.001
air_damping_Ns_m2 = 0.002
[excitation]
kind = "chirp"
amplitude_V = 10.0
start_Hz = 2.0
stop_Hz = 100.0
duration_s = 0.5
[sampling]
rate_Hz = 1000.0
duration_s = 0.5
noise_m = 1e-7
seed = 3
"""


def _config(tmp_path: Path, text: str = DESCRIBED):
    path = tmp_path / "strip.toml"
    path.write_text(text, encoding="utf-8")
    return load_config(path)


def test_the_description_gives_the_same_beam_as_a_sidecar(tmp_path):
    config = _config(tmp_path)
    rho, modulus = 2700.0, 69e9  # the aluminium preset
    assert config.geometry.linear_density_kg_m == pytest.approx(rho * 0.02 * 0.001, rel=1e-12)
    assert config.geometry.thickness_m == 0.001 and config.geometry.width_m == 0.02
    stiffness = modulus * 0.02 * 0.001**3 / 12
    # the truth where [parameters] is silent: EI from the material, the sensor as a point mass
    assert config.parameters["bending_stiffness_Nm2"] == pytest.approx(stiffness, rel=1e-12)
    assert config.parameters["sensor_mass_kg"] == 0.002 and "sensor_mass" in config.effects
    # a measurement sidecar with the same tables derives the same numbers
    sidecar = sidecar_from_document({
        "beam": {"length_m": 0.3, "width_m": 0.02, "thickness_m": 0.001, "material": "aluminium"},
        "patch": {"start_m": 0.01, "end_m": 0.04}, "sensor": {"position_m": 0.05, "mass_kg": 0.002},
    }, "flags", input_kind="voltage")
    assert sidecar.geometry == config.geometry
    assert sidecar.nominal == config.nominal and sidecar.nominal_spread == config.nominal_spread
    assert config.output == "strain"


def test_a_strain_config_simulates_the_gauge_and_writes_a_strain_record(tmp_path):
    config = _config(tmp_path)
    simulation = simulate(config, modes=None, noise_m=0.0)
    model = BeamModel(config.geometry, config.effects, config.intervals, config.knots)
    expected = model.response(config.parameters, simulation.voltage_V, 1e-3, None, output="strain")
    np.testing.assert_array_equal(simulation.displacement_m, expected)
    assert 1e-6 < np.abs(expected).max() < 1e-2  # microstrain to millistrain: a gauge's range
    csv_path, toml_path, _ = write_simulation(tmp_path / "out" / "gauge", simulate(config))
    assert csv_path.read_text().splitlines()[0] == "time_s,voltage_V,strain"
    record = read_measurement(csv_path)
    assert record.output_kind == "strain" and record.geometry == config.geometry
    assert record.nominal["bending_stiffness_Nm2"] == pytest.approx(config.parameters["bending_stiffness_Nm2"])


def test_the_cli_simulates_a_strain_config(tmp_path):
    config_path = tmp_path / "strip.toml"
    config_path.write_text(DESCRIBED, encoding="utf-8")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    done = subprocess.run([sys.executable, "-m", "beam", "simulate", str(config_path), "--out", str(tmp_path / "g")],
                          capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "g.csv").read_text().splitlines()[0] == "time_s,voltage_V,strain"


@pytest.mark.parametrize("change, message", [
    (("thickness_m = 0.001\n", ""), r"\[beam\] thickness_m"),
    (('output = "strain"', 'output = "curvature"'), r"\[sensor\] output: unknown output 'curvature'"),
    (("material = \"aluminium\"\n", "material = \"unobtainium\"\n"), r"\[beam\] material"),
])
def test_bad_descriptions_name_the_key(tmp_path, change, message):
    with pytest.raises(BeamInputError, match=message):
        _config(tmp_path, DESCRIBED.replace(*change))


def test_a_plain_config_still_simulates_a_displacement(tmp_path):
    plain = DESCRIBED.replace('output = "strain"\n', "").replace("mass_kg = 0.002\n", "")
    config = _config(tmp_path, plain)
    assert config.output == "displacement" and "sensor_mass" not in config.effects
    assert simulate(config).measurement().output_kind == "displacement"
