"""The short summary table printed after a run."""

from __future__ import annotations

from typing import Any

from rich.console import Console
from rich.table import Table

from .run import RunOutcome


def _fmt(v: Any) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return " / ".join(f"{k} {_fmt(x)}" for k, x in v.items())
    return str(v)


SUMMARY_KEYS = (
    "status", "radius_final_error_R", "radius_final_error_L", "radius_rmse_R", "radius_rmse_L",
    "innovation_in_2sigma", "nis_mean", "radius_nees_mean", "detection_time", "detection_delay",
    "time_to_correct_isolation", "isolated_wheel", "false_alarms", "false_isolations", "missed_detections",
    "cross_track_rms", "cross_track_max", "cross_track_final", "cross_track_max_recovered", "omega_at_limit_fraction",
    "policy", "reconfig_handovers", "reconfig_holds", "reconfig_reverts", "reconfig_handover_delay", "tipped",
    "solve_time_ms", "solver_failures", "exceptions", "filter_resets", "plant_out_of_domain_fraction",
    "wall_time_s", "realtime_factor",
)


def onset_lines(metrics: dict[str, Any]) -> list[str]:
    """One line per fault onset: its detection and isolation, or that it lies after the end of the run."""
    lines = []
    for e in metrics.get("onsets") or []:
        head = f"fault onset: {e['wheel']} at t = {e['time']:g} s"
        if e.get("status") == "after end":
            lines.append(f"{head}: after the end of the run ({_fmt(metrics.get('sim_time_s'))} s), "
                         "neither detected nor missed")
        elif "detection_time" in e:
            lines.append(f"{head}: detection delay {_fmt(e['detection_delay'])} s, correct isolation after "
                         f"{_fmt(e['time_to_correct_isolation'])} s, {e['false_isolations']} false isolation(s)"
                         + (" — missed" if e["missed_detection"] else ""))
    return lines


def print_run_summary(outcome: RunOutcome) -> None:
    """Print the key metrics of a run, each fault onset's outcome and where the files are."""
    m = outcome.metrics
    table = Table(title=f"run {outcome.run_id}", show_header=True)
    table.add_column("metric")
    table.add_column("value", justify="right")
    for k in SUMMARY_KEYS:
        if k in m:
            table.add_row(k, _fmt(m[k]))
    console = Console()
    console.print(table)
    for line in onset_lines(m):
        console.print(line, soft_wrap=True)
    if outcome.run_dir is not None:
        console.print(f"written: {outcome.run_dir}")
