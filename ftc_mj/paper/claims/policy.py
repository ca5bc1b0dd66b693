"""Claims about the reconfiguration policies, checked on the matrix's policy axis.

The policy axis (:func:`~ftc_mj.paper.matrix.policy_runs`) runs scenarios 2–4 with the UKF and the
NMPC with the actuation-rate term, under the policies ``none`` / ``direct`` / ``safe``, with speed
only and with speed + yaw rate. The claims are the paper's own about feedback (restated for the
physical plant) and the safety property asked of the ``safe`` policy. Preconditions stated in
advance (the outcome rules are in :mod:`.checks`):

- R2 compares ``safe`` with ``none``; a ``safe`` run that never handed radii over kept the nominal
  radii throughout, i.e. it is the ``none`` run by construction, so its comparisons are n/a;
- R3's "stays on the path" needs a reference the robot can follow: it is n/a when, with the true
  radii after the fault, the kinematic model needs a wheel rate beyond the limit somewhere in the
  checked window (``reference_feasible_recovered``); its hand-over is timed from the onset of a step
  fault and from the declaration of a ramp (a ramp is not detectable at its onset).
"""

from __future__ import annotations

from typing import Any

from ...metrics.run import FAULT_TRANSIENT_S
from ..matrix import POLICY_RATE_PENALTY, POLICY_SCENARIOS, make_label
from .checks import Evidence, Rows, chk, claim, evaluate, fmt, le, num, truthy
from .thresholds import HANDOVER_MAX_DELAY, POLICY_TOL, RECOVERED_ON_PATH

NO_HANDOVER = "safe never handed radii over: it is the none run by construction"
INFEASIBLE = "with the true radii the reference needs a wheel rate beyond the limit"
RAMPS = ("scenario4",)
"""Policy-axis scenarios whose fault is a ramp (hand-over timed from the declaration)."""
SENSING = (("speed", "speed"), ("yaw", "speed + yaw rate"))


def plabel(sc: str, policy: str, sensing: str) -> str:
    """Label of a policy-axis run (``sensing``: 'speed' or 'yaw')."""
    return make_label(sc, "ukf", policy, "nmpc", sensing="speed+yaw" if sensing == "yaw" else "speed",
                      rate_penalty=POLICY_RATE_PENALTY)


def _n(sc: str) -> int:
    return int(sc.removeprefix("scenario"))


def _evidence(rows: Rows) -> list[dict[str, Any]]:
    out = []
    for sc in POLICY_SCENARIOS:
        for sens, sname in SENSING:
            for pol in ("none", "direct", "safe"):
                r = rows.get(plabel(sc, pol, sens))
                out.append({"scenario": _n(sc), "sensing": sname, "policy": pol,
                            "max |cte| from onset+5 s [m]": num(r, "cross_track_max_recovered"),
                            "final |cte| [m]": None if num(r, "cross_track_final") is None
                            else abs(num(r, "cross_track_final") or 0.0),
                            "wheel at limit [s]": num(r, "omega_at_limit_s"),
                            "lift-off after transients [s]": num(r, "liftoff_time_post_transient_s"),
                            "tipped": truthy(r, "tipped"),
                            "first hand-over after onset [s]": num(r, "reconfig_handover_delay"),
                            "reverts": num(r, "reconfig_reverts")})
    return out


@claim("R1")
def claim_direct_feedback(c: Evidence, rows: Rows) -> None:
    c.table = _evidence(rows)
    helped, harmed = [], []
    for sc in POLICY_SCENARIOS:
        for sens, sname in SENSING:
            l0, l1 = plabel(sc, "none", sens), plabel(sc, "direct", sens)
            a, b = num(rows.get(l0), "cross_track_max_recovered"), num(rows.get(l1), "cross_track_max_recovered")
            ok = le(b, None if a is None else a + POLICY_TOL)
            c.checks.append(chk(f"scenario {_n(sc)}, {sname}: direct ≤ none + {POLICY_TOL:g} m (max |cte| from "
                                f"5 s after the fault)", ok, f"direct {fmt(b, ' m')} vs none {fmt(a, ' m')}", l0, l1))
            if a is not None and b is not None:
                (helped if b < a - POLICY_TOL else harmed if b > a + POLICY_TOL else []).append(
                    f"scenario {_n(sc)} with {sname} ({fmt(a, ' m')} → {fmt(b, ' m')})")
    if helped:
        c.notes.append("Direct feedback helped in " + "; ".join(helped) + ".")
    if harmed:
        c.notes.append("It harmed in " + "; ".join(harmed) + ": with speed alone only R_R ωR + R_L ωL is "
                       "observable, and on the physical plant a wrong split drives the robot into slip and wheel "
                       "lift-off, where the no-slip model the filter uses no longer holds, so the estimate gets "
                       "worse (docs/findings.md).")


