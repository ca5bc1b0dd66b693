"""Studies: parameter sweeps and Monte-Carlo runs on dask.distributed (``ftc-mj study``).

- :mod:`.spec` — study files (pydantic, one-line errors), expansion into a plan of runs with
  stable run keys;
- :mod:`.worker` — one run inside a worker process, returned as plain data;
- :mod:`.runner` — the client: cluster connection, submission, ``as_completed`` persistence of
  each row, resume;
- :mod:`.store` — the output folder (identity check, rows, log, ``results.parquet``);
- :mod:`.analysis` — ``summary.md`` and figures (means with 95 % confidence intervals).

See ``docs/studies.md``.
"""

from .runner import StudyReport, run_study
from .spec import StudyPlan, load_study

__all__ = ["StudyPlan", "StudyReport", "load_study", "run_study"]
