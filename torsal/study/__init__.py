"""Design studies: many variants of one design as Dask tasks, one results table, a Pareto plot
against the standard shading devices (``torsal study``).

- :mod:`~torsal.study.study_file`: the study file (axes, search, run options) and its variants;
- :mod:`~torsal.study.study_tasks`: one variant's pipeline as a task, the executors;
- :mod:`~torsal.study.search`: optuna's multi-objective search (``[search]``);
- :mod:`~torsal.study.study_report`: results table, Pareto front, verdict and ``study.html``;
- :mod:`~torsal.study.study`: :class:`Study`, which ties them together.

Example
-------
>>> from torsal.study import Study
>>> Study.__name__
'Study'
"""
from .study import SHARED_STAGE, Study, StudyProgress, StudyResult
from .study_file import StudyFileError, StudySpec, Variant, load_study_file

__all__ = ["Study", "StudyProgress", "StudyResult", "StudyFileError", "StudySpec", "Variant",
           "load_study_file", "SHARED_STAGE"]
