"""Families of stand-in records: free decays of strips with a known hidden effect, recorded as
labs and phones record them, and the shared 50 cm runs resampled to phone rates, cut and
stretched to other lengths' frequencies.

The issues (#38, #40) ask that the diagnosis be right on records nobody tuned for; these are the
records it is measured on. Each record carries its truth: the model and parameters that made it
and, for the amplitude-resolved identification, the describing-function curves it must follow
(:meth:`FamilyRecord.expected`).

=====================  =========================================================================
family                 what (each × hidden effect ``none``, ``quadratic_drag``,
                       ``clamp_friction``, ``tip_cubic_spring``, ``sensor_mass``; seeds 0-4)
=====================  =========================================================================
``accelerometer``      accelerometer near the tip (0.95 L), uniform 1, 2 or 4 kHz, 12 s, noise
                       0.02-0.05 m/s²
``phone``              a phone (acceleration) at the tip or mid-span, 100-500 Hz, jittered stamps
                       (±0.3 step) with a few stalls of 3-8 steps, gravity offset, noise
                       0.01-0.04 m/s², only the modes below 0.45 × its rate (its sensor's filter)
``node``               accelerometer at mode 2's node (0.783 L), 1 kHz: mode 2 barely seen
``strain``             strain gauge 2-5 cm from the root, 1-5 kHz, noise 1e-7, mains hum (50 or
                       60 Hz ± 0.05 Hz with its 3rd and 5th harmonics, 0.5-3 % of the release)
``phone-artifacts``    the phone at mid-span, clipped at 50-80 % of its largest sample (the sensor's
                       range), 20 spikes
``lab-artifacts``      the accelerometer near the tip, 1 kHz, hum, 20 spikes, and a second pluck
                       at 55-65 % of the record (a new release at 0.5-0.9 of the first)
``shared``             the five shared 50 cm runs (``../shared/real-data``, else the two bundled
                       in ``assets/real``): as recorded, resampled to 100, 200 or 400 Hz phone
                       stamps after a low-pass at 0.4 × the rate, cut to 2-12 s, and stretched in
                       time by (L / 0.5 m)² for L = 0.3 and 0.7 m (the frequencies of those
                       lengths, the same damping ratios)
=====================  =========================================================================

Strips: aluminium 50 × 2 mm (E 70 GPa, 2700 kg/m³) or steel 25 × 1 mm (200 GPa, 7850 kg/m³),
even seeds aluminium, odd steel; length uniform in 0.25-0.7 m; released from rest under a tip
load deflecting the tip by 2-5 % of the length (:func:`beam.io.release.release_state`); modal
damping zeta1 0.001-0.004, zeta2 0.002-0.006. Hidden effects: ``quadratic_drag`` C_d 5-20;
``clamp_friction`` k_f 500-3000 EI / L, the release at 0.4-0.8 of the slip rotation
(microslip: its describing function holds); ``tip_cubic_spring`` a tangent stiffness at the
release 5-25 % of 3 EI / L³; ``sensor_mass`` 3-15 % of the strip's mass at the sensor.

Generation is deterministic by (family, effect, seed) and cached as ``.npz`` in the temporary
directory (``BEAM_FAMILY_CACHE`` to move it): the nonlinear decays take 0.5-5 s each to
integrate once.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.signal

from beam.io.measurement import Measurement, read_measurement
from beam.io.release import release_state
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

ROOT = Path(__file__).resolve().parents[1]
EFFECTS = ("none", "quadratic_drag", "clamp_friction", "tip_cubic_spring", "sensor_mass")
SEEDS = range(5)
FAMILIES = ("accelerometer", "phone", "node", "strain", "phone-artifacts", "lab-artifacts")
#: (E (Pa), density (kg/m³), width (m), thickness (m)) of the two strips.
MATERIALS = {"aluminium": (70e9, 2700.0, 0.05, 0.002), "steel": (200e9, 7850.0, 0.025, 0.001)}
#: Where mode 2 of a uniform cantilever has its node (x / L).
MODE2_NODE = 0.7834
AIR_DENSITY = 1.204  # kg/m³, written again for the describing functions
#: Bump when the generation changes, so that cached records are made again.
VERSION = 1


@dataclass(frozen=True, eq=False)
class FamilyRecord:
    """One stand-in record and its truth.

    Attributes
    ----------
    family, effect : str
        The family and the hidden effect (``"none"`` for none; ``"real"`` for a shared run).
    seed : int
        The seed (0-4); the variant's index for the shared runs.
    name : str
        ``family/effect/seed`` with the strip, e.g. ``phone/quadratic_drag/2 (aluminium 0.43 m)``.
    measurement : Measurement
        The record (its geometry, stamps, output, sensor range).
    model : BeamModel or None
        The model that made it (None for a shared run).
    parameters : dict
        Its parameters.
    modes : int
        Modes the simulation retained.
    release_eta : ndarray
        Modal state of the release (for the describing functions).
    reference : tuple or None
        For a shared run's variant: the identification of the run as recorded, the time scale s
        (t' = s t) of the variant, and its phone filter's gain against the run's frequency.
    """

    family: str
    effect: str
    seed: int
    name: str
    measurement: Measurement
    model: BeamModel | None
    parameters: dict = field(default_factory=dict)
    modes: int = 0
    release_eta: np.ndarray = field(default_factory=lambda: np.zeros(0))
    reference: tuple | None = None

    # ------------------------------------------------------------------ truth
    def modal(self):
        """(omega (m,) rad/s, shapes (n, m), sensor gain per unit modal coordinate (m,) of the
        record's output kind as a displacement or strain)."""
        omega2, shapes = self.model.mode_shapes(self.parameters, self.modes)
        kind = self.measurement.output_kind
        if kind == "strain":
            row = -0.5 * self.measurement.geometry.thickness_m * self.model.parts.sensor_curvatures
        else:
            row = self.model.parts.sensor_values
        return np.sqrt(omega2), shapes, row @ shapes

    def frequencies_Hz(self) -> np.ndarray:
        """The truth model's natural frequencies (Hz) of the retained modes (the modes to look for)."""
        if self.model is None:
            return np.array([m.peak_frequency_Hz for m in self.reference[0].resolved]) / self.reference[1]
        return self.modal()[0] / (2 * np.pi)

    def expected(self, identified) -> dict[int, tuple[np.ndarray, np.ndarray, float, float] | None]:
        """Per mode number of ``identified`` (a :class:`beam.residuals.FreeDecayBackbone` of this
        record, its modes asked at :meth:`frequencies_Hz`): the describing function's frequency
        (Hz) and damping ratio at each of its blocks' amplitudes, and their physical tolerances
        (relative to the frequency, and to the damping ratio); None where no closed form holds
        (a mode other than the first under the clamp friction, whose joint loop mixes them).

        The describing functions, written from ``docs/physics-*.md`` (not imported): modal
        amplitudes A_k = displacement amplitude / |sensor gain_k|;

        * linear (``none``, ``sensor_mass``): the model's omega_k and zeta_k;
        * ``quadratic_drag``: zeta_k = zeta_k0 + (4 / 3 pi) kappa_kk A_k + (2 / pi) kappa_pk
          omega_p A_p / omega_k (p the mode of the largest velocity, its drag damping mode k);
        * ``tip_cubic_spring``: omega_k (1 + 3 k3 psi_k⁴ A_k² / 8 omega_k² + Σ_j 3 k3 psi_k² psi_j²
          A_j² / 4 omega_k²), zeta_k0 omega_k / omega(A);
        * ``clamp_friction`` (mode 1): omega_1 (1 - alpha r³ A / 2 omega²), zeta_10 omega_1 /
          omega(A) + (2 / 3 pi) alpha r³ A / omega², alpha = k_f² / 4 M_s.
        """
        if self.model is None:
            return {} if self.effect == "recorded" else self._expected_from_reference(identified)
        omega, shapes, gain = self.modal()
        values = self.parameters
        zeta0 = np.array([values.get(f"damping_ratio_mode_{k + 1}", 0.0) for k in range(self.modes)])
        out: dict[int, tuple | None] = {}
        amplitude = {}
        for mode in identified.modes:
            if mode.resolved and mode.number <= self.modes:
                amplitude[mode.number] = (mode.time_s, mode.displacement_amplitude / abs(gain[mode.number - 1]))

        def at(number, times):
            if number not in amplitude:
                return np.zeros(times.size)
            t, a = amplitude[number]
            return np.interp(times, t, a)

        velocity = np.abs(self.release_eta) * omega
        p = int(np.argmax(velocity))
        for mode in identified.modes:
            k = mode.number - 1
            if not mode.resolved or k >= self.modes:
                continue
            a = at(k + 1, mode.time_s)
            f = np.full(a.size, omega[k] / (2 * np.pi))
            zeta = np.full(a.size, zeta0[k])
            tol_f, tol_z = 3e-4, 0.05
            if self.effect == "quadratic_drag":
                x, w = _span_quadrature(self.measurement.geometry.length_m)
                psi = self.model.parts.basis.evaluate(x, 0) @ shapes
                scale = 0.5 * AIR_DENSITY * self.measurement.geometry.width_m * values["drag_coefficient"]
                own = scale * (w @ np.abs(psi[:, k]) ** 3)
                zeta = zeta0[k] + 4 / (3 * math.pi) * own * a
                if k != p:
                    cross = scale * (w @ (np.abs(psi[:, p]) * psi[:, k] ** 2))
                    zeta = zeta + 2 / math.pi * cross * omega[p] * at(p + 1, mode.time_s) / omega[k]
                tol_z = 0.05
            elif self.effect == "tip_cubic_spring":
                k3 = values["tip_cubic_stiffness_N_m3"]
                tip = self.model.parts.tip_values @ shapes
                shift = 3 * k3 * tip[k] ** 4 * a**2 / (8 * omega[k] ** 2)
                for j in range(self.modes):
                    if j != k:
                        shift = shift + 3 * k3 * tip[k] ** 2 * tip[j] ** 2 * at(j + 1, mode.time_s) ** 2 / (4 * omega[k] ** 2)
                f = f * (1 + shift)
                zeta = zeta0[k] / (1 + shift)
                tol_f = 3e-4 + 0.05 * float(np.max(shift, initial=0.0))
            elif self.effect == "clamp_friction":
                if k != 0:
                    out[mode.number] = None
                    continue
                root = self.model.parts.basis.evaluate(np.zeros(1), 1)[0] @ shapes
                alpha = values["clamp_friction_stiffness_Nm_rad"] ** 2 / (4 * values["clamp_slip_moment_Nm"])
                drop = alpha * abs(root[0]) ** 3 * a / (2 * omega[0] ** 2)
                f = f * (1 - drop)
                zeta = zeta0[0] / (1 - drop) + 2 / (3 * math.pi) * alpha * abs(root[0]) ** 3 * a / omega[0] ** 2
                tol_f = 3e-4 + 0.15 * float(np.max(drop, initial=0.0))
                tol_z = 0.15
            out[mode.number] = (f, zeta, tol_f, tol_z)
        return out

    def _expected_from_reference(self, identified) -> dict[int, tuple | None]:
        """A shared run's variant: the run's own identification as recorded, its frequencies
        divided by the time scale, read at the variant's amplitudes (an acceleration scales by
        1 / s²); tolerances 3e-4 and 5 % as the simulated records'."""
        reference, scale, gain = self.reference
        out: dict[int, tuple | None] = {}
        for mode in identified.modes:
            if not mode.resolved or mode.number > len(reference.resolved):
                continue
            ref = reference.resolved[mode.number - 1]
            a_ref = ref.amplitude * gain(ref.frequency_Hz) / scale**2  # the variant's amplitude of the same swing
            order = np.argsort(a_ref)
            inside = (mode.amplitude >= a_ref.min()) & (mode.amplitude <= a_ref.max())
            f = np.interp(mode.amplitude, a_ref[order], ref.frequency_Hz[order]) / scale
            zeta = np.interp(mode.amplitude, a_ref[order], ref.damping_ratio[order])
            f[~inside], zeta[~inside] = np.nan, np.nan
            out[mode.number] = (f, zeta, 3e-4, 0.05)
        return out

    def agreement(self, identified, share: float = 0.8) -> dict[int, bool | None]:
        """Per mode with a truth: whether at least ``share`` of its blocks' frequency and damping
        ratio lie within 3 of their standard errors plus the tolerance of :meth:`expected`
        (None: no truth to compare with). A mode asked for and reported unresolved agrees when
        the record cannot show it (its note says why); a mode resolved but wrong never does."""
        out: dict[int, bool | None] = {}
        for number, truth in self.expected(identified).items():
            if truth is None:
                out[number] = None
                continue
            mode = identified.mode(number)
            f, zeta, tol_f, tol_z = truth
            known = np.isfinite(f) & np.isfinite(zeta)
            if not known.any():
                out[number] = None
                continue
            ok_f = np.abs(mode.frequency_Hz - f) <= 3 * mode.frequency_sd_Hz + tol_f * f
            ok_z = np.abs(mode.damping_ratio - zeta) <= 3 * mode.damping_ratio_sd + tol_z * zeta
            out[number] = bool(np.mean((ok_f & ok_z)[known]) >= share)
        return out


def _span_quadrature(length_m: float, points: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [0, L] in two halves (the drag's |psi|³ and the mode
    shapes' sign changes are smooth enough for 2 × 32 points)."""
    g, w = np.polynomial.legendre.leggauss(points)
    half = 0.5 * length_m
    x = np.concatenate([0.5 * half * (g + 1), half + 0.5 * half * (g + 1)])
    return x, np.concatenate([0.5 * half * w, 0.5 * half * w])


# ---------------------------------------------------------------------------------------------
# simulated families


def _cache_dir() -> Path:
    folder = Path(os.environ.get("BEAM_FAMILY_CACHE", Path(tempfile.gettempdir()) / "beam-record-families"))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _draws(family: str, effect: str, seed: int) -> dict:
    """Everything random about one record, from one generator seeded by its name."""
    digest = int(hashlib.sha256(f"{family}/{effect}/{seed}".encode()).hexdigest()[:12], 16)
    rng = np.random.default_rng(digest)
    material = "aluminium" if seed % 2 == 0 else "steel"
    d = {
        "material": material, "length": float(rng.uniform(0.25, 0.7)), "release": float(rng.uniform(0.02, 0.05)),
        "zeta1": float(rng.uniform(0.001, 0.004)), "zeta2": float(rng.uniform(0.002, 0.006)),
        "zeta3": float(rng.uniform(0.003, 0.008)), "cd": float(rng.uniform(5.0, 20.0)),
        "kf": float(rng.uniform(500.0, 3000.0)), "slip": float(rng.uniform(0.4, 0.8)),
        "k3": float(rng.uniform(0.05, 0.25)), "mass": float(rng.uniform(0.03, 0.15)),
        "rate_acc": float(rng.choice([1000.0, 2000.0, 4000.0])), "rate_phone": float(rng.uniform(100.0, 500.0)),
        "rate_strain": float(rng.choice([1000.0, 2000.0, 5000.0])), "noise": float(rng.uniform(0.0, 1.0)),
        "tip_or_mid": bool(rng.integers(2)), "root": float(rng.uniform(0.02, 0.05)),
        "mains": float(rng.choice([50.0, 60.0])), "hum": float(rng.uniform(0.005, 0.03)),
        "mains_offset": float(rng.uniform(-0.05, 0.05)), "clip": float(rng.uniform(0.5, 0.8)),
        "tap_at": float(rng.uniform(0.55, 0.65)), "tap_size": float(rng.uniform(0.5, 0.9)),
        "stream": int(rng.integers(1 << 31)),
    }
    return d


def _strip(d: dict, family: str, effect: str) -> tuple[BeamGeometry, float]:
    youngs, density, width, thickness = MATERIALS[d["material"]]
    length = d["length"]
    stiffness = youngs * width * thickness**3 / 12
    sensor = {"accelerometer": 0.95, "node": MODE2_NODE, "lab-artifacts": 0.95, "phone-artifacts": 0.5,
              "phone": 0.95 if d["tip_or_mid"] else 0.5}.get(family)
    position = d["root"] if family == "strain" else sensor * length
    geometry = BeamGeometry(length, density * width * thickness, None, None, position, width_m=width,
                            thickness_m=thickness)
    return geometry, stiffness


def _parameters(d: dict, effect: str, geometry: BeamGeometry, stiffness: float, modes: int) -> dict:
    values = {"bending_stiffness_Nm2": stiffness}
    for k in range(modes):
        values[f"damping_ratio_mode_{k + 1}"] = d[f"zeta{min(k + 1, 3)}"]
    length, tip = geometry.length_m, d["release"] * geometry.length_m
    if effect == "quadratic_drag":
        values["drag_coefficient"] = d["cd"]
    elif effect == "clamp_friction":
        kf = d["kf"] * stiffness / length
        moment = 3 * stiffness * tip / length**2  # the root moment of the release
        values["clamp_friction_stiffness_Nm_rad"] = kf
        values["clamp_slip_moment_Nm"] = moment / (2 * d["slip"])  # theta0 / theta_s = M0 / 2 M_s
    elif effect == "tip_cubic_spring":
        values["tip_cubic_stiffness_N_m3"] = d["k3"] * 3 * stiffness / length**3 / tip**2
    elif effect == "sensor_mass":
        values["sensor_mass_kg"] = d["mass"] * geometry.mass_kg
    return values


def _stamps(family: str, d: dict, duration: float, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    if family in ("phone", "phone-artifacts"):
        rate = d["rate_phone"]
        n = int(rate * duration)
        t = (np.arange(n) + rng.uniform(-0.3, 0.3, n)) / rate
        keep = np.ones(n, dtype=bool)
        for start in rng.choice(n - 10, 6, replace=False):
            keep[start: start + int(rng.integers(3, 8))] = False
        return np.sort(t[keep]), rate
    rate = {"strain": d["rate_strain"], "accelerometer": d["rate_acc"]}.get(family, 1000.0)
    return np.arange(int(rate * duration)) / rate, rate


def _model_effects(effect: str) -> list[str]:
    return ["modal_damping"] + ([] if effect == "none" else [effect])


def make_record(family: str, effect: str, seed: int, duration: float = 12.0) -> FamilyRecord:
    """One record of a simulated family (module notes), cached."""
    if family not in FAMILIES or effect not in EFFECTS:
        raise ValueError(f"unknown family {family!r} or effect {effect!r}")
    d = _draws(family, effect, seed)
    geometry, stiffness = _strip(d, family, effect)
    model = BeamModel(geometry, _model_effects(effect), input_kind=None)
    rng = np.random.default_rng(d["stream"])
    t, rate = _stamps(family, d, duration, rng)
    probe = _parameters(d, effect, geometry, stiffness, 4)
    omega2, _ = model.mode_shapes({k: v for k, v in probe.items()}, 4)
    below = np.sqrt(omega2) / (2 * np.pi) < 0.45 * rate
    modes = int(max(1, min(3, below.sum()))) if family.startswith("phone") else int(min(3, max(1, below.sum())))
    values = _parameters(d, effect, geometry, stiffness, modes)
    output = "strain" if family == "strain" else "acceleration"
    tip = d["release"] * geometry.length_m
    eta, rate0 = release_state(model, values, tip, modes)
    key = hashlib.sha256(json.dumps([VERSION, family, effect, seed, duration, modes, values, d],
                                    sort_keys=True, default=float).encode()).hexdigest()[:20]
    path = _cache_dir() / f"{key}.npz"
    if path.exists():
        clean = np.load(path)["clean"]
    else:
        clean = _simulate(family, d, model, values, t, eta, rate0, modes, output, geometry)
        partial = path.with_name(f"{key}.{os.getpid()}.tmp.npz")
        np.savez(partial, clean=clean)
        os.replace(partial, path)
    y = clean.copy()
    peak = float(np.max(np.abs(y)))
    if output == "strain":
        y += 1e-7 * (1 + d["noise"]) * rng.standard_normal(t.size)
    else:
        scale = (0.01, 0.04) if family.startswith("phone") else (0.02, 0.05)
        y += (scale[0] + d["noise"] * (scale[1] - scale[0])) * rng.standard_normal(t.size)
    if family.startswith("phone"):
        y += 0.3  # gravity along a slightly tilted axis
    sensor_range = None
    if family in ("strain", "lab-artifacts"):
        mains = d["mains"] + d["mains_offset"]
        for harmonic, share in ((1, 1.0), (3, 0.4), (5, 0.15)):
            y += d["hum"] * share * peak * np.cos(2 * np.pi * harmonic * mains * t + rng.uniform(0, 2 * np.pi))
    if family in ("phone-artifacts", "lab-artifacts"):
        k = rng.choice(t.size, 20, replace=False)
        y[k] += rng.choice([-1.0, 1.0], 20) * rng.uniform(0.2, 1.0, 20) * peak
    if family == "phone-artifacts":
        sensor_range = d["clip"] * peak
        y = np.clip(y, -sensor_range, sensor_range)
    column = "strain" if output == "strain" else "acceleration_m_s2"
    nominal = {"bending_stiffness_Nm2": stiffness}
    name = f"{family}/{effect}/{seed} ({d['material']} {geometry.length_m:.2f} m)"
    measurement = Measurement(name=f"{family}-{effect}-{seed}", title=name, geometry=geometry, time_s=t,
                              nominal=nominal, sensor_range=sensor_range, **{column: y})
    return FamilyRecord(family, effect, seed, name, measurement, model, values, modes, eta)


def _simulate(family, d, model, values, t, eta, rate0, modes, output, geometry) -> np.ndarray:
    """The clean output; for ``lab-artifacts`` a second pluck from rest at tap_at of the record."""
    clean = model.free_response(values, t, eta, rate0, modes=modes, output=output)
    if family == "lab-artifacts":
        at = int(d["tap_at"] * t.size)
        second, zero = release_state(model, values, d["tap_size"] * d["release"] * geometry.length_m, modes)
        clean = clean.copy()
        clean[at:] = model.free_response(values, t[at:], second, zero, modes=modes, output=output)
    return clean


def family(name: str, effects=EFFECTS, seeds=SEEDS) -> list[FamilyRecord]:
    """Every record of a family (its effects × seeds; the shared runs' variants for ``"shared"``)."""
    if name == "shared":
        return shared_family()
    return [make_record(name, effect, seed) for effect in effects for seed in seeds]


# ---------------------------------------------------------------------------------------------
# the shared real runs


def shared_runs() -> list[Path]:
    """The shared 50 cm runs beside the clone (``../shared/real-data``), else the bundled two."""
    for folder in (ROOT.parent / "shared" / "real-data", ROOT.parent.parent / "shared" / "real-data"):
        found = sorted(folder.glob("adxl_50cm_*.csv"))
        if found:
            return found
    return sorted((ROOT / "assets" / "real").glob("adxl_50cm_*.csv"))


def _phone_version(record: Measurement, rate: float, start: float, stop: float, scale: float,
                   rng: np.random.Generator):
    """A run cut to [start, stop] s, stretched in time by ``scale`` (t' = scale t: frequencies
    divided by it, the acceleration by its square) and recorded by a phone at ``rate`` (jittered
    stamps, its sensor's low-pass at 0.4 × rate: a 4th-order Butterworth run forwards and
    backwards on the run put on a uniform grid). Returns the measurement and the filter's gain
    (a function of the run's frequency, Hz), which scales each mode's amplitude."""
    t, y = record.time_s, record.output
    step = float(np.median(np.diff(t)))
    grid = np.arange(t[0], t[-1], step)
    uniform = np.interp(grid, t, y)
    sos = scipy.signal.butter(4, 0.4 * rate * scale, fs=1.0 / step, output="sos")
    smooth = scipy.signal.sosfiltfilt(sos, uniform)
    n = int((stop - start) * rate * scale)
    stamps = np.sort(start + (np.arange(n) + rng.uniform(-0.3, 0.3, n)) / (rate * scale))
    stamps = stamps[(stamps > grid[0]) & (stamps < grid[-1])]
    values = np.interp(stamps, grid, smooth) / scale**2

    def gain(frequency_Hz):
        _, response = scipy.signal.sosfreqz(sos, worN=np.atleast_1d(frequency_Hz), fs=1.0 / step)
        return np.abs(response) ** 2

    measurement = Measurement(name=f"{record.name}-{rate:g}Hz", title=record.title,
                              geometry=record.geometry.with_free_length(record.geometry.length_m * math.sqrt(scale)),
                              time_s=(stamps - start) * scale, nominal=dict(record.nominal), acceleration_m_s2=values)
    return measurement, gain


def shared_family() -> list[FamilyRecord]:
    """The shared runs' variants: each run as recorded, at 100/200/400 Hz phone stamps (the
    whole run), cut to 2-12 s at 200 Hz, and stretched to the frequencies of 0.3 and 0.7 m at
    400 Hz; their reference is the run's identification as recorded (:meth:`FamilyRecord.expected`)."""
    from beam.residuals import identify_backbone

    out = []
    for index, path in enumerate(shared_runs()):
        run = read_measurement(path)
        reference = identify_backbone(run.time_s, run.output, output=run.output_kind, clipped=run.clipped)
        rng = np.random.default_rng(index)
        end = float(run.time_s[-1])
        variants = [("as recorded", (run, np.ones_like), 1.0)]  # its own reference: timed, not scored
        for rate in (100.0, 200.0, 400.0):
            variants.append((f"{rate:g} Hz", _phone_version(run, rate, 0.0, end, 1.0, rng), 1.0))
        variants.append(("200 Hz, 2-12 s", _phone_version(run, 200.0, 2.0, 12.0, 1.0, rng), 1.0))
        for length in (0.3, 0.7):
            scale = (length / 0.5) ** 2
            variants.append((f"400 Hz as {length:g} m", _phone_version(run, 400.0, 0.0, end, scale, rng), scale))
        for k, (label, (measurement, gain), scale) in enumerate(variants):
            out.append(FamilyRecord("shared", "recorded" if k == 0 else "real", k, f"shared/{path.stem}/{label}",
                                    measurement, None, reference=(reference, scale, gain)))
    return out
