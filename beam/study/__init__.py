"""Calibration-window studies: many calibrations (records x windows x effect sets x likelihoods) on Dask.

See :func:`beam.study.run.run_study`, :func:`beam.study.windows.parse_windows` and ``beam study``.
"""

from beam.study.cells import StudyCell, run_cell
from beam.study.run import StudyResult, parse_effect_sets, run_study, study_cells
from beam.study.windows import default_windows, parse_windows

__all__ = ["StudyCell", "StudyResult", "default_windows", "parse_effect_sets", "parse_windows", "run_cell",
           "run_study", "study_cells"]
