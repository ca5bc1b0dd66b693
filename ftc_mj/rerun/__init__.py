"""Rerun recordings of runs: written only when a run asks for ``run.rrd`` (or a comparison is made),
so this package — and rerun-sdk — is imported only by code that writes or views a recording.

- :mod:`~ftc_mj.rerun.stream`: a recording stream with a file sink, time columns and column builders;
- :mod:`~ftc_mj.rerun.record`: one run's recording (:func:`~ftc_mj.rerun.record.write_rrd`);
- :mod:`~ftc_mj.rerun.blueprint`: the layout of a run's recording;
- :mod:`~ftc_mj.rerun.overlay`: one recording overlaying several runs (``ftc-mj compare``);
- :mod:`~ftc_mj.rerun.read`: reading series and events back from a ``.rrd``;
- :mod:`~ftc_mj.rerun.viewer`: the native Rerun viewer (``ftc-mj view``).

Nothing is imported here, so ``import ftc_mj.rerun.<module>`` loads only what that module needs.
"""
