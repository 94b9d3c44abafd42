"""Simulated measurements: run a config through :class:`beam.physics.model.BeamModel` and write files.

:func:`simulate` gives the time, voltage, clean and noisy displacement of a
:class:`beam.io.config.SimulationConfig`; :func:`write_simulation` writes them in the measurement
format (``PREFIX.csv`` + ``PREFIX.toml``, holding only what a lab would know) plus
``PREFIX.truth.toml`` with everything that produced them (true parameters, effects, modes, noise,
seed, excitation, sampling), so that a hidden effect stays hidden from whoever calibrates.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from beam.errors import BeamInputError
from beam.io.config import SimulationConfig, check_parameters, read_knots
from beam.io.measurement import OUTPUT_COLUMNS, Measurement, measurement_paths, write_measurement
from beam.io.text import TomlReader, dump_toml, load_toml
from beam.physics.effects import parse_effects
from beam.physics.model import BeamModel

#: Suffix of the true-parameter file next to a simulated measurement.
TRUTH_SUFFIX = ".truth.toml"


@dataclass(frozen=True, eq=False)
class Simulation:
    """A simulated record and how it was made.

    Parameters
    ----------
    config : SimulationConfig
        The config simulated.
    modes : int or None
        Modes retained by the modal response (None: all modes).
    noise_m : float
        Standard deviation of the Gaussian noise added (m).
    seed : int
        Seed of the noise generator.
    time_s, voltage_V : numpy.ndarray
        Sample times t_k = k / rate_Hz (s) and held voltage (V).
    clean_displacement_m, displacement_m : numpy.ndarray
        The model's output at the sensor (``config.output``: a displacement in m unless the
        config asks for another output, e.g. a strain), and the same plus noise.
    """

    config: SimulationConfig
    modes: int | None
    noise_m: float
    seed: int
    time_s: np.ndarray = field(repr=False)
    voltage_V: np.ndarray = field(repr=False)
    clean_displacement_m: np.ndarray = field(repr=False)
    displacement_m: np.ndarray = field(repr=False)

    def measurement(self, name: str = "simulated") -> Measurement:
        """The noisy record as a :class:`Measurement` (title, geometry and nominal of the config)."""
        column = next(c for c, kind in OUTPUT_COLUMNS.items() if kind == self.config.output)
        return Measurement(
            name=name, title=self.config.title, geometry=self.config.geometry, time_s=self.time_s,
            voltage_V=self.voltage_V, nominal=dict(self.config.nominal),
            nominal_spread={k: v for k, v in self.config.nominal_spread.items() if k in self.config.nominal},
            **{column: self.displacement_m},
        )

    def truth_document(self) -> dict[str, Any]:
        """Contents of ``PREFIX.truth.toml``: everything needed to reproduce the record."""
        config = self.config
        excitation, sampling = config.require_simulation()
        excitation_table = excitation.to_table()
        return {
            "title": config.title,
            "config": str(config.path) if config.path else "",
            "effects": list(config.effects),
            "modes": "all" if self.modes is None else int(self.modes),
            "noise_m": float(self.noise_m),
            "seed": int(self.seed),
            "intervals": int(config.intervals),
            "knots": config.knots,
            "parameters": dict(config.parameters),
            "excitation": excitation_table,
            "sampling": {"rate_Hz": float(sampling.rate_Hz), "duration_s": float(sampling.duration_s),
                         "samples": int(self.time_s.size)},
        }


def simulate(
    config: SimulationConfig,
    *,
    modes: int | None = None,
    noise_m: float | None = None,
    seed: int | None = None,
) -> Simulation:
    """Simulate the sensor's output of a config (``config.output``), with Gaussian sensor noise.

    Parameters
    ----------
    config : SimulationConfig
        Geometry, true parameters, excitation and sampling.
    modes : int or None
        Modes kept by :meth:`BeamModel.response`; None keeps all of them.
    noise_m : float, optional
        Noise standard deviation in the output's unit (m for a displacement); default
        ``[sampling] noise_m``.
    seed : int, optional
        Noise seed (``numpy.random.default_rng``); default ``[sampling] seed``.

    Returns
    -------
    Simulation
    """
    excitation, sampling = config.require_simulation()
    noise_m = sampling.noise_m if noise_m is None else noise_m
    seed = sampling.seed if seed is None else seed
    if isinstance(noise_m, bool) or not np.isfinite(noise_m) or noise_m < 0:
        raise BeamInputError(f"noise must be a finite number >= 0 (m), got {noise_m!r}")
    if isinstance(seed, bool) or int(seed) != seed or seed < 0:
        raise BeamInputError(f"seed must be an integer >= 0, got {seed!r}")
    time_s = sampling.time_s()
    voltage_V = excitation.voltage(time_s)
    model = BeamModel(config.geometry, config.effects, config.intervals, config.knots)
    clean = model.response(config.parameters, voltage_V, sampling.sample_interval_s, modes=modes, output=config.output)
    clean = np.asarray(clean, dtype=float)
    clean = clean.reshape(time_s.size)  # one parameter set: (n,), also if the model returns (1, n)
    if not np.all(np.isfinite(clean)):
        raise BeamInputError(f"the simulated {config.output} is not finite (unstable parameters or time step?)")
    noise = np.random.default_rng(int(seed)).normal(0.0, float(noise_m), size=time_s.size) if noise_m > 0 else 0.0
    return Simulation(
        config=config, modes=modes, noise_m=float(noise_m), seed=int(seed), time_s=time_s, voltage_V=voltage_V,
        clean_displacement_m=clean, displacement_m=clean + noise,
    )


def truth_path(prefix: str | os.PathLike[str]) -> Path:
    """``PREFIX.truth.toml`` for an output prefix."""
    csv_path, _ = measurement_paths(prefix)
    return csv_path.with_name(csv_path.stem + TRUTH_SUFFIX)


def write_simulation(prefix: str | os.PathLike[str], simulation: Simulation) -> tuple[Path, Path, Path]:
    """Write ``PREFIX.csv``, ``PREFIX.toml`` and ``PREFIX.truth.toml`` in one all-or-nothing step.

    Parameters
    ----------
    prefix : str or path-like
        Output path without suffix; parent directories are created.
    simulation : Simulation
        What to write.

    Returns
    -------
    tuple of Path
        The CSV, sidecar and truth files.
    """
    truth = truth_path(prefix)
    truth_text = dump_toml(
        simulation.truth_document(),
        header_comment="True parameters of a simulated measurement: keep away from whoever calibrates.\n"
        "The measurement itself is the .csv and .toml of the same name.",
    )
    written = write_measurement(prefix, simulation.measurement(), extra_files={truth: truth_text})
    return written.csv_path, written.toml_path, truth


@dataclass(frozen=True)
class Truth:
    """What ``PREFIX.truth.toml`` records about a simulated measurement.

    Parameters
    ----------
    parameters : dict
        True parameter values by public name.
    effects : tuple of str
        Effects switched on in the simulation.
    modes : int or None
        Modes kept (None: all).
    noise_m : float
        Noise standard deviation (m).
    seed : int
        Noise seed.
    intervals : int
        B-spline elements of the model.
    knots : str
        Knot layout of the model (``"patch"`` or ``"uniform"``; ``"uniform"`` when the file
        predates the patch knots and has no ``knots``).
    excitation, sampling : dict
        The ``[excitation]`` and ``[sampling]`` tables as written.
    path : Path
        The truth file.
    """

    parameters: dict[str, float]
    effects: tuple[str, ...]
    modes: int | None
    noise_m: float
    seed: int
    intervals: int
    knots: str
    excitation: dict[str, Any]
    sampling: dict[str, Any]
    path: Path


def read_truth(path: str | os.PathLike[str]) -> Truth:
    """Read ``PREFIX.truth.toml`` (or the truth file next to ``PREFIX.csv`` / ``PREFIX.toml``).

    Parameters
    ----------
    path : str or path-like
        The truth file, or either file of the measurement pair.

    Returns
    -------
    Truth
    """
    path = Path(path)
    if not path.name.endswith(TRUTH_SUFFIX):
        path = truth_path(path)
    reader = TomlReader(load_toml(path, "truth file"), path)
    document = reader.document
    reader.check_top_level(
        tables=("parameters", "excitation", "sampling"),
        keys=("title", "config", "effects", "modes", "noise_m", "seed", "intervals", "knots"),
    )
    parameters = check_parameters(reader.table("parameters"), f"{path}: [parameters]")
    effects = document.get("effects")
    if not isinstance(effects, list):
        raise reader.fail("effects", f"must be an array of effect ids, got {effects!r}")
    modes = document.get("modes", "all")
    if modes != "all" and (isinstance(modes, bool) or not isinstance(modes, int) or modes < 1):
        raise reader.fail("modes", f"must be a positive integer or \"all\", got {modes!r}")
    try:
        effect_ids = parse_effects(effects)
    except BeamInputError as exc:
        raise reader.fail("effects", str(exc)) from None
    return Truth(
        parameters=parameters,
        effects=effect_ids,
        modes=None if modes == "all" else modes,
        noise_m=reader.number(None, document, "noise_m", allow_zero=True),
        seed=reader.integer(None, document, "seed", minimum=0),
        intervals=reader.integer(None, document, "intervals", minimum=2),
        knots=read_knots(reader, document, None, default="uniform"),
        excitation=dict(reader.table("excitation")),
        sampling=dict(reader.table("sampling")),
        path=path,
    )
