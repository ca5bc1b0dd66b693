"""Metrics of a run computed from its trace (``metrics.json``): the run's estimation, tracking,
actuation, solver, plant and reconfiguration metrics (:mod:`.run`), the fault decision's detection
and isolation per onset (:mod:`.detection`), the records a study sweeps thresholds over (:mod:`.fdi`)
and the path-following metrics (:mod:`.path`). The scheduled fault onsets they are measured from are
in :mod:`.onsets`. Nothing here runs a simulation."""