@claim("R2")
def claim_safe_no_harm(c: Evidence, rows: Rows) -> None:
    c.table = _evidence(rows)
    for sc in POLICY_SCENARIOS:
        for sens, sname in SENSING:
            l0, l1 = plabel(sc, "none", sens), plabel(sc, "safe", sens)
            r0, r1 = rows.get(l0), rows.get(l1)
            na = NO_HANDOVER if num(r1, "reconfig_handovers") == 0 else ""
            for key, what, unit in (("cross_track_max_recovered", "max |cte| from 5 s after the fault", " m"),
                                    ("omega_at_limit_s", "time with a wheel at its limit", " s"),
                                    ("liftoff_time_post_transient_s", "lift-off time outside the puncture transient",
                                     " s")):
                a, b = num(r0, key), num(r1, key)
                c.checks.append(chk(f"scenario {_n(sc)}, {sname}: safe {what} ≤ none + {POLICY_TOL:g}{unit}",
                                    le(b, None if a is None else a + POLICY_TOL),
                                    f"safe {fmt(b, unit)} vs none {fmt(a, unit)}", l0, l1, na=na))
            t0, t1 = truthy(r0, "tipped"), truthy(r1, "tipped")
            c.checks.append(chk(f"scenario {_n(sc)}, {sname}: safe does not tip the robot where none does not",
                                None if t0 is None or t1 is None else (not t1 or t0),
                                f"tipped: safe {fmt(t1)}, none {fmt(t0)}", l0, l1, na=na))
    excl = []
    for sc in POLICY_SCENARIOS:
        r = rows.get(plabel(sc, "none", "yaw"))
        k, dur = num(r, "onsets_in_run"), num(r, "sim_time_s")
        if k is not None and dur:
            excl.append(f"{k * FAULT_TRANSIENT_S / dur:.1%} of scenario {_n(sc)}'s run")
    if excl:
        c.notes.append(f"Lift-off is counted outside the {FAULT_TRANSIENT_S:g} s after each onset (the puncture's own "
                       f"skid and hop), a selection stated in advance; it excludes " + ", ".join(excl) + ".")
    same = [f"scenario {_n(sc)} ({sname})" for sc in POLICY_SCENARIOS for sens, sname in SENSING
            if num(rows.get(plabel(sc, "safe", sens)), "reconfig_handovers") == 0]
    if same:
        c.notes.append("The safe policy never handed radii over in " + ", ".join(same) + ": there the wheel could "
                       "not be isolated or the split was not identified (speed only), so it ran exactly as `none` "
                       "and those comparisons are n/a.")


@claim("R3")
def claim_safe_in_time(c: Evidence, rows: Rows) -> None:
    for sc in POLICY_SCENARIOS:
        lb = plabel(sc, "safe", "yaw")
        r = rows.get(lb)
        d, m = num(r, "reconfig_handover_delay"), num(r, "cross_track_max_recovered")
        t_det, t_hand = num(r, "detection_time"), num(r, "reconfig_first_handover_time")
        c.table.append({"scenario": _n(sc), "first hand-over after onset [s]": d,
                        "after declaration [s]": None if t_det is None or t_hand is None else t_hand - t_det,
                        "max |cte| from onset+5 s [m]": m, "reverts": num(r, "reconfig_reverts"),
                        "holds": num(r, "reconfig_holds"),
                        "reference feasible": truthy(r, "reference_feasible_recovered")})
        if sc in RAMPS:
            dd = None if t_det is None or t_hand is None else t_hand - t_det
            text, detail = (f"scenario {_n(sc)} (ramp): hand-over within {HANDOVER_MAX_DELAY:g} s of the declaration",
                            f"declared at {fmt(t_det, ' s')}, first hand-over at {fmt(t_hand, ' s')}")
        else:
            dd = d
            text, detail = (f"scenario {_n(sc)}: hand-over within {HANDOVER_MAX_DELAY:g} s of the fault",
                            f"hand-over after {fmt(d, ' s')}")
        handed = None if r is None else (dd is not None and -1e-9 < dd <= HANDOVER_MAX_DELAY)
        c.checks.append(chk(text, handed, detail, lb))
        feasible = truthy(r, "reference_feasible_recovered")
        req = num(r, "reference_omega_required_recovered")
        c.checks.append(chk(f"scenario {_n(sc)}: max |cte| from 5 s after the fault ≤ {RECOVERED_ON_PATH:g} m",
                            le(m, RECOVERED_ON_PATH), f"max |cte| {fmt(m, ' m')}; the reference needs up to "
                                                      f"{fmt(req, ' rad/s')} of wheel rate with the true radii", lb,
                            na=INFEASIBLE if feasible is False else ""))


POLICY_CLAIMS = (claim_direct_feedback, claim_safe_no_harm, claim_safe_in_time)


def evaluate_policy_claims(rows: Rows) -> list[Evidence]:
    """The reconfiguration-policy claims, evaluated on ``rows`` (label → flattened metrics)."""
    return evaluate(POLICY_CLAIMS, rows)
