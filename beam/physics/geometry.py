"""Geometry of the cantilever, its piezo patch, its sensor and where a point force acts."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from beam.errors import BeamInputError

#: Beam lengths accepted in a sidecar or config (m), inclusive: where the model is finite for
#: every parameter at the corners of the default prior ranges (``tests/test_reliability_numerics.py``).
LENGTH_RANGE_M: tuple[float, float] = (1e-2, 1e2)
#: Linear densities accepted in a sidecar or config (kg/m), inclusive (the same).
LINEAR_DENSITY_RANGE_KG_M: tuple[float, float] = (1e-3, 1e4)


@dataclass(frozen=True)
class BeamGeometry:
    """What a lab knows about the beam before any calibration.

    Parameters
    ----------
    length_m : float
        Beam length L (m); clamped at x = 0, free at x = L.
    linear_density_kg_m : float
        Linear density rho of the bare beam (kg/m); fixed, never calibrated.
    patch_start_m, patch_end_m : float or None
        Ends p_l < p_r of the piezoelectric patch (m), inside [0, L]; both None for a beam
        without a patch (a record driven by a point force, or a free response).
    sensor_position_m : float
        Where the sensor measures w(x_obs, t) (or its velocity or acceleration) (m), in (0, L].
    force_position_m : float or None
        Where a measured point force acts (m), in (0, L]; None when no point force drives the beam.
    width_m : float or None
        Width b of the strip (m), the side the air meets as it bends (``[beam] width_m``); only the
        ``quadratic_drag`` effect needs it. None when unknown.
    thickness_m : float or None
        Thickness h of the strip (m) (``[beam] thickness_m``): a strain gauge on its surface
        reads epsilon = -(h/2) w''(x_obs) (the ``"strain"`` output). None when unknown.

    Notes
    -----
    Positions (patch, sensor, force) are measured from the clamp. :meth:`with_free_length`
    moves the clamp's edge and keeps every position's distance from the free tip.
    """

    length_m: float
    linear_density_kg_m: float
    patch_start_m: float | None
    patch_end_m: float | None
    sensor_position_m: float
    force_position_m: float | None = None
    width_m: float | None = None
    thickness_m: float | None = None

    def __post_init__(self) -> None:
        if (self.patch_start_m is None) != (self.patch_end_m is None):
            raise BeamInputError(
                f"patch needs both start_m and end_m (or neither, for a beam without a patch), got start_m = "
                f"{self.patch_start_m}, end_m = {self.patch_end_m}"
            )
        optional = ("patch_start_m", "patch_end_m", "force_position_m", "width_m", "thickness_m")
        for name in ("length_m", "linear_density_kg_m", "patch_start_m", "patch_end_m", "sensor_position_m",
                     "force_position_m", "width_m", "thickness_m"):
            value = getattr(self, name)
            if value is None and name in optional:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise BeamInputError(f"{name} must be a finite number, got {value!r}")
        for name, (low, high), unit in (("length_m", LENGTH_RANGE_M, "m"),
                                        ("linear_density_kg_m", LINEAR_DENSITY_RANGE_KG_M, "kg/m")):
            value = getattr(self, name)
            if value <= 0:
                raise BeamInputError(f"{name} must be positive, got {value}")
            if not low <= value <= high:
                raise BeamInputError(f"{name} must lie in [{low:g}, {high:g}] {unit} (where the model is finite), got {value:g}")
        if self.width_m is not None and not 0 < self.width_m <= self.length_m:
            raise BeamInputError(f"width_m must be positive and at most the length {self.length_m} m, got {self.width_m}")
        if self.thickness_m is not None and not 0 < self.thickness_m <= self.length_m:
            raise BeamInputError(f"thickness_m must be positive and at most the length {self.length_m} m, got {self.thickness_m}")
        if self.has_patch and not 0 <= self.patch_start_m < self.patch_end_m <= self.length_m:
            raise BeamInputError(
                f"patch must satisfy 0 <= start_m < end_m <= length_m = {self.length_m}, "
                f"got start_m = {self.patch_start_m}, end_m = {self.patch_end_m}"
            )
        if not 0 < self.sensor_position_m <= self.length_m:
            raise BeamInputError(
                f"sensor position_m must lie in (0, {self.length_m}] (on the beam, not at the clamp), "
                f"got {self.sensor_position_m}"
            )
        if self.force_position_m is not None and not 0 < self.force_position_m <= self.length_m:
            raise BeamInputError(
                f"force position_m must lie in (0, {self.length_m}] (on the beam, not at the clamp), "
                f"got {self.force_position_m}"
            )

    @property
    def has_patch(self) -> bool:
        """Whether the beam carries a piezo patch (``[patch]`` in the sidecar)."""
        return self.patch_start_m is not None

    @property
    def mass_kg(self) -> float:
        """Mass of the bare beam rho L (kg)."""
        return self.linear_density_kg_m * self.length_m

    def with_free_length(self, length_m: float) -> "BeamGeometry":
        """The same strip clamped so that ``length_m`` (m) of it is free (the ``effective_length`` effect).

        A clamp's edge is where the uncertainty lies: the free tip, and everything bonded to the
        strip (patch, sensor, force point), stay where they are on the strip, so every position
        keeps its distance from the tip and shifts by ``length_m - self.length_m`` from the
        clamp. A patch reaching into the clamp is cut at its edge (the part held does not bend).

        Raises
        ------
        BeamInputError
            ``length_m`` not a positive finite number; the sensor or the force point (or the
            whole patch) would lie inside the clamp.
        """
        if isinstance(length_m, bool) or not isinstance(length_m, (int, float)) or not math.isfinite(length_m) or length_m <= 0:
            raise BeamInputError(f"effective_length_m must be a positive finite number, got {length_m!r}")
        shift = float(length_m) - self.length_m
        if shift == 0.0:
            return self
        if self.sensor_position_m + shift <= 0:
            raise BeamInputError(f"effective_length_m = {length_m:g} m puts the sensor ({self.length_m - self.sensor_position_m:g} m "
                                 "from the tip) inside the clamp")
        if self.force_position_m is not None and self.force_position_m + shift <= 0:
            raise BeamInputError(f"effective_length_m = {length_m:g} m puts the force point inside the clamp")
        start = end = None
        if self.has_patch:
            end = self.patch_end_m + shift
            if end <= 0:
                raise BeamInputError(f"effective_length_m = {length_m:g} m puts the whole patch inside the clamp")
            start = max(self.patch_start_m + shift, 0.0)
        return replace(
            self, length_m=float(length_m), patch_start_m=start, patch_end_m=end,
            sensor_position_m=self.sensor_position_m + shift,
            force_position_m=None if self.force_position_m is None else self.force_position_m + shift,
            width_m=None if self.width_m is None else min(self.width_m, float(length_m)),
            thickness_m=None if self.thickness_m is None else min(self.thickness_m, float(length_m)),
        )
