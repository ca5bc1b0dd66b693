"""The ``[diagnosis]`` section's models: the built-in residual diagnoser's
(:class:`ResidualDiagnoserSettings`), none (:class:`NoDiagnoserSettings`) and a plug-in's
(:class:`PluginDiagnoserSettings`). Every threshold is relative to a nominal quantity — a fraction of the
nominal radius, of the servo's gain before the change, of the speed, or a log-likelihood ratio of a
residual normalised by its sensor's σ — so a rescaled robot is diagnosed the same (docs/fdi.md).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from ...fields import Flag, Options, StrictModel, component, options_of, ranged, ranged_int

Seconds = ranged(0.01, 60.0, unit="s")


class DiagnosisSettings(StrictModel):
    """What every diagnoser kind's settings share: the ``kind`` naming it."""

    kind: str = "residual"


class ResidualDiagnoserSettings(DiagnosisSettings):
    """The built-in structured-residual diagnoser (:class:`~.residual.ResidualDiagnoser`)."""

    kind: Literal["residual"] = "residual"
    """Structured residuals (tyres, servos, speed sensor, gyro) with a windowed GLR each."""
    windows: Annotated[list[Seconds], Field(min_length=1, max_length=16)] = Field(
        default_factory=lambda: [0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0])
    """The GLR's candidate change times: this long (s) before the latest pose fix."""
    glr_period: ranged(0.0, 10.0, unit="s") = 0.05
    """The pose channels' GLRs are evaluated at a new pose fix at most this often (s): their statistics change
    little in between, and each evaluation costs a few hundred µs of Python."""
    reference_window: Seconds = 6.0
    """Length (s) of the window before a candidate change that gives a tyre's and a servo's nominal value."""
    threshold: ranged(0.5, 1.0e3) = 12.5
    """GLR threshold (log-likelihood ratio): 12.5 is a 5σ shift of a Gaussian residual."""
    confirm: ranged(0.0, 10.0, unit="s") = 0.2
    """How long (s) an alarm holds before it is declared."""
    tyre_change: Flag = True
    """Run the fast tyre detector (:mod:`.change`: the estimator's calibrated CUSUM on what the filter steps on,
    the ``tyre_change`` channel), which detects a radius change at the speed and gyro rate and declares nothing;
    its threshold is calibrated for a mean time to a false alarm of ``estimator.decision.arl0`` under the
    benchmark's drawn conditions (docs/fdi.md, "The fast tyre detector"). Off: the tyre alarms are the
    rolling-ratio channels' alone, which read the pose fixes and come about ten times Lorden's bound with a gyro."""
    pose_rate: ranged(0.0, 1.0e4, lo_open=True, unit="Hz") | None = None
    """Use pose fixes at most at this rate (Hz); unset: every fix the loop hands over (the controller's pose,
    at the estimator rate)."""
    pose_floor: ranged(1.0e-6, 0.5) = 1.0e-3
    """The least σ assumed for a pose fix, as a fraction of the nominal radius (m/m; and rad)."""
    tyre_floor: ranged(0.0, 0.5) = 0.004
    """σ of a tyre's rolling ratio between two windows of the healthy robot (fraction of nominal radius)."""
    tyre_min_drop: ranged(0.0, 1.0) = 0.02
    """The least radius drop declared (fraction of the nominal radius)."""
    tyre_min_drop_second: ranged(0.0, 1.0) = 0.06
    """The least drop declared on the other tyre once one is declared punctured (fraction of nominal radius)."""
    tyre_update_window: Seconds = 1.0
    """A declared puncture's size is re-declared from the rolling ratio over this window (s), at most this often."""
    tyre_min_turn: ranged(0.0, 1.0e3, unit="rad") = 1.0
    """The least wheel rotation (rad) in a window for its rolling ratio to count."""
    speed_floor: ranged(0.0, 0.5) = 0.005
    """σ of the speed model (a fraction of the speed): chassis side-slip, the pose's arc approximation."""
    gyro_floor: ranged(0.0, 0.5) = 0.002
    """σ of the yaw-rate model (a fraction of the yaw rate)."""
    launch: ranged(0.0, 60.0, unit="s") = 2.0
    """The servo's reference window starts after this time (s): the launch from rest has another gain."""
    servo_window: Seconds = 2.0
    """Window (s) of the servo's gain regression after a candidate change (its reference window:
    ``reference_window`` before it, after ``launch``)."""
    servo_confirm: ranged(0.0, 10.0, unit="s") = 0.5
    """How long (s) a servo alarm holds before it is declared (a lock's alarm comes first)."""
    servo_ratio: ranged(0.0, 1.0, lo_open=True, hi_open=True) = 0.5
    """Alarm when a servo's identified gain falls below this fraction of its gain before."""
    servo_lag_growth: ranged(1.0, 100.0) = 1.3
    """A servo alarm needs its wheel's mean lag behind the command to have grown by this factor (same sign)."""
    servo_size_exponent: ranged(0.05, 5.0) = 0.4
    """Size of a servo loss = (gain ratio) ** exponent: the closed-loop regression's bias, fitted on dev runs."""
    servo_min_excitation: ranged(0.0, 1.0e3) = 1.0e-5
    """Below this variance ((rad/s)²) of ``ω_cmd − ω`` in the reference window the command does not excite the
    servo's regression: its gain is read from the mean lag instead."""
    servo_afters: Annotated[list[Seconds], Field(min_length=1, max_length=16)] = Field(
        default_factory=lambda: [1.0, 1.5, 2.0, 3.0, 4.0])
    """The load test's candidate change times (:mod:`.servo`): this long (s) before now, each against the
    ``reference_window`` before it."""
    servo_min_loss: ranged(0.0, 1.0, lo_open=True, hi_open=True) = 0.15
    """The load test alarms on a lag step that says at least this fraction of the servo's gain was lost."""
    servo_motion_tol: ranged(0.0, 1.0) = 0.01
    """The load test compares two windows only when each wheel's mean rate moved by at most this fraction of
    the mean wheel rate (the same motion carries the same load)."""
    servo_min_lag: ranged(0.0, 1.0) = 0.002
    """The load test needs the lag before the change to be at least this fraction of the mean wheel rate (a
    wheel that carries no load says nothing of its servo's gain)."""
    servo_other_fraction: ranged(0.0, 10.0) = 0.3
    """The load test needs the other wheel's lag to have changed by at most this fraction of the tested one's
    change (a servo loss moves its own wheel's lag; a load change moves both)."""
    servo_correlation: ranged(0.0, 60.0, unit="s") = 0.5
    """Correlation time (s) of the lag's fluctuation about its mean (the loop's corrections): a window of ``T``
    seconds holds ``T / servo_correlation`` independent samples of it."""
    servo_lag_floor: ranged(0.0, 1.0) = 0.05
    """σ of the healthy lag's mean between two windows at one operating point, a fraction of the lag."""
    unresponsive_below: ranged(0.0, 1.0) = 0.1
    """A servo fault whose size (remaining fraction) is below this is declared ``unresponsive``."""
    unresponsive_lag: ranged(0.0, 10.0) = 0.15
    """A servo whose wheel lags its command by more than this fraction of it is declared ``unresponsive``."""
    lock_window: Seconds = 0.1
    """Window (s) of the lock test."""
    lock_ratio: ranged(0.0, 1.0, lo_open=True, hi_open=True) = 0.1
    """Alarm when a wheel turns at less than this fraction of its command."""
    lock_min_command: ranged(0.0, 1.0) = 0.05
    """The lock test needs a command of at least this fraction of ``robot.omega_max``."""
    lock_confirm: ranged(0.0, 10.0, unit="s") = 0.1
    """How long (s) a lock's alarm holds before it is declared (beyond the ``lock_window`` its statistic already
    averages): each 0.1 s of it lets a locked wheel drag the robot on before the safe stop starts, and costs the stop
    about 0.5 m of the corridor at 7–10 m/s (ftc-v2 dev lock draws 0–205, ``pathfollow``: 11/15 stopped inside it at
    ``confirm``'s 0.2 s, 13/15 at 0.1 s, 14/15 at 0, the 15th off the path before its lock). Not 0: a wheel
    commanded to reverse passes through rest, and its statistic stays above the alarm for about 0.05 s (dev draw 54:
    a false lock at 0)."""
    dropout_min: ranged(0.0, 10.0, unit="s") = 0.05
    """A sensor that delivers nothing for this long (s) is declared dropped out."""
    pose_window: Seconds = 3.0
    """Window (s) of pose fixes the GLR of a displacement of the pose sensor reads."""
    pose_recent: Seconds = 1.5
    """A displacement's candidate onsets: the fixes of the last this long (s) of the window."""
    pose_threshold: ranged(0.5, 1.0e3) = 20.0
    """GLR threshold of a displacement of the pose fixes (log-likelihood ratio; a 6.3σ shift): the dead-reckoned
    track it is tested against has its own error, which the fix's σ leaves out."""
    pose_min_offset: ranged(0.0, 1.0e3) = 3.0
    """A displacement of the pose fixes is tested when it exceeds this many σ of a fix (the larger of the
    configured σ and the median RMS residual of the pose windows so far: the dead-reckoned track's own error)."""
    pose_rms_count: ranged_int(1, 100000) = 200
    """How many of the latest pose windows' RMS residuals give that median."""
    pose_dropout_intervals: ranged(1.0, 1.0e3) = 3.0
    """A pose sensor that delivers no fix for this many of its intervals (and ``dropout_min``) is declared
    dropped out."""
    shape_min: ranged(0.0, 60.0, unit="s") = 2.0
    """Time (s) after a sensor fault's estimated onset before bias and drift are told apart (and between two
    fits of a bias declared)."""
    shape_bin: ranged(0.05, 10.0, unit="s") = 0.5
    """Correlation time (s) of the speed's and yaw rate's model floors in the bias/drift fit; its candidate onsets
    are a fifth of it apart."""
    drift_llr: ranged(0.0, 1.0e3) = 4.0
    """A sensor fault is a drift when the drift's log-likelihood ratio over the bias (nats) exceeds this."""
    fit_window: Seconds = 30.0
    """The span (s) of integrated residual a sensor fault's bias/drift fit reads (the latest, after ``launch``)."""
    fit_samples: ranged_int(10, 10000) = 300
    """At most this many samples of the integrated residual enter the bias/drift fit (every n-th fix, the latest
    kept): the fit's cost grows as their cube."""


class NoDiagnoserSettings(DiagnosisSettings):
    """No diagnoser (``diagnosis.kind = "none"``): no declarations, no alarms."""

    kind: Literal["none"] = "none"


class PluginDiagnoserSettings(DiagnosisSettings):
    """A plug-in diagnoser (a kind a plug-in module registered) with its own ``options``."""

    kind: component("diagnosers")
    """A registered diagnoser (:data:`ftc_mj.registry.diagnosers`)."""
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of the plug-in diagnoser (its registered settings model)."""

    _options = options_of("diagnosers", "kind")


DIAGNOSER_KINDS: dict[str, type[DiagnosisSettings]] = {"residual": ResidualDiagnoserSettings,
                                                       "none": NoDiagnoserSettings}
"""The built-in diagnoser kinds and their settings models."""
