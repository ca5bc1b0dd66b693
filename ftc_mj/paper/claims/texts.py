"""The statements of every claim ``ftc-mj paper`` checks, by claim id, in the order ``claims.md``
lists them: its title and what the paper says (quoted or closely paraphrased, with its section), or
for the claims beyond the paper (R1–R3, P1) the setting they are restated in.

The checks of a claim are in its family module (:mod:`.paper`, :mod:`.policy`, :mod:`.pathfollow`);
:func:`.checks.claim` starts each claim's :class:`~.checks.Evidence` from this table.
"""

from __future__ import annotations

CLAIM_TEXTS: dict[str, tuple[str, str]] = {
    "1": (
        "All filters detect the scenario 2 fault, with a peak in the innovations at the fault",
        "§4.2: 'all filters were able to detect the fault … at 10 seconds there was a peak change in the "
        "innovation curves'."),
    "2": (
        "Without feedback the robot cannot stay on the path after a puncture",
        "§4.2: 'the robot was only able to remain on the path if feedback from the filter was provided to "
        "reconfigure the controller'; §4.3: 'without feedback it is impossible to maintain the robot on the "
        "path. Reconfiguring the controller … allowed the robot to easily follow the reference path'."),
    "3": (
        "Scenario 1: all filters estimate the radii well; innovations within 2σ about 95 % of the time",
        "§4.1: 'the speed innovations remained well within the uncertainty bounds … both with and without "
        "feedback'; 'All filters do a very good job of estimating the radius of the tyres with and without "
        "feedback'; 'the robot remained on the path with and without feedback'; the IMMs 'were able to very "
        "quickly detect the correct mode of operation'."),
    "4": (
        "Scenario 4: the 4-model IMMs fail, the 5-model IMMs succeed",
        "§4.4: 'Both of the IMM filters failed, because the fault type of scenario 4 was not modelled'; "
        "filter re-design: 'if a hypothesis is made the IMM performs very well … the filters do an excellent "
        "job of making the correct estimations on the radius of the wheel'."),
    "5": (
        "Scenario 4: the EKF breaks down with feedback (not without); the UKF stays consistent",
        "§4.4: 'The EKF breaks down 5 seconds after the fault occurs, when feedback is turned on as can be seen "
        "by the innovations exceeding the covariance bounds. Without feedback however the innovations remain "
        "within the uncertainty bounds. The results from the UKF are much better … innovations which remain "
        "well within the uncertainty bounds with and without feedback'."),
    "6": (
        "Scenario 4: the UKF is the best single filter",
        "§4.4: 'without a hypothesis on the IMM filters the UKF was the only filter able to produce the correct "
        "estimates of the wheel radii'; 'the UKF was able to maintain the robot on the path the longest'; "
        "§4.5: 'the UKF displayed better performance than the EKF, especially in the case of scenario 4'."),
    "7": (
        "The LMPC diverges in scenario 2 while the NMPC tracks",
        "§4.6: 'the nonlinear MPC controller does an excellent job of keeping the robot on the path despite a "
        "faulty wheel whereas the solution produced by the linear controller has diverged'; the radius "
        "estimates are 'the same' with both; the innovation uncertainty with the LMPC is 'double'; scenario 4: "
        "'Neither of the controllers were able to drive the robot to the path'."),
    "8": (
        "The wheel rates limit-cycle under the NMPC (less than under the LMPC)",
        "§4.6: 'the switching behaviour observed in wheel rotation rates is highly undesirable … The wheel rates "
        "produced by the nonlinear MPC controller show a dramatic decrease in this switching behaviour. It is, "
        "however, still present'."),
    "9": (
        "The IMMs reach the correct estimate faster than the UKF at the 10 s step",
        "§4.5: 'The IMM filters were able to reach the correct estimate faster than the single UKF particularly "
        "when a sudden change is present as is evident at the 10 second mark'; §4.2: 'The IMM filters produced "
        "slightly better estimates than the single UKF filter'."),
    "10": (
        "Scenario 3 (left puncture at 5 s, right at 10 s)",
        "§4.3: innovations 'clearly indicated … the detection of both faults'; 'the IMM filters produce the "
        "best estimates of the radii. The UKF performs slightly better than the EKF, and turning feedback on "
        "results in a faster settling time'; IMMs: 'after 5 secs model 3 is the best model … once the second "
        "fault occurs … mode 4 is the correct match'; 'An anomaly occurred with the UKF filter where even "
        "turning the feedback on did not result in the robot following the path after the … second fault'."),
    "11": (
        "The IMMs find the correct mode immediately (scenarios 2 and 4 with 5 models)",
        "§4.2: 'both of the IMM filters were seen to find the correct mode immediately as mode 3 is the most "
        "confident'; §4.4 (re-design): 'if a hypothesis is made the IMM performs very well'."),
    "12": (
        "Scenario 4: the wheels work at their constraints after the fault; no controller keeps the path",
        "§4.4: 'with this type of fault both wheels were required to work at their constraints'; 'none of the "
        "filters show full compliance with the reference trajectory'; 5-model IMMs: 'the control inputs are "
        "required to work at the constraints the majority of the time once the fault occurred'."),
    "R1": (
        "Direct feedback of the estimated radii keeps the robot on the path better than none",
        "Beyond the paper's matrix. The paper's §4.2–4.3 claim that reconfiguring the controller with "
        "the filter's estimates keeps the robot on the path, restated on the policy axis: the same runs with "
        "policy `direct` against `none`, with the paper's speed sensing and with a yaw-rate gyro added, UKF, "
        "NMPC with the actuation-rate term."),
    "R2": (
        "The safe policy never makes a fault worse than no reconfiguration",
        "Beyond the paper: an active FTC system must not make a fault worse. Policy `safe` hands radii "
        "over only when the fault is declared and isolated and the filter's covariance says the radii (and "
        "their split) are identified, clamps and rate-limits them, and reverts on filter trouble."),
    "R3": (
        "With a yaw-rate gyro the safe policy hands over within 2 s and keeps the robot on the path",
        "Beyond the paper: with speed + yaw rate both radii are observable, so the safe policy should "
        "reconfigure the controller soon after the fault and the robot should stay within 1 m of the path from "
        "5 s after the fault."),
    "P1": (
        "With a yaw-rate gyro, active FTC with the path-following NMPC keeps the robot on its path on "
        "the physical plant and slows it to what the damaged robot can still do",
        "Beyond the paper: the paper's loop, reconfigured with the estimated radii, tracks a time-parametrised "
        "reference; on the MuJoCo robot the return after the ≈0.7 s detection delay lifts a wheel "
        "(docs/findings.md). Here the controller follows the geometric path with its own progress, bounded by "
        "the robot's derived lift-off limit; UKF, `safe` policy, speed + yaw rate (σ 0.01 rad/s)."),
}
"""Claim id → (title, what the paper says)."""
