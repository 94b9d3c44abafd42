"""Stand-ins for the records real labs bring, made with the project's simulator (:class:`BeamModel`):
a steel bar tapped with a hammer and read by a strain gauge near its root, an aluminium strip
plucked and read by an accelerometer; and the artifacts injected into them (mains hum with
harmonics, spikes, a saturated converter, a second tap in the middle of a decay).

Nothing here knows how the artifacts are found: each record is made from the physics and the
artifact's own definition, and returned with its truth.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

#: A steel bar 400 x 20 x 3 mm (rho A = 7850 x 6e-5 = 0.471 kg/m; E I = 207e9 x 4.5e-11 = 9.315 N m²),
#: a strain gauge 30 mm from the clamp, the hammer at the tip. Modes 15.6, 97.5, 273, 535 Hz.
BAR_LENGTH, BAR_WIDTH, BAR_THICKNESS = 0.4, 0.02, 0.003
BAR_DENSITY = 7850.0 * BAR_WIDTH * BAR_THICKNESS
BAR_EI = 207e9 * BAR_WIDTH * BAR_THICKNESS**3 / 12
BAR_GAUGE = 0.03
BAR = BeamGeometry(BAR_LENGTH, BAR_DENSITY, None, None, BAR_GAUGE, force_position_m=BAR_LENGTH,
                   width_m=BAR_WIDTH, thickness_m=BAR_THICKNESS)
#: The bar's true damping (air + Kelvin-Voigt): zeta 4.1e-3 on mode 1 (a decay time of 2.5 s), 2.6e-3 on mode 2.
BAR_TRUTH = {"bending_stiffness_Nm2": BAR_EI, "air_damping_Ns_m2": 0.35, "kelvin_voigt_Nm2s": 6e-5}
#: The bar described as a student would (the sidecar's keys).
BAR_DESCRIPTION = {"beam": {"length_m": BAR_LENGTH, "width_m": BAR_WIDTH, "thickness_m": BAR_THICKNESS,
                            "material": "steel"}, "sensor": {"position_m": BAR_GAUGE}}

#: An aluminium strip 300 x 20 x 2 mm (rho A = 0.108 kg/m, E I = 69e9 x 1.333e-11 = 0.92 N m²),
#: an accelerometer 1 cm from the tip. Modes 18.1, 113.7, 318 Hz.
STRIP_LENGTH = 0.3
STRIP_DENSITY = 2700.0 * 0.02 * 0.002
STRIP_EI = 69e9 * 0.02 * 0.002**3 / 12
STRIP = BeamGeometry(STRIP_LENGTH, STRIP_DENSITY, None, None, STRIP_LENGTH - 0.01, width_m=0.02, thickness_m=0.002)
STRIP_TRUTH = {"bending_stiffness_Nm2": STRIP_EI, "air_damping_Ns_m2": 0.02, "kelvin_voigt_Nm2s": 4e-6}
STRIP_DESCRIPTION = {"beam": {"length_m": STRIP_LENGTH, "width_m": 0.02, "thickness_m": 0.002,
                              "material": "aluminium"}, "sensor": {"position_m": STRIP_LENGTH - 0.01}}


def hammer(time_s: np.ndarray, onsets_s, impulses_Ns, contact_s: float = 1.5e-3) -> np.ndarray:
    """A hammer's force (N): a half-sine pulse of ``contact_s`` at each onset, of the given impulse (N s)."""
    force = np.zeros_like(time_s)
    for onset, impulse in zip(onsets_s, impulses_Ns):
        inside = (time_s >= onset) & (time_s < onset + contact_s)
        force[inside] += impulse * np.pi / (2 * contact_s) * np.sin(np.pi * (time_s[inside] - onset) / contact_s)
    return force


def tapped_bar(onsets_s, impulses_Ns, *, duration_s: float, rate_Hz: float = 2000.0, noise: float = 2e-8,
               seed: int = 0, truth: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bar's strain (SI) at the gauge under hammer taps, every mode of the Galerkin model, plus
    Gaussian noise; returns (time, noisy strain, clean strain)."""
    model = BeamModel(BAR, ("air_damping", "kelvin_voigt"), input_kind="force")
    t = np.arange(int(round(duration_s * rate_Hz))) / rate_Hz
    fine = 10  # the contact resolved: the force held over steps of a tenth of the record's
    t_fine = np.arange(t.size * fine) / (rate_Hz * fine)
    force = hammer(t_fine, onsets_s, impulses_Ns)
    clean = model.response(truth or BAR_TRUTH, force, 1 / (rate_Hz * fine), None, output="strain")[::fine]
    return t, clean + noise * np.random.default_rng(seed).standard_normal(t.size), clean


def plucked_strip(*, duration_s: float = 4.0, rate_Hz: float = 1000.0, peak: float = 20.0, noise: float = 0.02,
                  offset: float = 0.3, seed: int = 1, truth: dict | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The strip released from rest (mode 1 and a little of mode 2, the first 3 modes), accelerometer
    output (m/s²) starting at ``peak`` m/s², with an offset and Gaussian noise; (time, noisy, clean)."""
    model = BeamModel(STRIP, ("air_damping", "kelvin_voigt"), input_kind=None)
    t = np.arange(int(round(duration_s * rate_Hz))) / rate_Hz
    clean = model.free_response(truth or STRIP_TRUTH, t, [1.0, -0.004, 0.0], [0.0, 0.0, 0.0], modes=3,
                                output="acceleration")
    clean *= peak / np.abs(clean).max()
    return t, clean + offset + noise * np.random.default_rng(seed).standard_normal(t.size), clean + offset


@dataclass(frozen=True)
class HumTruth:
    mains_Hz: float
    lines_Hz: tuple[float, ...]
    amplitudes: tuple[float, ...]

    def evaluate(self, time_s: np.ndarray) -> np.ndarray:
        phases = np.linspace(0.3, 2.9, len(self.lines_Hz))
        return sum(a * np.cos(2 * np.pi * f * time_s + p) for f, a, p in zip(self.lines_Hz, self.amplitudes, phases))


def mains_hum(mains_Hz: float, harmonics, amplitudes, offset_pct: float = 0.03) -> HumTruth:
    """Hum at ``mains_Hz`` off by ``offset_pct`` % (a grid's drift, a logger's clock) and its harmonics."""
    fundamental = mains_Hz * (1 + offset_pct / 100)
    return HumTruth(mains_Hz, tuple(k * fundamental for k in harmonics), tuple(amplitudes))


def write_table(path: Path, header: str, time_s: np.ndarray, values: np.ndarray, scale: float = 1.0,
                digits: int = 9) -> Path:
    """A lab's text export: ``header`` then ``time,value * scale`` rows."""
    rows = "\n".join(f"{t:.6f},{v * scale:.{digits}g}" for t, v in zip(time_s, values))
    path.write_text(header + "\n" + rows + "\n", encoding="utf-8")
    return path
