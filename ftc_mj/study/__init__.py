"""Studies: parameter sweeps and Monte-Carlo runs on dask.distributed (``ftc-mj study``).

- :mod:`.spec` — the study file's schema (pydantic, one-line errors);
- :mod:`.plan` — a study file expanded into a plan of runs with stable run keys (:func:`plan_study`);
- :mod:`.worker` — one run inside a worker process, returned as plain data;
- :mod:`.runner` — the client: cluster connection, submission, ``as_completed`` persistence of
  each row, resume;
- :mod:`.store` — the output folder (identity check, rows, log, ``results.parquet``);
- :mod:`.stats`, :mod:`.series`, :mod:`.metrics` — 95 % intervals, the compact time series, the
  summarised metrics and their grouping by axis;
- :mod:`.analysis` — ``summary.md`` (:mod:`.findings`, :mod:`.tables`) and its figures
  (:mod:`.summary_figures` on :mod:`.plotting`);
- :mod:`.fdi` — ``ftc-mj fdi-curves``: operating characteristics of the decision rules.

The published tables of ``docs/`` from the built-in studies (``ftc-mj study NAME --report``) are
:mod:`ftc_mj.reports.doc_tables`, in the reports layer above the studies.

See ``docs/studies.md``.
"""

from .plan import StudyPlan, plan_study
from .runner import StudyReport, run_study

__all__ = ["StudyPlan", "StudyReport", "plan_study", "run_study"]
