"""Geometry of the cantilever, its piezo patch and its displacement sensor."""

from __future__ import annotations

import math
from dataclasses import dataclass

from beam.errors import BeamInputError
from beam.io.limits import LENGTH_RANGE_M, LINEAR_DENSITY_RANGE_KG_M


@dataclass(frozen=True)
class BeamGeometry:
    """What a lab knows about the beam before any calibration.

    Parameters
    ----------
    length_m : float
        Beam length L (m); clamped at x = 0, free at x = L.
    linear_density_kg_m : float
        Linear density rho of the bare beam (kg/m); fixed, never calibrated.
    patch_start_m, patch_end_m : float
        Ends p_l < p_r of the piezoelectric patch (m), inside [0, L].
    sensor_position_m : float
        Where the displacement w(x_obs, t) is measured (m), in (0, L].
    """

    length_m: float
    linear_density_kg_m: float
    patch_start_m: float
    patch_end_m: float
    sensor_position_m: float

    def __post_init__(self) -> None:
        for name in ("length_m", "linear_density_kg_m", "patch_start_m", "patch_end_m", "sensor_position_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise BeamInputError(f"{name} must be a finite number, got {value!r}")
        for name, (low, high), unit in (("length_m", LENGTH_RANGE_M, "m"),
                                        ("linear_density_kg_m", LINEAR_DENSITY_RANGE_KG_M, "kg/m")):
            value = getattr(self, name)
            if value <= 0:
                raise BeamInputError(f"{name} must be positive, got {value}")
            if not low <= value <= high:
                raise BeamInputError(f"{name} must lie in [{low:g}, {high:g}] {unit} (where the model is finite), got {value:g}")
        if not 0 <= self.patch_start_m < self.patch_end_m <= self.length_m:
            raise BeamInputError(
                f"patch must satisfy 0 <= start_m < end_m <= length_m = {self.length_m}, "
                f"got start_m = {self.patch_start_m}, end_m = {self.patch_end_m}"
            )
        if not 0 < self.sensor_position_m <= self.length_m:
            raise BeamInputError(
                f"sensor position_m must lie in (0, {self.length_m}] (on the beam, not at the clamp), "
                f"got {self.sensor_position_m}"
            )

    @property
    def mass_kg(self) -> float:
        """Mass of the bare beam rho L (kg)."""
        return self.linear_density_kg_m * self.length_m
