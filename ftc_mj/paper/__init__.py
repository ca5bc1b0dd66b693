"""``ftc-mj paper``: the paper's test matrix run as a study and its claims judged — over seeds, or
on seed 0 in the single-seed quick look (the same pipeline with one seed).

One direction, no cycles: :mod:`.matrix` and :mod:`.seeds` (what runs) → :mod:`.matrix_study`
(running it as a study; :mod:`.derived` adds the trace-derived metrics) → :mod:`.claims` (checks,
claim families, thresholds) → :mod:`.verdicts` (judging them per seed and over seeds) →
:mod:`.render` (``claims.md``), :mod:`.diff` (against a baseline), :mod:`.figures`,
:mod:`.summary` (``summary.csv``) and :mod:`.tuning` (the data-tuned parameters) → :mod:`.run` (the
pipeline and ``paper_run.json``). ``docs/paper-claims.md`` is published from an output folder by
:mod:`ftc_mj.reports.paper_claims`, in the reports layer above this package.
"""
