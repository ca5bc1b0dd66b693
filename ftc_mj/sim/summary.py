"""The short summary printed after a run: first the physical outcome (on the path, off the path,
tipped over: :mod:`ftc_mj.metrics.outcome`) beside the simulation status, then a table of each metric
with its unit, radii shown as truth and
estimate at the end of the run, errors signed as estimate − truth; then one line per fault onset
(detected, missed, or after the end of the run) and a note when the ``safe`` policy kept the
nominal radii because the split between the radii was not identified."""

from __future__ import annotations

import math
import shlex
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

from ..metrics.outcome import NOT_JUDGED
from ..model.sensors import SensorSettings
from .run import RunOutcome

SUMMARY_ROWS: tuple[tuple[str, str, str], ...] = (
    ("outcome", "outcome (robot)", ""),
    ("status", "simulation status", ""),
    ("radius_final_error_R", "R_R final error (estimate − truth)", "m"),
    ("radius_final_error_L", "R_L final error (estimate − truth)", "m"),
    ("radius_rmse_R", "R_R RMSE", "m"),
    ("radius_rmse_L", "R_L RMSE", "m"),
    ("innovation_in_2sigma", "speed innovations inside ±2σ", "fraction"),
    ("nis_mean", "NIS per measurement dimension (mean; 1 if consistent)", ""),
    ("radius_nees_mean", "radius NEES (mean; 2 if consistent)", ""),
    ("detection_time", "fault declared at", "s"),
    ("detection_delay", "detection delay after the onset", "s"),
    ("time_to_correct_isolation", "correct isolation after the onset", "s"),
    ("isolated_wheel", "isolated wheel", ""),
    ("false_alarm", "false alarm", ""),
    ("false_alarms", "false alarms", "count"),
    ("false_isolations", "false isolations", "count"),
    ("missed_detections", "missed detections", "count"),
    ("cross_track_rms", "cross-track RMS", "m"),
    ("cross_track_max", "cross-track max |e|", "m"),
    ("cross_track_final", "cross-track final (+ = left of the path)", "m"),
    ("cross_track_max_recovered", "cross-track max |e| from 5 s after the fault", "m"),
    ("omega_at_limit_fraction", "time with a wheel command at its limit", "fraction"),
    ("policy", "reconfiguration policy", ""),
    ("reconfig_handovers", "hand-overs / holds / reverts", ""),
    ("reconfig_handover_delay", "hand-over delay after the onset", "s"),
    ("tipped", "tipped over", ""),
    ("solve_time_ms", "solve time median / p95 / max", "ms"),
    ("solver_failures", "solver failures", ""),
    ("exceptions", "exceptions in the loop", "count"),
    ("filter_resets", "filter divergence resets", ""),
    ("plant_out_of_domain_fraction", "time outside the kinematic model's domain", "fraction"),
    ("wall_time_s", "wall time", "s"),
    ("realtime_factor", "real-time factor (sim / wall)", ""),
)
"""(metric key, row label, unit) of the table, in order."""


def _fmt(v: Any) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return " / ".join(_fmt(x) for x in v.values())
    return str(v)


SAMPLED_TIMES = frozenset({"detection_time", "detection_delay", "time_to_correct_isolation",
                           "reconfig_handover_delay"})
"""Metrics that are times of trace samples (s): printed rounded to the sample period, not as the float
sums they are (``0.9500000000000011``)."""


def seconds(v: Any, sample_s: float | None) -> str:
    """A time ``v`` (s) rounded to the sample period ``sample_s`` (s) and shown with its decimals (``0.95``
    for 0.01 s); other values, or without a period, as :func:`_fmt`."""
    if not isinstance(v, float) or not sample_s or not math.isfinite(v):
        return _fmt(v)
    decimals = max(0, math.ceil(-math.log10(sample_s) - 1e-9))
    return f"{round(v / sample_s) * sample_s:.{decimals}f}"


CONSISTENCY_TESTS = {"nis_mean": "nis_test", "radius_nees_mean": "radius_nees_test"}
"""Summary rows whose value is judged against the 95 % χ² bounds stored beside it."""


def consistency_verdict(value: Any, test: Any) -> str:
    """``value`` with its verdict against the two-sided 95 % bounds ``test`` (``lo``, ``hi``): consistent
    inside them; above: the filter is overconfident (its covariance too small for its errors); below:
    conservative (too large). Just the value without bounds."""
    if not isinstance(value, float) or not isinstance(test, dict) or test.get("lo") is None or not math.isfinite(value):
        return _fmt(value)
    lo, hi = float(test["lo"]), float(test["hi"])
    verdict = ("consistent" if lo <= value <= hi else "overconfident" if value > hi else "conservative")
    return f"{_fmt(value)} ({verdict}: 95 % bounds {lo:.3g}–{hi:.3g})"


