"""Which physical effect is missing from a calibrated beam model: the diagnosis.

:func:`diagnose` runs the whole diagnosis and returns one :class:`DiagnosisReport`;
:func:`diagnosis_stream` is the same diagnosis as a generator that says which fits it needs,
for a caller that runs them elsewhere (the dashboard's worker processes, a Dask cluster).

The names are imported on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public name -> module that defines it.
_LAZY = {
    "DiagnosisReport": "beam.discovery.findings",
    "Remaining": "beam.discovery.findings",
    "ResidualReport": "beam.discovery.findings",
    "VerdictParts": "beam.discovery.findings",
    "diagnose": "beam.discovery.report",
    "Candidate": "beam.discovery.ranking",
    "LadderStep": "beam.discovery.ranking",
    "Ranking": "beam.discovery.ranking",
    "WAIT": "beam.discovery.stream",
    "BaseRequest": "beam.discovery.stream",
    "CheckRequest": "beam.discovery.stream",
    "Done": "beam.discovery.stream",
    "FitRequest": "beam.discovery.stream",
    "Speculation": "beam.discovery.stream",
    "Step": "beam.discovery.stream",
    "diagnosis_stream": "beam.discovery.stream",
    "run_request": "beam.discovery.stream",
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'beam.discovery' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
