"""Limits on what users may load and calibrate (constants only).

The record checks and the decimation that use them are in :mod:`beam.calibration.records`.

Caps (each refusal is a one-line :class:`beam.errors.BeamInputError`):

:data:`MAX_MEASUREMENT_BYTES`
    64 MiB per measurement CSV, about 1.3 million samples written at full precision (~50 bytes
    a row); larger files are refused before they are read.
:data:`MAX_TOML_BYTES`
    1 MiB per sidecar, config or truth file.
:data:`LENGTH_RANGE_M`, :data:`LINEAR_DENSITY_RANGE_KG_M`
    A sidecar's or config's beam: 0.01 m to 100 m long, 1e-3 to 1e4 kg/m.
:data:`MAX_CALIBRATION_SAMPLES`
    20,000 samples per calibrated record; longer records are decimated by
    :func:`beam.calibration.records.decimate_measurement`.
:data:`MAX_ABS_VOLTAGE_V`, :data:`MIN_DISPLACEMENT_VARIATION_M`
    A record to calibrate (:func:`beam.calibration.records.check_calibration_record`): |voltage| at most 1e4 V (piezo
    patches are driven at a few hundred volts) and not zero throughout; in the window, the
    displacement at most the beam's length in size and varying by more than 1e-12 m (standard
    deviation).

The geometry ranges are where :class:`beam.physics.model.BeamModel` is finite for every parameter at
the corners of the default prior ranges (``tests/test_reliability_numerics.py`` checks them);
outside them its matrices overflow or its eigensolver fails.
"""

from __future__ import annotations

#: Largest measurement CSV read (bytes).
MAX_MEASUREMENT_BYTES = 64 * 2**20
#: Largest sidecar, config or truth TOML read (bytes).
MAX_TOML_BYTES = 2**20
from beam.physics.geometry import LENGTH_RANGE_M, LINEAR_DENSITY_RANGE_KG_M  # noqa: E402,F401 - the model's range, re-exported
#: Most samples a calibration uses; longer records are decimated.
MAX_CALIBRATION_SAMPLES = 20_000
#: Largest |voltage| (V) of a record to calibrate.
MAX_ABS_VOLTAGE_V = 1e4
#: Smallest standard deviation (m) of the displacement in a calibration window.
MIN_DISPLACEMENT_VARIATION_M = 1e-12

#: Anti-alias filter: taps per unit of decimation factor, and cutoff (fraction of the new Nyquist).
FILTER_TAPS_PER_FACTOR = 40
FILTER_CUTOFF = 0.9