def onset_lines(metrics: dict[str, Any], sample_s: float | None = None) -> list[str]:
    """One line per fault onset: its detection and isolation (times rounded to ``sample_s``, s), or that it
    lies after the end of the run."""
    lines = []
    for e in metrics.get("onsets") or []:
        head = f"fault onset: {e['wheel']} at t = {e['time']:g} s"
        if e.get("status") == "after end":
            lines.append(f"{head}: after the end of the run ({_fmt(metrics.get('sim_time_s'))} s), "
                         "neither detected nor missed")
        elif "detection_time" in e:
            lines.append(f"{head}: detection delay {seconds(e['detection_delay'], sample_s)} s, correct "
                         f"isolation after {seconds(e['time_to_correct_isolation'], sample_s)} s, "
                         f"{e['false_isolations']} false isolation(s)"
                         + (" — missed" if e["missed_detection"] else ""))
    return lines


def _offset(d: dict[str, Any]) -> str:
    """``, offset (dx, dy) m`` of a declaration that has one (a pose bias or jump), else ``""``."""
    offset = d.get("offset")
    return "" if offset is None else f", offset ({offset[0]:.3g}, {offset[1]:.3g}) m"


def diagnosis_lines(metrics: dict[str, Any]) -> list[str]:
    """One line per declaration of the diagnoser (component, target, mode, size, its offset vector (m) where it
    has one, onset, declaration time) and, for every configured fault, whether it was isolated."""
    lines = [f"diagnosis at t = {d['declared']:.2f} s: {d['component']} {d['target']} {d['mode']}, size "
             f"{_fmt(d['size'])}{_offset(d)} (onset {d['onset']:.2f} s)" for d in metrics.get("diagnoses") or []]
    for e in metrics.get("diagnosis_faults") or []:
        verdict = (f"isolated after {e['isolation_delay']:.2f} s" if e["isolated"]
                   else f"not isolated (first declaration: {e['declared'] or 'none'})")
        lines.append(f"fault {e['fault_class']} on {e['target']} at {e['onset']:g} s: {verdict}")
    return lines


def _final(trace: dict[str, np.ndarray], col: str) -> float | None:
    a = np.asarray(trace.get(col, []), dtype=float)
    a = a[np.isfinite(a)]
    return float(a[-1]) if a.size else None


def radii_rows(m: dict[str, Any], trace: dict[str, np.ndarray]) -> list[tuple[str, str, str]]:
    """Rows ``(label, value, unit)`` with the true and estimated radii at the end of the run."""
    rows = []
    for s in ("R", "L"):
        truth, est = _final(trace, f"R_{s}"), _final(trace, f"R_{s}_hat")
        model = _final(trace, f"R_{s}_model")
        rows.append((f"R_{s} at the end: truth / estimate / controller's model",
                     f"{_fmt(truth)} / {_fmt(est)} / {_fmt(model)}", "m"))
    return rows


WORKING_OPTIONS = ("--set", "sensors.yaw_rate_sigma=0.01", "--set", "controller.rate_penalty=1", "--reconfig", "safe")
"""The options that keep scenario 2's robot on its path (docs/findings.md, finding 5): a yaw-rate gyro
(σ 0.01 rad/s) separates the radii, the actuation-rate term in the cost ends the wheel-rate limit
cycle, and the ``safe`` policy hands the identified radii over. Either alone is not enough: the gyro
with the paper's cost runs the robot far off its path with a wheel in the air (seed 0: 160 m, 23 s of lift-off;
on some CPUs' round-off it tips over near the end of the run)."""


def working_command(scenario: str) -> str:
    """The full command running ``scenario`` with :data:`WORKING_OPTIONS` (quoted for a POSIX shell)."""
    return shlex.join(["ftc-mj", "run", scenario, *WORKING_OPTIONS])


def nominal_hold_note(m: dict[str, Any], trace: dict[str, np.ndarray], max_sigma: float | None,
                      scenario: str | None = None) -> str | None:
    """One sentence when the ``safe`` policy never handed radii over although a fault was declared,
    because the radius split was not identified (its σ above ``max_sigma``, or no isolated wheel), ending
    with the command that identifies it (:func:`working_command` of ``scenario``, default the run's name)."""
    if m.get("policy") != "safe" or m.get("reconfig_handovers") or m.get("detection_time") is None:
        return None
    split = _final(trace, "radius_split_std")
    if m.get("isolated_wheel") not in (None, "unknown") and (split is None or max_sigma is None
                                                             or split <= max_sigma):
        return None
    why = f"σ of the split {split:.2f} m > {max_sigma:g} m" if split is not None and max_sigma else "no wheel isolated"
    return ("The safe policy kept the nominal radii: a fault was declared, but the speed alone cannot tell which "
            f"tyre shrank ({why}). A yaw-rate gyro tells them apart and the actuation-rate term in the cost lets "
            "the policy hand the estimates over (the gyro alone, with the paper's cost, runs the robot far off "
            "its path with a wheel in the air); "
            f"try: {working_command(scenario or str(m.get('scenario') or 'SCENARIO'))}")


