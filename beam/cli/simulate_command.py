"""``beam simulate CONFIG.toml --out PREFIX``: a simulated measurement plus its truth file."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from beam.cli.arguments import non_negative_float, non_negative_int, positive_int
from beam.errors import BeamInputError
from beam.io.config import load_config


#: Unit of the noise sd in the summary line, by output (a strain is dimensionless).
NOISE_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²", "strain": "(strain)"}


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` subcommand."""
    parser = subparsers.add_parser(
        "simulate",
        help="simulate a measurement (PREFIX.csv + PREFIX.toml) and its truth file",
        description="Simulate CONFIG and write PREFIX.csv + PREFIX.toml in the measurement format (geometry, "
        "sensor and [nominal] only) and PREFIX.truth.toml (true parameters, effects, modes, noise, seed, "
        "excitation), so that a hidden effect stays hidden.",
    )
    parser.add_argument("config", metavar="CONFIG.toml", help="simulation config")
    parser.add_argument("--out", required=True, metavar="PREFIX", help="output path without suffix")
    parser.add_argument("--modes", type=positive_int, default=None, metavar="N",
                        help="modes kept by the modal response (default: all)")
    parser.add_argument("--noise", type=non_negative_float, default=None, metavar="SD",
                        help="noise standard deviation (m); default [sampling] noise_m, else 0")
    parser.add_argument("--seed", type=non_negative_int, default=None, metavar="S",
                        help="noise seed; default [sampling] seed, else 0")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Simulate and write the three files; returns the exit status."""
    config = load_config(args.config)
    config.require_simulation()
    folder = Path(args.out).parent
    try:
        folder.mkdir(parents=True, exist_ok=True)  # fail before simulating, not after
    except OSError as exc:
        raise BeamInputError(f"--out {args.out}: cannot create the folder {folder}: {exc.strerror}") from None
    from beam.io.simulation import (  # imports scipy: only once the config is valid
        simulate,
        write_simulation,
    )

    simulation = simulate(config, modes=args.modes, noise_m=args.noise, seed=args.seed)
    csv_path, toml_path, truth = write_simulation(args.out, simulation)
    modes = "all" if simulation.modes is None else simulation.modes
    sys.stdout.write(
        f"wrote {csv_path}, {toml_path} and {truth} ({simulation.time_s.size} samples at "
        f"{config.sampling.rate_Hz:g} Hz, effects: {', '.join(config.effects) or 'none'}, modes: {modes}, "
        f"noise {simulation.noise_m:g} {NOISE_UNITS[config.output]})\n"
    )
    return 0
