"""A record of unknown scale (#39 item 9): ADC counts calibrate a linear free decay as its SI record
does, and the effects that depend on the amplitude are neither offered nor calibrated on it.

Reference: the shared real run (``assets/real``, MIT-licensed) in m/s², and the same samples as
an ADC would give them, c = 1000 / g_n · a + 512 (an offset and a scale the reader is not told).
A linear model of a free decay is invariant under y -> s y + b: its initial state and offset are
linear and profiled out, the noise prior scales with the data. So the two MAPs agree to the
optimiser's tolerance, far inside the posterior sd, and the noise sd scales by s.
"""

from __future__ import annotations

import numpy as np
import pytest

from beam.calibration import calibration_preview
from beam.discovery.ranking import candidate_effects
from beam.io.measurement import Measurement, read_measurement, true_unit_problem
from beam.physics.effects import EFFECTS

REAL = "assets/real/adxl_50cm_114655.csv"
SCALE = 1e3 / 9.80665


def _counts(measurement: Measurement, **geometry) -> Measurement:
    geometry = measurement.geometry if not geometry else type(measurement.geometry)(
        **{**measurement.geometry.__dict__, **geometry})
    return Measurement(name="counts", title="counts", geometry=geometry, time_s=measurement.time_s,
                       acceleration_m_s2=SCALE * measurement.output + 512.0, nominal=measurement.nominal,
                       arbitrary_units=True, artifacts=measurement.artifacts)  # the same samples left out


@pytest.mark.slow
def test_a_linear_free_decay_in_counts_calibrates_as_in_si():
    si = read_measurement(REAL)
    counts = _counts(si)
    a, b = (calibration_preview(m, window=(0.0, 2.0)) for m in (si, counts))
    names = [p.name for p in a.laplace.problem.parameters]
    sd = dict(zip(names, a.laplace.sd_internal))
    for name in ("bending_stiffness_Nm2", "air_damping_Ns_m2", "kelvin_voigt_Nm2s"):
        # in the internal (log) coordinate: the same optimum to a hundredth of a posterior sd
        gap = abs(np.log(b.laplace.map.values[name]) - np.log(a.laplace.map.values[name]))
        assert gap < 0.01 * sd[name], (name, gap, sd[name])
    assert b.laplace.map.values["noise_sd"] / a.laplace.map.values["noise_sd"] == pytest.approx(SCALE, rel=1e-3)
    assert b.rmse_calibration / a.rmse_calibration == pytest.approx(SCALE, rel=1e-3)
    assert b.to_json()["output_unit"] == "a.u."


def test_the_amplitude_effects_are_not_offered_on_a_record_of_unknown_scale():
    si = read_measurement(REAL)
    counts = _counts(si, width_m=0.05, thickness_m=0.002)
    wide = Measurement(name="si", title="si", geometry=counts.geometry, time_s=si.time_s,
                       acceleration_m_s2=si.output, nominal=si.nominal)
    offered, blind = candidate_effects(("air_damping",), wide), candidate_effects(("air_damping",), counts)
    assert "quadratic_drag" in offered and "quadratic_drag" not in blind
    assert set(offered) - set(blind) == {e for e in offered if EFFECTS[e].nonlinear}
    assert true_unit_problem(counts, ("air_damping", "kelvin_voigt")) is None
    assert true_unit_problem(wide, "quadratic_drag") is None
    words = true_unit_problem(counts, "air_damping,quadratic_drag,clamp_friction")
    assert words.startswith("quadratic_drag, clamp_friction need the signal in its true unit: their forces depend "
                            "on the amplitude")


def test_the_library_refuses_an_amplitude_effect_on_a_record_of_unknown_scale():
    """The refusal holds where every front end builds its setup (``make_setup``), not only in the CLI."""
    from beam.calibration import make_setup
    from beam.errors import BeamInputError

    counts = _counts(read_measurement(REAL), width_m=0.05, thickness_m=0.002)
    with pytest.raises(BeamInputError, match="true unit"):
        make_setup(counts, window=(0.0, 2.0), effects="modal_damping,quadratic_drag", modes=2)
    assert make_setup(counts, window=(0.0, 2.0), effects="modal_damping", modes=2).effects == ("modal_damping",)
