"""MuJoCo's warnings as the plant sees them: counters in ``MjData.warning``, never printed or logged.

The plant reads the warning counters to raise its ``PHYSICS_WARNING`` and ``UNSTABLE`` flags
(:mod:`ftc_mj.plant.truth`); the warning texts themselves are dropped (:func:`silence_mujoco_warnings`).
"""

from __future__ import annotations

import mujoco

BAD_STATE_WARNINGS = tuple(int(w) for w in (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                                            mujoco.mjtWarning.mjWARN_BADQACC))
"""MuJoCo's "simulation is unstable" warnings (NaN, Inf or > 1e10 in qpos, qvel, qacc)."""


def _drop_warning(message: str) -> None:
    """MuJoCo warning handler: the plant reads the warning counters of ``MjData`` instead."""


def silence_mujoco_warnings() -> None:
    """Route MuJoCo's warning texts to a handler that drops them, instead of MuJoCo's default, which prints
    them and appends them to ``MUJOCO_LOG.TXT`` in the current working directory. Process-wide and
    idempotent; the counters in ``MjData.warning`` (and so the plant's flags) are unaffected."""
    if mujoco.get_mju_user_warning() is not _drop_warning:
        mujoco.set_mju_user_warning(_drop_warning)
