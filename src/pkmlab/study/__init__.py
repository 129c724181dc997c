"""Studies: many runs of one scenario — gain and speed sweeps, uncertainty (Monte Carlo) studies, gain
tuning — on one machine's cores or a Dask cluster.

* :mod:`~pkmlab.study.definition`: what a study is (base scenario, grid axes, draws of the plant);
* :mod:`~pkmlab.study.runs`: a chunk of runs in one process, one row per run, failures included;
* :mod:`~pkmlab.study.engine`: chunks on Dask (or in-process), written atomically, resumable;
* :mod:`~pkmlab.study.sweep`: the whole study — table, summary, figures (``pkmlab sweep``);
* :mod:`~pkmlab.study.tuning`: gains that minimise the worst-case error under an effort limit
  (``pkmlab tune``).

Needs the ``study`` extra (``pip install 'pkmlab[study]'``: Dask, pandas, PyArrow, Optuna).
"""

from .definition import Study, load_study, study_from_dict
from .engine import StudyError, StudyInterrupted
from .sweep import sweep
from .tuning import TuningResult, tune

__all__ = ["Study", "StudyError", "StudyInterrupted", "TuningResult", "load_study", "study_from_dict", "sweep",
           "tune"]
