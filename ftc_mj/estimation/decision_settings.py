"""The fault decision's settings (the ``[estimator.decision]`` section), declared once for every rule
(:mod:`.decision`, :mod:`.rule_statistics`) and every estimator kind (:mod:`.settings`)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ..fields import Flag, Fraction, NonNegFloat, Options, PosFloat, StrictModel, component, options_of


class DecisionSettings(StrictModel):
    """The fault-decision rule on top of the estimator and its settings (the ``[estimator.decision]`` section)."""

    rule: component("decision_rules") = "auto"
    """A registered decision rule (:data:`ftc_mj.registry.decision_rules`). Built-in: ``sigma``: a radius
    departs from nominal by ``k_sigma`` standard deviations and by at least ``min_drop`` for ``dwell``
    seconds; ``mode``: the probability of a fault class of an IMM bank's declared hypotheses above
    ``mode_threshold`` for ``dwell`` seconds; ``auto``: ``mode`` for an estimator that declares
    hypotheses (IMMs), else ``sigma``; ``cusum`` / ``glr``: a CUSUM / Willsky–Jones GLR on the whitened
    innovations crosses the threshold set for a mean time between false alarms ``arl0``
    (:mod:`ftc_mj.estimation.change`)."""
    k_sigma: PosFloat = 3.0
    """Sigma rule: departure of a radius from nominal, in its standard deviations, that counts as a fault."""
    min_drop: NonNegFloat = 0.1
    """Minimum radius departure (m) for the sigma rule (guards against tiny-σ false alarms)."""
    dwell: NonNegFloat = 0.5
    """Time (s) the condition must hold before a fault is declared. It trades false alarms and false
    isolations against the delay of a reconfiguration. Chosen by the rule of the built-in study
    ``tune_dwell`` on the development seeds 0–9: the smallest dwell without a false alarm or false
    isolation in any run (the measurements: docs/studies.md)."""
    mode_threshold: Fraction = 0.9
    """Mode rule: probability of a fault class above which it counts as declared."""
    max_split_sigma: PosFloat = 0.15
    """Sigma rule: a wheel is isolated only when the σ (m) of the radius split along the direction
    the speed cannot observe is at most this; otherwise the declared wheel is ``'unknown'``."""
    arl0: PosFloat = 100.0
    """``cusum``/``glr`` rules: target mean time (s) between false alarms; sets their thresholds."""
    cusum_shift: PosFloat = 1.0
    """CUSUM design shift (σ of the whitened innovation) the test is tuned to detect fastest."""
    glr_window: PosFloat = 0.5
    """GLR: onsets considered (s back from the current step); the filter absorbs a radius jump well within
    it, after which a jump leaves no trace in the innovations."""
    change_holdoff: NonNegFloat = 2.0
    """``cusum``/``glr``: time (s) after a declared change during which further threshold crossings only
    re-anchor the residual generator and add no wheel: on the physical plant a puncture is followed by a
    transient the constant-radius model cannot explain (the tyre settling, wheel slip, the controller's
    reaction), which the detectors would otherwise read as further changes."""
    null_model: Literal["physical", "ideal"] = "physical"
    """``cusum``/``glr`` (and their logged statistics): what the change detectors take a healthy robot to be —
    a method's choice about the robot it is built for, never read from the simulator that runs.
    ``physical``: the physical robot's null model (:mod:`ftc_mj.estimation.null_model`): the residual
    generator one filter step behind the estimator (the body follows the wheels within a step), and tyre slip
    near the grip limit as effective-radius noise, σ a fraction of the nominal radius that grows with the
    demanded lateral acceleration (in g), a speed or yaw-rate channel unused where that noise exceeds twice
    its sensor's σ; with a threshold offset per detector and sensor set measured on the MuJoCo robot
    (:func:`~ftc_mj.estimation.calibration.physical_offset`) the thresholds keep their design ARL0 there
    (docs/fdi.md, "Calibration on the physical plant"). ``ideal``: the no-slip kinematic model alone, exact
    for a robot that is that model (the kinematic plant), where the physical null model only costs a step of
    delay and sensitivity at high lateral acceleration."""
    isolation_llr: PosFloat = 4.6
    """``cusum``/``glr``: a wheel is isolated when its hypothesis leads the runner-up by this log-likelihood
    ratio (nats; 4.6 ≈ 99:1 odds); otherwise the declared wheel is ``'unknown'``."""
    statistics: Flag = False
    """Compute every rule's decision statistic each step and log it in the trace (``*_stat`` columns), so
    that thresholds can be swept afterwards without re-running (``ftc-mj fdi-curves``); it costs CPU time
    at every filter step (measured in docs/fdi.md). The ``cusum`` and ``glr`` rules compute their own
    statistic regardless."""
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in rule (its registered settings model); built-in rules take none."""

    _options = options_of("decision_rules", "rule")
