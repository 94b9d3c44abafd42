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
    changes the free length; a sensor or force point keeps its distance from the end it is
    nearer (a strain gauge near the root from the clamp's edge, an accelerometer near the tip
    from the tip), the patch its distance from the tip.
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
        """The same strip with ``length_m`` (m) of it free (the ``effective_length`` effect).

        The sensor and the force point keep their distance from the end of the stated free
        length they are nearer: one in the outer half (an accelerometer near the tip) keeps its
        distance from the tip and shifts by ``length_m - self.length_m`` from the clamp; one in
        the root half (a strain gauge near the clamp) keeps its distance from the clamp's edge.
        A position is measured from the end it is near, and that is where it is known: a gauge
        bonded 5 mm from the jaw reads the strain 5 mm from where the bar is held whatever the
        free length the record's modes call for (moving it with the tip put a root gauge of a
        419 mm bar vibrating as if 365 mm long inside the clamp). The patch keeps its distance
        from the tip; one reaching into the clamp is cut at its edge (the part held does not bend).

        Raises
        ------
        BeamInputError
            ``length_m`` not a positive finite number; the sensor or the force point would lie
            inside the clamp or beyond the tip, or the whole patch inside the clamp.
        """
        if isinstance(length_m, bool) or not isinstance(length_m, (int, float)) or not math.isfinite(length_m) or length_m <= 0:
            raise BeamInputError(f"effective_length_m must be a positive finite number, got {length_m!r}")
        shift = float(length_m) - self.length_m
        if shift == 0.0:
            return self
        sensor = self._kept_position("sensor", self.sensor_position_m, float(length_m))
        force = None if self.force_position_m is None else self._kept_position("force point", self.force_position_m,
                                                                                 float(length_m))
        start = end = None
        if self.has_patch:
            end = self.patch_end_m + shift
            if end <= 0:
                raise BeamInputError(f"effective_length_m = {length_m:g} m puts the whole patch inside the clamp")
            start = max(self.patch_start_m + shift, 0.0)
        return replace(
            self, length_m=float(length_m), patch_start_m=start, patch_end_m=end, sensor_position_m=sensor,
            force_position_m=force,
            width_m=None if self.width_m is None else min(self.width_m, float(length_m)),
            thickness_m=None if self.thickness_m is None else min(self.thickness_m, float(length_m)),
        )

    def _kept_position(self, what: str, position_m: float, length_m: float) -> float:
        """Where a point at ``position_m`` (m from the clamp) lies on the strip with ``length_m``
        free (:meth:`with_free_length`): its distance from the nearer end kept."""
        from_root = position_m <= 0.5 * self.length_m
        moved = position_m if from_root else length_m - (self.length_m - position_m)
        if moved <= 0:
            raise BeamInputError(f"effective_length_m = {length_m:g} m puts the {what} ({self.length_m - position_m:g} m "
                                 "from the tip) inside the clamp")
        if moved > length_m:
            raise BeamInputError(f"effective_length_m = {length_m:g} m puts the {what} ({position_m:g} m from the clamp) "
                                 "beyond the tip")
        return moved
