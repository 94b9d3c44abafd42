"""A beam described in a student's words, records in other formats through read_measurement,
bundled names, and the nominal bending stiffness anchored on the record's lowest peak."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beam.cli.arguments import measurement_path
from beam.errors import BeamInputError
from beam.io.anchor import (
    MODE1_BETA_L,
    anchor_nominal,
    closed_form_mode1_Hz,
    lowest_strong_peak,
    mode1_frequency,
)
from beam.io.bundled import ASSETS
from beam.io.materials import MATERIALS, MIN_BENDING_STIFFNESS_LOG_SD, find_material
from beam.io.measurement import (
    APPROXIMATE_MASS_LOG_SD,
    KNOWN_MASS_LOG_SD,
    read_measurement,
    write_measurement,
)
from beam.physics.geometry import BeamGeometry
from tests.record_files import write_phyphox_csv

ROWS = "time_s,acceleration_m_s2\n" + "".join(f"{k * 1e-3!r},{math.sin(k / 10)!r}\n" for k in range(50))


def _pair(tmp_path, sidecar: str, rows: str = ROWS, name: str = "run"):
    (tmp_path / f"{name}.csv").write_text(rows)
    (tmp_path / f"{name}.toml").write_text(sidecar)
    return tmp_path / f"{name}.csv"


STRIP = """[beam]
length_m = 0.5
width_m = 0.05
thickness_m = 0.002
material = "aluminium"
[sensor]
position_m = 0.44
"""


def test_width_thickness_and_material_give_the_density_and_a_nominal_ei(tmp_path):
    read = read_measurement(_pair(tmp_path, STRIP))
    aluminium = MATERIALS["aluminium"]
    assert read.geometry.linear_density_kg_m == pytest.approx(aluminium.density_kg_m3 * 0.05 * 0.002, rel=1e-15)
    assert read.nominal["bending_stiffness_Nm2"] == pytest.approx(aluminium.youngs_modulus_Pa * 0.05 * 0.002**3 / 12,
                                                                  rel=1e-15)
    # the prior's width: the material's E spread, 3x the thickness's, the width's, 4x the length's (floored)
    expected = math.sqrt(0.03**2 + (3 * 2e-5 / 0.002) ** 2 + (2e-4 / 0.05) ** 2 + (4 * 5e-3 / 0.5) ** 2)
    assert read.nominal_spread["bending_stiffness_Nm2"] == pytest.approx(max(MIN_BENDING_STIFFNESS_LOG_SD, expected))
    assert "aluminium" in read.nominal_origin["bending_stiffness_Nm2"]


def test_wood_ruler_spread_follows_its_material():
    wood = find_material("wooden ruler")
    assert wood.name == "wood ruler" and wood.youngs_modulus_spread == pytest.approx(0.22)
    for name in ("Aluminum", "stainless", "plastic ruler", "spring-steel ruler", "brass", "copper", "steel"):
        assert find_material(name).name in MATERIALS
    with pytest.raises(BeamInputError, match="material 'unobtainium': unknown; expected one of steel"):
        find_material("unobtainium")


def test_explicit_modulus_and_density_and_a_given_linear_density_wins(tmp_path):
    sidecar = STRIP.replace('material = "aluminium"', "youngs_modulus_Pa = 2.0e11\ndensity_kg_m3 = 7800.0\n"
                                                      "linear_density_kg_m = 0.8")
    read = read_measurement(_pair(tmp_path, sidecar))
    assert read.geometry.linear_density_kg_m == 0.8
    assert read.nominal["bending_stiffness_Nm2"] == pytest.approx(2.0e11 * 0.05 * 0.002**3 / 12, rel=1e-15)
    assert read.nominal_spread["bending_stiffness_Nm2"] == pytest.approx(MIN_BENDING_STIFFNESS_LOG_SD)


def test_a_nominal_in_the_sidecar_is_kept(tmp_path):
    read = read_measurement(_pair(tmp_path, STRIP + "[nominal]\nbending_stiffness_Nm2 = 1.5\n"))
    assert read.nominal["bending_stiffness_Nm2"] == 1.5 and "bending_stiffness_Nm2" not in read.nominal_spread


@pytest.mark.parametrize("sensor, spread", [("mass_kg = 0.004\n", KNOWN_MASS_LOG_SD),
                                            ("mass_kg = 0.2\nmass_approximate = true\n", APPROXIMATE_MASS_LOG_SD)])
def test_sensor_mass_known_or_approximate(tmp_path, sensor, spread):
    read = read_measurement(_pair(tmp_path, STRIP + sensor))
    assert read.nominal["sensor_mass_kg"] == pytest.approx(float(sensor.split("=")[1].split()[0]))
    assert read.nominal_spread["sensor_mass_kg"] == spread


@pytest.mark.parametrize("change, fragments", [
    (("material = \"aluminium\"", "material = \"cheese\""), ["[beam] material", "unknown; expected one of"]),
    (("thickness_m = 0.002\n", ""), ["[beam] thickness_m: missing key", "together"]),
    (("thickness_m = 0.002", "thickness_m = 0.2"), ["[beam] thickness_m", "more than width_m"]),
    (("width_m = 0.05\nthickness_m = 0.002\nmaterial = \"aluminium\"\n", ""), ["[beam] linear_density_kg_m: missing key",
                                                                              "width_m, thickness_m and material"]),
    (("position_m = 0.44", "position_m = 0.44\nmass_approximate = true"), ["[sensor] mass_approximate",
                                                                          "without mass_kg"]),
    (("position_m = 0.44", "position_m = 0.44\nmass_kg = 0.1\nmass_approximate = 1"), ["must be true or false"]),
    (("width_m", "widht_m"), ["[beam] widht_m: unknown key (did you mean 'width_m'?)"]),
])
def test_a_bad_description_is_one_line_naming_the_key(tmp_path, change, fragments):
    path = _pair(tmp_path, STRIP.replace(*change))
    with pytest.raises(BeamInputError) as info:
        read_measurement(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(tmp_path / "run.toml"))
    for fragment in fragments:
        assert fragment in message, message


# ---------------------------------------------------------------------------------------------
# other formats through read_measurement, bundled names
# ---------------------------------------------------------------------------------------------

def test_a_npy_next_to_its_sidecar_is_read(tmp_path):
    t = np.arange(0, 2, 1e-3)
    y = np.sin(2 * np.pi * 8 * t) * np.exp(-t)
    np.save(tmp_path / "x.npy", np.c_[t, y])
    (tmp_path / "x.toml").write_text(STRIP)
    read = read_measurement(tmp_path / "x.npy", unit="m/s^2")
    assert read.output_kind == "acceleration" and read.sample_count == t.size
    np.testing.assert_array_equal(read.output, y)
    assert read.source[0] == "read as NumPy .npy"


def test_a_phyphox_export_with_a_sidecar_of_its_name(tmp_path):
    t = np.arange(0, 2, 2e-3)
    z = np.sin(2 * np.pi * 8 * t) * np.exp(-t)
    write_phyphox_csv(tmp_path / "Raw Data.csv", t, {"x": 0 * t, "y": 9.81 + 0 * t, "z": z}, ";", ",")
    with pytest.raises(BeamInputError, match=r"Raw Data.csv: read as phyphox CSV .* the beam is not described: give "
                                             r"--length.* or a sidecar Raw Data.toml"):
        read_measurement(tmp_path / "Raw Data.csv")
    (tmp_path / "Raw Data.toml").write_text(STRIP)
    read = read_measurement(tmp_path / "Raw Data.csv")
    np.testing.assert_allclose(read.output, z, rtol=1e-9, atol=1e-12)
    beam = {"beam": {"length_m": 0.3, "width_m": 0.02, "thickness_m": 0.001, "material": "steel"},
            "sensor": {"position_m": 0.3}}
    described = read_measurement(tmp_path / "Raw Data.csv", beam=beam)
    assert described.geometry.length_m == 0.3 and described.toml_path is None


def test_a_csv_that_is_neither_the_projects_nor_readable_says_both(tmp_path):
    path = _pair(tmp_path, STRIP, rows="t,v,d\n0,1,2\n0.001,2,3\n")
    with pytest.raises(BeamInputError) as info:
        read_measurement(path)
    assert "header must be exactly" in str(info.value) and "read as another format:" in str(info.value)


def test_bundled_names_resolve_from_anywhere(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert measurement_path("adxl_50cm_114655") == str(ASSETS / "real" / "adxl_50cm_114655.csv")
    assert measurement_path("lab_run_1") == str(ASSETS / "measurements" / "lab_run_1.csv")
    assert measurement_path("elsewhere/lab_run_1") == "elsewhere/lab_run_1"


# ---------------------------------------------------------------------------------------------
# the nominal EI anchored on the record
# ---------------------------------------------------------------------------------------------

def test_mode1_of_the_model_is_the_closed_form_of_a_uniform_cantilever():
    geometry = BeamGeometry(0.5, 0.27, None, None, 0.44)
    assert mode1_frequency(geometry, 2.333) == pytest.approx(closed_form_mode1_Hz(0.5, 0.27, 2.333), rel=1e-4)
    assert MODE1_BETA_L == pytest.approx(1.875104068711961, rel=1e-15)


def test_the_sensor_mass_lowers_mode1_as_rayleigh_says():
    """Rayleigh's quotient with the unloaded shape (normalised to int phi² = L, phi(L)² = 4): a
    small mass M at the tip gives f = f0 sqrt(m L / (m L + 4 M)), to second order in M / (m L)."""
    geometry = BeamGeometry(0.5, 0.27, None, None, 0.5)
    mass = 0.02 * 0.27 * 0.5
    ratio = mode1_frequency(geometry, 2.0, mass) / mode1_frequency(geometry, 2.0)
    assert ratio == pytest.approx(math.sqrt(0.27 * 0.5 / (0.27 * 0.5 + 4 * mass)), rel=2e-3)


def test_the_anchor_puts_the_lowest_strong_peak_on_mode_1_and_keeps_a_given_nominal():
    geometry = BeamGeometry(0.4, 0.2, None, None, 0.4)
    truth = 1.1
    f1 = mode1_frequency(geometry, truth)
    t = np.arange(0, 10, 1 / 2000)
    rng = np.random.default_rng(4)
    # an accelerometer: mode 2 (6.27 f1) looks larger than mode 1, yet moves far less
    acceleration = (1.0 * np.exp(-0.2 * t) * np.sin(2 * np.pi * f1 * t)
                    + 3.0 * np.exp(-1.0 * t) * np.sin(2 * np.pi * 6.267 * f1 * t) + 0.01 * rng.normal(size=t.size))
    peak = lowest_strong_peak(t, acceleration, "acceleration")
    assert peak.frequency_Hz == pytest.approx(f1, rel=5e-3)
    nominal, origin = anchor_nominal(geometry, {}, t, acceleration, "acceleration")
    assert nominal["bending_stiffness_Nm2"] == pytest.approx(truth, rel=1e-2)
    assert "lowest strong spectral peak" in origin["bending_stiffness_Nm2"]
    assert anchor_nominal(geometry, {"bending_stiffness_Nm2": 3.0}, t, acceleration, "acceleration") == (
        {"bending_stiffness_Nm2": 3.0}, {})


def test_a_simulated_record_without_nominal_calibrates_with_its_lowest_peak_on_mode_1(tmp_path):
    from beam.calibration import calibration_preview
    from tests.simulated_data import TRUE_BASE, simulated_measurement

    record = simulated_measurement(TRUE_BASE, seed=3, nominal={})
    write_measurement(tmp_path / "sim", record, nominal={})
    read = read_measurement(tmp_path / "sim.csv")
    assert read.nominal["bending_stiffness_Nm2"] == pytest.approx(TRUE_BASE["bending_stiffness_Nm2"], rel=0.1)
    peak = lowest_strong_peak(read.time_s, read.output, read.output_kind)
    result = calibration_preview(read, window=(0.0, 1.5))
    values = {name: float(v) for name, v in result.laplace.map.values.items() if name in result.setup.physical_names}
    frequencies, _ = result.setup.model.natural_modes(values, 2)
    assert frequencies[0] == pytest.approx(peak.frequency_Hz, rel=0.02)
    assert values["bending_stiffness_Nm2"] == pytest.approx(TRUE_BASE["bending_stiffness_Nm2"], rel=0.01)


def test_the_calibration_prior_follows_the_description(tmp_path):
    from beam.calibration.run import prepare

    t = np.arange(0, 3, 1 / 500)
    rows = "time_s,acceleration_m_s2\n" + "".join(f"{a!r},{math.exp(-a) * math.sin(2 * math.pi * 6.5 * a)!r}\n"
                                                   for a in t.tolist())
    read = read_measurement(_pair(tmp_path, STRIP + "mass_kg = 0.01\n", rows=rows))
    _, problem = prepare(read, effects="sensor_mass", modes=2)
    priors = {p.name: p.prior for p in problem.parameters}
    stiffness, mass = priors["bending_stiffness_Nm2"], priors["sensor_mass_kg"]
    assert (stiffness.median, stiffness.sigma) == (read.nominal["bending_stiffness_Nm2"],
                                                   read.nominal_spread["bending_stiffness_Nm2"])
    assert (mass.median, mass.sigma) == (0.01, KNOWN_MASS_LOG_SD)


def test_a_peak_on_the_wrong_mode_is_said_in_words():
    from beam.io.anchor import mode_order_warnings
    from beam.physics.model import BeamModel

    read = read_measurement(ASSETS / "real" / "adxl_50cm_114655.csv")
    model = BeamModel(read.geometry, (), input_kind=None)
    peak = lowest_strong_peak(read.time_s, read.output, read.output_kind)
    right = (peak.frequency_Hz / mode1_frequency(read.geometry, 1.0)) ** 2
    assert mode_order_warnings(read, model, {"bending_stiffness_Nm2": right}) == []
    # EI / 6.27² puts mode 2 where mode 1 belongs (f2/f1 = 6.267 for the uniform cantilever)
    wrong = mode_order_warnings(read, model, {"bending_stiffness_Nm2": right / 6.267**2, "noise_sd": 1.0})
    assert len(wrong) == 1 and f"({peak.frequency_Hz:.4g} Hz) sits on model mode 2" in wrong[0]


def test_a_burst_at_mode_2_anchors_nothing_and_warns_of_nothing(tmp_path):
    from beam.io.anchor import mode_order_warnings
    from beam.physics.excitation import Excitation
    from beam.physics.model import BeamModel
    from tests.simulated_data import GEOMETRY, TRUE_BASE, simulated_measurement

    model = BeamModel(GEOMETRY, ("air_damping", "kelvin_voigt"))
    f2 = float(model.natural_modes(TRUE_BASE, 2)[0][1])
    burst = Excitation("burst", amplitude_V=10.0, frequency_Hz=f2, cycles=12)
    record = simulated_measurement(TRUE_BASE, excitation=burst, seed=5, nominal={})
    write_measurement(tmp_path / "burst", record, nominal={})
    read = read_measurement(tmp_path / "burst.csv")
    assert "bending_stiffness_Nm2" not in read.nominal  # the input never reached mode 1's band
    assert mode_order_warnings(read, model, TRUE_BASE) == []


def test_the_dashboard_upload_reads_a_phyphox_export_with_a_described_beam():
    from dashboard.jobs.beam import load_upload

    t = np.arange(0, 3, 2e-3)
    z = np.sin(2 * np.pi * 7 * t) * np.exp(-0.5 * t)
    from tests.record_files import phyphox_csv_text

    text = phyphox_csv_text(["Time (s)", "Linear Acceleration z (m/s^2)"], [t, z], "\t", ",")
    read = load_upload("Raw Data.csv", text.encode(), "Raw Data.toml", STRIP.encode())
    np.testing.assert_allclose(read.output, z, rtol=1e-9, atol=1e-12)
    assert read.nominal_origin["bending_stiffness_Nm2"].startswith("E b h³ / 12 from aluminium's E")


def test_beam_flags_without_a_beam_file_add_to_the_records_own_sidecar(tmp_path):
    """``--width`` and ``--thickness`` on a record whose sidecar has no width: the sidecar's length,
    density, sensor and nominal stay, the flags add the width (as the drag needs)."""
    import argparse

    from beam.cli.record_arguments import add_record_arguments, measurement_from_args

    path = _pair(tmp_path, "[beam]\nlength_m = 0.5\nlinear_density_kg_m = 0.27\n[sensor]\nposition_m = 0.44\n"
                           "[nominal]\nbending_stiffness_Nm2 = 2.333\n")
    parser = argparse.ArgumentParser()
    parser.add_argument("data")
    add_record_arguments(parser)
    record = measurement_from_args(parser.parse_args([str(path), "--width", "0.05", "--thickness", "0.002"]))
    assert record.geometry.width_m == 0.05 and record.geometry.length_m == 0.5
    assert record.geometry.sensor_position_m == 0.44 and record.geometry.linear_density_kg_m == 0.27
    assert record.nominal["bending_stiffness_Nm2"] == 2.333
