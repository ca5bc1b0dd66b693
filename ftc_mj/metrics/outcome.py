"""The physical outcome of a run, beside its simulation ``status``: did the robot stay on its path,
leave it, or tip over. A run with status ``ok`` only *completed*; a robot that fell over is a valid
experimental result of a completed run, so the outcome is what says whether the controller held.

Keys added to ``metrics.json`` (:func:`physical_outcome`):

``outcome``
    ``on the path``, ``off the path``, ``tipped over`` or ``not judged`` (:data:`NOT_JUDGED`: status
    ``failed`` or ``unstable`` — the run did not complete, or its physics blew up — or a completed run that
    ended before the window it is judged on, e.g. a 15 s run of a fault at 10 s).
``outcome_rule``
    The rule that decided it, in words with its numbers (m, s).
``outcome_cross_track_m``
    The |cross-track error| (m) the rule compared with :data:`OFF_PATH_M`: its largest value from
    :data:`~ftc_mj.metrics.run.RECOVERY_S` after the first fault onset (``cross_track_max_recovered``),
    or, without a fault, from the settling time on (``cross_track_max_settled``).
``wheel_lifted``
    A wheel left the ground outside the transient after each onset (``liftoff_time_post_transient_s``
    > 0); reported beside the outcome, not instead of it (a short hop does not leave the path).
"""

from __future__ import annotations

import math
from typing import Any

from .run import RECOVERY_S

OFF_PATH_M = 0.5
"""A run is off the path when its |cross-track error| exceeds this (m) after the fault's recovery window."""
OUTCOMES = ("on the path", "off the path", "tipped over", "not judged")
"""Every value of ``outcome``, best first."""
NOT_JUDGED = (f"not judged: the run did not complete (status not ok), or it ended before the window its outcome "
              f"is judged on (from {RECOVERY_S:g} s after the first fault onset; without a fault, from the settling "
              "time) — a longer duration judges it")
"""What ``not judged`` means (printed in the run summary beside the outcome)."""


def _finite(v: Any) -> float | None:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) else None


def physical_outcome(m: dict[str, Any]) -> dict[str, Any]:
    """``outcome``, ``outcome_rule``, ``outcome_cross_track_m`` and ``wheel_lifted`` (module docstring) of a
    run's metrics ``m`` (which must hold ``status``, ``tipped`` and the tracking metrics)."""
    lift = _finite(m.get("liftoff_time_post_transient_s"))
    out: dict[str, Any] = {"wheel_lifted": bool(lift) if lift is not None else None}
    recovered = "cross_track_max_recovered" in m
    ct = _finite(m.get("cross_track_max_recovered" if recovered else "cross_track_max_settled"))
    out["outcome_cross_track_m"] = ct
    window = f"from {RECOVERY_S:g} s after the fault" if recovered else "after the settling time"
    if m.get("status") != "ok":
        out["outcome"] = "not judged"
        out["outcome_rule"] = f"status {m.get('status')}: the run did not complete soundly"
    elif m.get("tipped"):
        out["outcome"] = "tipped over"
        out["outcome_rule"] = "the chassis rolled or pitched past plant.tipped_limit_deg"
    elif ct is None:
        out["outcome"] = "not judged"
        out["outcome_rule"] = f"no cross-track error {window}: the run ended before; a longer duration judges it"
    else:
        off = ct > OFF_PATH_M
        out["outcome"] = "off the path" if off else "on the path"
        out["outcome_rule"] = (f"max |cross-track| {ct:.2f} m {window} {'>' if off else '<='} {OFF_PATH_M:g} m")
    return out
