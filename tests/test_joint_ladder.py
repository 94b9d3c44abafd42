"""One strip clamped at four lengths (#38 item 7): a 4 g sensor and a compliant clamp, both needed.

The records (``tests/stand_ins.joint_strip``: 30/40/50/60 cm, 3 s at 400 Hz, modes 1 and 2 in each)
are simulated by the project's model. The independent reference is the exact solution of the
cantilever with a point mass and a rotational root spring (``tests/reference_beams``: the transfer
matrix of the two uniform segments, the characteristic determinant's roots by brentq), fitted to
each record's own f1 and f2 (a least-squares fit of two damped sinusoids to the record, scipy): EI
with the mass alone and EI with the spring alone leave the frequencies hundreds of times their
scatter away, EI with both reaches it, at the truth. The joint ladder must then name both.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from tests import stand_ins as si
from tests.reference_beams import bracket_roots, mass_spring_determinant

WINDOW = (0.0, 2.0)


def record_frequencies(record, guess_Hz: tuple[float, float]) -> np.ndarray:
    """f1, f2 (Hz) of a record by least squares of offset + two damped sinusoids, from spectral guesses."""
    t, y = record.time_s, record.output
    # spectral guesses: the periodogram's highest peak near each guess (zero-padded 16x)
    n = 16 * t.size
    spectrum = np.abs(np.fft.rfft((y - y.mean()) * np.hanning(t.size), n))
    freq = np.fft.rfftfreq(n, t[1] - t[0])
    starts = []
    for g in guess_Hz:
        band = (freq > 0.8 * g) & (freq < 1.2 * g)
        starts.append(float(freq[band][np.argmax(spectrum[band])]))

    def model(x):
        out = np.full(t.size, x[0])
        for k in range(2):
            a, b, f, s = x[1 + 4 * k: 5 + 4 * k]
            out += np.exp(-s * t) * (a * np.cos(2 * np.pi * f * t) + b * np.sin(2 * np.pi * f * t))
        return out

    x0 = [y.mean()]
    for f in starts:
        x0 += [np.std(y), 0.0, f, 0.5]
    fit = least_squares(lambda x: model(x) - y, x0, x_scale="jac")
    return np.sort(fit.x[[3, 7]])


def exact_frequencies(ei: float, length: float, *, mass: float = 0.0, spring: float = np.inf,
                      near_Hz: np.ndarray) -> np.ndarray:
    """f1, f2 (Hz) of the exact cantilever with the sensor mass 6 cm from the tip and the root spring
    (:func:`tests.reference_beams.mass_spring_determinant`), each root bracketed near the record's own."""
    determinant = mass_spring_determinant(ei, si.STRIP_DENSITY, length, clamp_stiffness=spring, mass=mass,
                                          mass_at=length - 0.06)
    out = []
    for f in near_Hz:
        roots = bracket_roots(determinant, 2 * np.pi * 0.6 * f, 2 * np.pi * 1.4 * f, 1, grid=200)
        out.append(roots[0] / (2 * np.pi) if roots.size else np.nan)
    return np.array(out)


@pytest.fixture(scope="module")
def records():
    return [si.joint_strip(length, seed=k) for k, length in enumerate(si.JOINT_LENGTHS)]


@pytest.fixture(scope="module")
def measured(records):
    from tests.reference_beams import cantilever_beta_l

    out = []
    for record in records:  # guesses: the bare rigid-clamped strip at the nominal EI
        length = record.geometry.length_m
        guess = cantilever_beta_l(2) ** 2 / (2 * np.pi) * np.sqrt(si.STRIP_EI / (si.STRIP_DENSITY * length**4))
        out.append(record_frequencies(record, tuple(guess)))
    return np.array(out)


