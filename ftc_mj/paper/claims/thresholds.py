"""The one table of thresholds the claims are judged with: every number a check compares against,
with its unit and meaning, in the order ``claims.md`` lists them (:data:`THRESHOLDS`).

The metric definitions the claims also name (``OFF_PATH``, ``SETTLE_TOL``, ``SETTLE_HOLD``) belong
to the derived metrics (:mod:`ftc_mj.paper.derived`) and are listed here with them.
"""

from __future__ import annotations

from ..derived import OFF_PATH as OFF_PATH  # in the table below (read by name)
from ..derived import SETTLE_HOLD
from ..derived import SETTLE_TOL as SETTLE_TOL  # in the table below (read by name)

# ------------------------------------------------------------------------------- the paper's claims (1–12)
DETECT_MAX_DELAY = 2.0
PEAK_Z = 6.0
GOOD_RMSE_NOFAULT = 0.1
GOOD_RMSE = 0.2
FAIL_RMSE = 0.3
INNOV_95 = 0.93
INNOV_OK = 0.90
MODE_MAX_DELAY = 1.0
CHATTER_REVERSALS = 1.0
CHATTER_AT_LIMIT = 0.05
LMPC_TV_RATIO = 2.0
SAME_ESTIMATE = 0.1
UNCERTAINTY_RATIO = 1.5
AT_LIMIT_MAJORITY = 0.5
MIN_IN_DOMAIN = 0.25

# ------------------------------------------------------------------------------- reconfiguration policies (R1–R3)
POLICY_TOL = 0.05
HANDOVER_MAX_DELAY = 2.0
RECOVERED_ON_PATH = 1.0

# ------------------------------------------------------------------------------- path following (P1)
ON_PATH = 0.5
NEAR_PATH = 1.0
LIFTOFF_MAX = 0.2
SPEED_TOL = 0.15
SCENARIO1_TRACK = 0.1
SCENARIO1_SPEED = 0.01

_MEANINGS: dict[str, str] = {
    "DETECT_MAX_DELAY": "s; a filter 'detects' the fault when its decision layer declares it within "
                        "this delay after onset, with no false alarm before",
    "PEAK_Z": "z-score of the 0.1 s-mean speed innovation within 1 s after an onset that counts as a "
              "visible innovation peak (noise alone gives about 3; see innovation_peak_z_ref)",
    "GOOD_RMSE_NOFAULT": "m; radius RMSE (either wheel, whole run) for 'estimates well' "
                         "without a fault (5 % of R0)",
    "GOOD_RMSE": "m; radius RMSE after the fault onset (and |final error|) for 'correct estimate' "
                 "(10 % of R0)",
    "FAIL_RMSE": "m; radius RMSE after the fault onset above which an estimate has 'failed'",
    "INNOV_95": "fraction of speed innovations inside ±2σ accepted as 'about 95 %'",
    "INNOV_OK": "fraction of speed innovations inside ±2σ (after the onset) below which a filter has "
                "'broken down' (also: any divergence reset)",
    "OFF_PATH": "m; |cross-track error| above which the robot is 'off the path' (the track width)",
    "SETTLE_TOL": f"m; a radius estimate has 'reached the correct value' when its error stays within "
                  f"this for {SETTLE_HOLD:g} s",
    "MODE_MAX_DELAY": "s; an IMM 'finds the correct mode immediately' when that mode is the most "
                      "probable (held 0.5 s) within this delay",
    "CHATTER_REVERSALS": "1/s; command reversals (steps > 1 rad/s changing sign, both wheels) "
                         "per second that count as limit cycling",
    "CHATTER_AT_LIMIT": "fraction of time after the fault with a wheel command at its limit "
                        "that counts as limit cycling (with reversals)",
    "LMPC_TV_RATIO": "LMPC/NMPC ratio of command total variation for 'a dramatic decrease in "
                     "switching' with the NMPC",
    "SAME_ESTIMATE": "m; difference of radius RMSEs for 'the same estimates'",
    "UNCERTAINTY_RATIO": "LMPC/NMPC ratio of the median innovation σ after the fault for "
                         "'about double the uncertainty'",
    "AT_LIMIT_MAJORITY": "fraction of time after the fault with a wheel command at its limit "
                         "for 'working at the constraints the majority of the time'",
    "MIN_IN_DOMAIN": "smallest share of the samples after the onset inside the kinematic model's "
                     "domain (no plant flag) for which an 'in the domain' RMSE is evaluated (else "
                     "n/a)",
    "POLICY_TOL": "m or s; a policy is 'not worse' than another when its cross-track error, wheel-rate "
                  "saturation time or lift-off time exceeds the other's by at most this",
    "HANDOVER_MAX_DELAY": "s; the safe policy 'hands over in time' when its first hand-over is "
                          "at most this long after the first fault onset",
    "RECOVERED_ON_PATH": "m; largest |cross-track error| from 5 s after the first fault onset "
                         "to the end for 'stays on the path'",
    "ON_PATH": "m; largest |contouring error| from 5 s after the last fault onset for 'on the path'",
    "NEAR_PATH": "m; largest |contouring error| after 5 s in scenario 4 (the whole run but the start)",
    "LIFTOFF_MAX": "s; wheel lift-off outside the 1 s puncture transients",
    "SPEED_TOL": "fraction; scenario 4 speed over the last 5 s against the feasible speed",
    "SCENARIO1_TRACK": "m; scenario 1 largest |contouring error| after 5 s",
    "SCENARIO1_SPEED": "fraction; scenario 1 mean speed against the desired 10 m/s",
}
"""Name → unit and meaning, in the order ``claims.md`` lists the thresholds."""

THRESHOLDS: dict[str, tuple[float, str]] = {name: (globals()[name], meaning) for name, meaning in _MEANINGS.items()}
"""Name → (value, unit and meaning): each constant above with its meaning."""
