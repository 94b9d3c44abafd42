"""The ``beam`` command line: one module per subcommand, each with ``register(subparsers)``."""

from beam.cli.main import main

__all__ = ["main"]
