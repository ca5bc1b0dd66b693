"""A claim beyond the paper: does active FTC keep the robot on its path on the physical plant?

Checked on the path-following axis of the matrix (:func:`~ftc_mj.paper.matrix.pathfollow_runs`): the
path-following NMPC (``pf-nmpc``) with the UKF, the ``safe`` reconfiguration policy and a yaw-rate gyro on
scenarios 1–4, beside the time-parametrised NMPC in the same setting (the policy axis' runs), and with speed
sensing only under ``safe`` and ``none``; ``ftc-mj paper`` evaluates it on every seed of its seed set,
the study ``pathfollow`` runs the full controller × policy × sensing comparison (docs/findings.md).

The thresholds are those asked of a fault-tolerant controller worth the name on this robot: on the
path (within :data:`ON_PATH` from 5 s after the last puncture) without lifting a wheel outside the
1 s puncture transients for more than :data:`LIFTOFF_MAX`, never tipped; when the damaged robot
cannot reach the desired speed (scenario 4, the left tyre shrinks to 0.1 m) within
:data:`NEAR_PATH` of the path for the whole run at a speed within :data:`SPEED_TOL` of the one its
wheels can still give; without a fault at the desired speed within 1 %.
"""

from __future__ import annotations

from typing import Any

from ..matrix import PF_SCENARIOS, POLICY_RATE_PENALTY, make_label
from .checks import Evidence, Rows, all_of, chk, claim, evaluate, fmt, le, num, truthy
from .thresholds import LIFTOFF_MAX, NEAR_PATH, ON_PATH, POLICY_TOL, SCENARIO1_SPEED, SCENARIO1_TRACK, SPEED_TOL


def _label(sc: str, controller: str, policy: str, sensing: str) -> str:
    return make_label(sc, "ukf", policy, controller, sensing=sensing, rate_penalty=POLICY_RATE_PENALTY)


def _n(sc: str) -> int:
    return int(sc.removeprefix("scenario"))


def _row_numbers(r: dict[str, Any] | None) -> dict[str, Any]:
    return {"max |e_c| from last onset+5 s [m]": num(r, "contouring_max_recovered"),
            "max |e_c| after 5 s [m]": num(r, "cross_track_max_settled"),
            "lift-off after transients [s]": num(r, "liftoff_time_post_transient_s"),
            "tipped": truthy(r, "tipped"),
            "speed last 5 s / feasible": num(r, "speed_ratio_final"),
            "at the lateral bound [s]": num(r, "lateral_bound_time_s")}


@claim("P1")
def claim_pathfollow_on_path(c: Evidence, rows: Rows) -> None:
    for sc in PF_SCENARIOS:
        for ctl in ("pf-nmpc", "nmpc"):
            c.table.append({"scenario": _n(sc), "controller": ctl,
                            **_row_numbers(rows.get(_label(sc, ctl, "safe", "speed+yaw")))})
    for sc in ("scenario2", "scenario3"):
        lb = _label(sc, "pf-nmpc", "safe", "speed+yaw")
        r = rows.get(lb)
        e, lift, tip = num(r, "contouring_max_recovered"), num(r, "liftoff_time_post_transient_s"), truthy(r, "tipped")
        c.checks.append(chk(f"scenario {_n(sc)}: max |e_c| from 5 s after the last onset ≤ {ON_PATH:g} m, lift-off "
                            f"outside the transients ≤ {LIFTOFF_MAX:g} s, not tipped",
                            all_of(le(e, ON_PATH), le(lift, LIFTOFF_MAX), None if tip is None else not tip),
                            f"{fmt(e, ' m')}, {fmt(lift, ' s')}, tipped {tip}", lb))
    lb = _label("scenario4", "pf-nmpc", "safe", "speed+yaw")
    r = rows.get(lb)
    e, ratio, tip = num(r, "cross_track_max_settled"), num(r, "speed_ratio_final"), truthy(r, "tipped")
    c.checks.append(chk(f"scenario 4: within {NEAR_PATH:g} m of the path after 5 s, speed over the last 5 s within "
                        f"{SPEED_TOL:.0%} of the feasible speed, not tipped",
                        all_of(le(e, NEAR_PATH), None if ratio is None else abs(ratio - 1.0) <= SPEED_TOL,
                               None if tip is None else not tip),
                        f"{fmt(e, ' m')}, speed/feasible {fmt(ratio)}, tipped {tip}", lb))
    lb = _label("scenario1", "pf-nmpc", "safe", "speed+yaw")
    r = rows.get(lb)
    e, v = num(r, "cross_track_max_settled"), num(r, "speed_mean_final")
    c.checks.append(chk(f"scenario 1: max |e_c| after 5 s ≤ {SCENARIO1_TRACK:g} m and speed within "
                        f"{SCENARIO1_SPEED:.0%} of 10 m/s",
                        all_of(le(e, SCENARIO1_TRACK), None if v is None else abs(v / 10.0 - 1.0) <= SCENARIO1_SPEED),
                        f"{fmt(e, ' m')}, {fmt(v, ' m/s')}", lb))
    for sc in ("scenario2", "scenario3", "scenario4"):
        la, lb = _label(sc, "pf-nmpc", "none", "speed"), _label(sc, "pf-nmpc", "safe", "speed")
        a = num(rows.get(la), "contouring_max_recovered")
        b = num(rows.get(lb), "contouring_max_recovered")
        c.checks.append(chk(f"scenario {_n(sc)}, speed only: safe ≤ none + {POLICY_TOL:g} m (max |e_c| from 5 s "
                            f"after the last onset)", le(b, None if a is None else a + POLICY_TOL),
                            f"safe {fmt(b, ' m')} vs none {fmt(a, ' m')}", la, lb))
    nm = [num(rows.get(_label(sc, "nmpc", "safe", "speed+yaw")), "liftoff_time_post_transient_s")
          for sc in ("scenario2", "scenario3")]
    if all(x is not None for x in nm):
        c.notes.append(f"The time-parametrised NMPC in the same setting lifts a wheel for {fmt(nm[0], ' s')} "
                       f"(scenario 2) and {fmt(nm[1], ' s')} (scenario 3) outside the puncture transients: it must "
                       "catch up with the reference after the detection delay. The full comparison on held-out seeds "
                       "is the study `pathfollow` (docs/findings.md).")


PATHFOLLOW_CLAIMS = (claim_pathfollow_on_path,)


def evaluate_pathfollow_claims(rows: Rows) -> list[Evidence]:
    """The path-following claim, evaluated on ``rows`` (label → flattened metrics)."""
    return evaluate(PATHFOLLOW_CLAIMS, rows)
