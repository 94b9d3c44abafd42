"""Entry point of the ``beam`` console script.

Each subcommand lives in its own module exposing ``register(subparsers)``, which adds a parser
whose ``func(args) -> int`` runs the command. User errors (:class:`beam.errors.BeamInputError`,
unreadable files, bad options) end with exit status 2 and one line on stderr starting ``error:``.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from beam.errors import BeamInputError

#: Subcommand modules, in the order they appear in ``beam --help``.
COMMAND_MODULES = (
    "beam.cli.modes_command",
    "beam.cli.simulate_command",
    "beam.cli.toy_command",
    "beam.cli.calibrate_command",
    "beam.cli.diagnose_command",
    "beam.cli.study_command",
    "beam.cli.import_command",
)


class _OneLineErrorParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are a single ``error:`` line and exit status 2."""

    def error(self, message: str):
        sys.stderr.write(f"error: {self.prog}: {message}\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineErrorParser(
        prog="beam",
        description="Cantilever beam with a piezo patch: simulation, Bayesian calibration "
        "under model discrepancy, and diagnosis of missing physics.",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_OneLineErrorParser)
    subparsers.required = True
    for module_name in COMMAND_MODULES:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:  # a command still being written
            if exc.name == module_name:
                continue
            raise
        module.register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the ``beam`` command line; returns the process exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BeamInputError as exc:
        sys.stderr.write(f"error: {_one_line(str(exc))}\n")
        return 2
    except (OSError, UnicodeDecodeError) as exc:
        sys.stderr.write(f"error: {_one_line(str(exc))}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("error: interrupted\n")
        return 2
    except Exception as exc:  # a bug: still one line, never a traceback for the user
        sys.stderr.write(f"error: internal error ({type(exc).__name__}: {_one_line(str(exc))[:300]}); please report it\n")
        return 2


def _one_line(text: str) -> str:
    return " ".join(text.split())


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
