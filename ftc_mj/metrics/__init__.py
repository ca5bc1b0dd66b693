"""Metrics of a run computed from its trace (``metrics.json``): the run's estimation, tracking,
actuation, solver, plant and reconfiguration metrics (:mod:`.run`), the fault decision's detection
and isolation per onset (:mod:`.detection`), the records a study sweeps thresholds over (:mod:`.fdi`)
and the path-following metrics (:mod:`.path`), from the trace and the run's resolved record
(:mod:`.record`, built once by :mod:`ftc_mj.sim.record`), not from the application config; the distinct
onsets the detection metrics window by are in :mod:`.onsets`. Nothing here runs a simulation."""
