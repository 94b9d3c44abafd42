"""Which physical effect is missing from a calibrated beam model: the diagnosis.

:func:`diagnose` runs the whole diagnosis and returns one :class:`DiagnosisReport`;
:func:`diagnosis_stream` is the same diagnosis as a generator that says which fits it needs,
for a caller that runs them elsewhere (the dashboard's worker processes, a Dask cluster).
"""

from __future__ import annotations

from beam.discovery.findings import DiagnosisReport, Remaining, ResidualReport, VerdictParts
from beam.discovery.ranking import Candidate, LadderStep, Ranking
from beam.discovery.report import diagnose
from beam.discovery.stream import (
    WAIT,
    BaseRequest,
    CheckRequest,
    CurveRequest,
    Done,
    FitRequest,
    Speculation,
    Step,
    diagnosis_stream,
    run_request,
)

__all__ = [
    "WAIT",
    "BaseRequest",
    "Candidate",
    "CheckRequest",
    "CurveRequest",
    "DiagnosisReport",
    "Done",
    "FitRequest",
    "LadderStep",
    "Ranking",
    "Remaining",
    "ResidualReport",
    "Speculation",
    "Step",
    "VerdictParts",
    "diagnose",
    "diagnosis_stream",
    "run_request",
]