def test_the_exact_reference_agrees_with_the_project_model_and_the_closed_forms():
    """The reference itself: the tip-mass and root-spring closed forms, then the project's Galerkin
    model of the strip with both (1e-6)."""
    from beam.physics.geometry import BeamGeometry
    from beam.physics.model import BeamModel
    from tests.reference_beams import cantilever_mass_spring_frequencies_Hz, clamp_spring_beta_l, tip_mass_beta_l

    ei, rho, length = 2.2, si.STRIP_DENSITY, 0.4
    scale = np.sqrt(ei / (rho * length**4)) / (2 * np.pi)
    np.testing.assert_allclose(cantilever_mass_spring_frequencies_Hz(ei, rho, length, mass=0.3 * rho * length) / scale,
                               tip_mass_beta_l(0.3, 3) ** 2, rtol=1e-9)
    np.testing.assert_allclose(cantilever_mass_spring_frequencies_Hz(ei, rho, length, clamp_stiffness=5 * ei / length)
                               / scale, clamp_spring_beta_l(5.0, 3) ** 2, rtol=1e-9)
    geometry = BeamGeometry(length_m=length, linear_density_kg_m=rho, patch_start_m=None, patch_end_m=None,
                            sensor_position_m=length - 0.06)
    model = BeamModel(geometry, si.JOINT_EFFECTS, input_kind=None)
    galerkin = model.natural_modes(si.JOINT_TRUTH, 3)[0]
    exact = cantilever_mass_spring_frequencies_Hz(ei, rho, length, clamp_stiffness=233.0, mass=0.004,
                                                  mass_at=length - 0.06, count=3)
    np.testing.assert_allclose(galerkin, exact, rtol=1e-6)


@pytest.mark.slow
def test_the_records_own_frequencies_need_both_the_mass_and_the_spring(records, measured):
    """Exact transfer-matrix fits of the eight measured frequencies: EI + mass and EI + spring miss
    them by far more than EI + both, which recovers the truth (4 g, 233 N m/rad)."""
    lengths = [r.geometry.length_m for r in records]

    def residuals(x, kind):
        ei = np.exp(x[0])
        mass = np.exp(x[1]) if kind in ("mass", "both") else 0.0
        spring = np.exp(x[-1]) if kind in ("spring", "both") else np.inf
        out = [exact_frequencies(ei, L, mass=mass, spring=spring, near_Hz=f) / f - 1 for L, f in zip(lengths, measured)]
        return np.concatenate(out)

    starts = {"mass": [np.log(2.2), np.log(0.004)], "spring": [np.log(2.2), np.log(233.0)],
              "both": [np.log(2.3), np.log(0.003), np.log(400.0)]}
    fits = {k: least_squares(residuals, x0, args=(k,), x_scale="jac") for k, x0 in starts.items()}
    rms = {k: float(np.sqrt(np.mean(f.fun**2))) for k, f in fits.items()}
    assert rms["both"] < 2e-4, rms  # the frequencies' own scatter (3 s records)
    assert rms["mass"] > 10 * rms["both"] and rms["spring"] > 10 * rms["both"], rms
    ei, mass, spring = np.exp(fits["both"].x)
    assert mass == pytest.approx(0.004, rel=0.15) and spring == pytest.approx(233.0, rel=0.3), (ei, mass, spring)


@pytest.mark.slow
def test_the_joint_ladder_names_both_and_its_table_holds_every_record(records):
    """The joint ladder climbs while a rung is missing: both effects of the truth, one after the
    other; its table has the joint figures and each record's on every row; the separation words
    compare effects of one kind with each record's own f1; the interval says what widens it."""
    from beam.discovery.joint import joint_diagnose
    from beam.discovery.judgement import effect_kind

    diagnosis = joint_diagnose(records, window=WINDOW, modes=2, base="modal_damping")
    added = [r.added for r in diagnosis.ladder[1:]]
    assert set(added[:2]) == {"sensor_mass", "clamp_compliance"}, (added, diagnosis.verdict())
    # each rung of the climb is itself missing on top of the rung below
    for k, rung in enumerate(diagnosis.ladder[1:], start=1):
        judged = next(c for c in diagnosis.ladder[k - 1].candidates if c.effect == rung.added)
        assert judged.material and judged.rung == k - 1
    # on the last rung the window error of every record is at the noise (0.05 m/s²) within 20 %
    last = diagnosis.table()
    rung_rows = [row for row in last if row["kind"] == "rung"]
    assert len(rung_rows) == len(diagnosis.ladder)
    for row in rung_rows[-1:]:
        for record in row["records"]:
            assert record["rmse_calibration"] == pytest.approx(0.05, rel=0.2), row
    assert all(len(row["records"]) == len(records) for row in last)
    for pair in diagnosis.separation():
        assert effect_kind(pair["better"]) == effect_kind(pair["worse"])
        for r in pair["records"]:  # physical numbers: every model near the record's own f1
            assert abs(r["f1_better_Hz"] / r["f1_measured_Hz"] - 1) < 0.05
    verdict = diagnosis.verdict()
    assert "sensor_mass" in verdict and "clamp_compliance" in verdict and "Jointly EI =" in verdict
    ei = next(r for r in diagnosis.intervals() if r["name"] == "bending_stiffness_Nm2")
    assert ei["correlation_widening"] >= 1.0 and ei["most_correlated"] is not None
