"""ftc-mj: active fault-tolerant control of a MuJoCo differential-drive robot.

Layers (data flows downwards; lower layers never import higher ones)::

    config ─┬─> plant (MuJoCo truth, faults, sensors)
            ├─> model (kinematics, one definition)
            ├─> estimation (EKF, UKF, IMM, fault decision)   uses model
            ├─> control (reference, NMPC, LMPC, open loop)   uses model
            └─> sim (multi-rate loop) -> trace, metrics, recorder (Rerun)
    report (paper matrix, claims, figures), study (dask sweeps), cli
"""

__version__ = "0.1.0"
