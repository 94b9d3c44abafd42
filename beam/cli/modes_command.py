"""``beam modes CONFIG.toml [--count N] [--json]``: natural frequencies and damping ratios."""

from __future__ import annotations

import argparse
import json
import sys

from beam.cli.arguments import positive_int
from beam.config import load_config


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``modes`` subcommand."""
    parser = subparsers.add_parser(
        "modes",
        help="natural frequencies (Hz) and damping ratios of a config's true parameters",
        description="Natural frequencies |lambda|/2pi (Hz) and damping ratios -Re(lambda)/|lambda| of the full "
        "Galerkin model of CONFIG's [parameters] (geometry and parameters are needed; [excitation] and "
        "[sampling] are not).",
    )
    parser.add_argument("config", metavar="CONFIG.toml", help="simulation config")
    parser.add_argument("--count", type=positive_int, default=None, metavar="N",
                        help="show the N lowest modes (default: all)")
    parser.add_argument("--json", action="store_true",
                        help='print {"frequencies_Hz": [...], "damping_ratios": [...]} instead of a table')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the modes; returns the exit status."""
    config = load_config(args.config)
    from beam.model import BeamModel  # scipy is slow to import: only once the config is valid

    model = BeamModel(config.geometry, config.effects, config.intervals, config.knots)
    count = None if args.count is None else min(args.count, model.size)
    frequencies, ratios = model.natural_modes(config.parameters, count)
    if args.json:
        document = {"frequencies_Hz": [float(f) for f in frequencies], "damping_ratios": [float(z) for z in ratios]}
        sys.stdout.write(json.dumps(document) + "\n")
        return 0
    effects = ", ".join(config.effects) or "none"
    lines = [f"{config.title} (effects: {effects}; {config.intervals} intervals, knots {config.knots!r})",
             f"{'mode':>4}  {'frequency (Hz)':>15}  {'damping ratio':>13}"]
    lines += [f"{i:>4}  {f:>15.6g}  {z:>13.4g}" for i, (f, z) in enumerate(zip(frequencies, ratios), start=1)]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