def safe_stop_lines(events: list[Any]) -> list[str]:
    """Why the robot stopped: one line per safe-stop event of the accommodation
    (:mod:`ftc_mj.reconfiguration.accommodation`; none when it did not stop)."""
    return [f"SAFE STOP at t = {e.t:.2f} s — {e.text.removeprefix('safe stop: ')}" for e in events
            if e.text.startswith("safe stop: ")]


OUTCOME_STYLE = {"on the path": "bold green", "off the path": "bold red", "tipped over": "bold white on red",
                 "not judged": "bold yellow"}
"""How each outcome is printed (rich styles; plain text without a terminal)."""


def outcome_lines(m: dict[str, Any]) -> list[tuple[str, str]]:
    """The summary's first lines, ``(text, rich style)``: the physical outcome with its rule, whether a
    wheel lifted, and what the simulation status means (exit code 0 for a completed run, whatever the
    robot did)."""
    if "outcome" not in m:
        return []
    out = m["outcome"]
    lines = [(f"OUTCOME: {out.upper()} ({m.get('outcome_rule')})", OUTCOME_STYLE.get(out, "bold"))]
    if out == "not judged":
        lines.append((NOT_JUDGED, "yellow"))
    if m.get("wheel_lifted"):
        lines.append((f"a wheel lifted off the ground for {_fmt(m.get('liftoff_time_post_transient_s'))} s "
                      "(outside the first second after each fault onset)", "yellow"))
    status = m.get("status")
    done = "the simulation completed" if status == "ok" else "the simulation did not complete soundly"
    lines.append((f"simulation status: {status} ({done}; the outcome above is what the robot did)", ""))
    return lines


def pose_source_line(sensors: SensorSettings) -> str:
    """Where the run's controller took its pose from (``sensors.pose_source``), in one line."""
    if sensors.pose_source == "sensor":
        return (f"controller pose: the pose sensor (σ {sensors.position_sigma:g} m, {sensors.fix_heading_sigma:g} rad "
                f"at {sensors.position_rate:g} Hz), through the filter (sensors.pose_source = \"sensor\")")
    noise = f" + N(0, {sensors.pose_sigma:g}²) noise" if sensors.pose_sigma > 0 else ""
    return f"controller pose: the true pose{noise} (sensors.pose_source = \"truth\", the paper's)"


def print_run_summary(outcome: RunOutcome, max_sigma: float | None = None, scenario: str | None = None,
                      sample_s: float | None = None, sensors: SensorSettings | None = None) -> None:
    """Print the key metrics of a run (with units) and where its files are. ``max_sigma`` (m) is the
    safe policy's identification bound, for the note on a nominal hold; ``scenario`` the scenario as the
    user named it (a built-in name or a file), for the command the note suggests; ``sample_s`` the trace's
    sample period (s), to which times are rounded; ``sensors`` the run's sensors, to say where the
    controller's pose came from (:func:`pose_source_line`)."""
    m, trace = outcome.metrics, outcome.result.trace
    table = Table(title=f"run {outcome.run_id}", show_header=True)
    table.add_column("metric")
    table.add_column("value", justify="right")
    table.add_column("unit")
    for key, label, unit in SUMMARY_ROWS:
        if key not in m:
            continue
        value = m[key]
        if key == "status" and value == "ok":
            value = "ok (completed)"
        if key == "reconfig_handovers":
            value = f"{m.get('reconfig_handovers')} / {m.get('reconfig_holds')} / {m.get('reconfig_reverts')}"
        if key in CONSISTENCY_TESTS:
            text = consistency_verdict(value, m.get(CONSISTENCY_TESTS[key]))
        else:
            text = seconds(value, sample_s) if key in SAMPLED_TIMES else _fmt(value)
        table.add_row(label, text, unit)
        if key == "radius_final_error_L":
            for row in radii_rows(m, trace):
                table.add_row(*row)
    console = Console()
    for text, style in outcome_lines(m):
        console.print(text, style=style or None, soft_wrap=True)
    console.print(table)
    for line in onset_lines(m, sample_s) + diagnosis_lines(m):
        console.print(line, soft_wrap=True)
    note = nominal_hold_note(m, trace, max_sigma, scenario)
    if note:
        console.print(note, soft_wrap=True)
    if sensors is not None:
        console.print(pose_source_line(sensors), soft_wrap=True)
    for line in safe_stop_lines(outcome.result.events):
        console.print(line, style="bold yellow", soft_wrap=True)
    if outcome.run_dir is not None:
        console.print(f"written: {outcome.run_dir}")
