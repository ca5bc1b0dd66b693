"""The reports layer: what turns the results of the studies, the paper and the benchmark into the pages
of ``docs/``. It sits above :mod:`ftc_mj.study`, :mod:`ftc_mj.paper` and :mod:`ftc_mj.benchmark`, and
nothing below imports it (``tests/test_architecture.py`` checks the layer order).

- :mod:`.doc_tables` — the published tables (and the path-following figure) of the built-in studies,
  printed by ``ftc-mj study NAME --report``;
- :mod:`.paper_claims` — ``ftc-mj paper --publish DOCS``: ``DOCS/paper-claims.md`` and its figures;
- :mod:`.benchmark_page` — ``ftc-mj bench … --publish DOCS``: ``DOCS/benchmark.md`` and its figures.

Every table is built by the one Markdown helper :mod:`ftc_mj.markdown` (it sits at the base, since the
study summaries, ``claims.md`` and the leaderboard below this layer write tables too).
"""
