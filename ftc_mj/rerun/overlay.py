"""One Rerun recording that overlays several finished runs (``ftc-mj compare``, ``ftc-mj view A B``).

Each run directory contributes its ``trace.parquet`` (required), ``metrics.json`` (status and the
numbers of the summary table), ``config.toml`` (the reference path) and the events of its
``run.rrd`` (else the fault declarations and reconfiguration changes read off the trace). Every
run is logged under its own entity prefix ``/runs/<token>`` (``token`` = its label made
path-safe), on one ``sim_time`` timeline (integer nanoseconds, like the per-run recordings):

- ``/reference`` (static ``LineStrips3D``, from the first run whose config gives one);
- ``/runs/<token>/path`` (growing ``LineStrips3D``) and ``/runs/<token>/robot`` (``Points3D`` at
  10 Hz): the axle midpoint (m);
- ``/runs/<token>/radius/{right,left}/{truth,estimate,model}``: true, estimated and controller-model
  radii (m); ``/runs/<token>/cross_track_error`` (m, positive = left of the path);
  ``/runs/<token>/wheel_rate/{right,left}`` (rad/s, measured); ``/runs/<token>/imm/mode_prob_k``;
  ``/runs/<token>/reconfig_state`` (0 nominal, 1 hold, 2 handed over, 3 reverted);
- ``/runs/<token>/events`` (``TextLog``, each line prefixed with the run's label) and ``/summary``
  (static markdown table: label, status and key metrics of every run).

The blueprint overlays them: one 3D view of all trajectories, and time-series views whose contents
are the same entity of every run (right radius, left radius, cross-track error, wheel rates, mode
probabilities for IMM runs, reconfiguration state), each series named ``<label>: <quantity>`` in a
legend and drawn in the run's colour; the events of all runs and the summary table below.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ftc_mj.errors import BadInput
from ftc_mj.markdown import table
from ftc_mj.rundir import RECORDING, read_config, read_metrics, read_run_trace, trace_events
from ftc_mj.telemetry import Event

from .blueprint import overview_eye
from .read import read_events
from .stream import growing_path, recording_file, seconds_to_ns, send_events, send_series, sim_time, strips_column

RUN_COLORS = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75),
              (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207))
"""Colour of the k-th run (cycled)."""
MAX_RUNS = 32
"""Most runs one comparison takes (more plots than this are unreadable)."""
POINT_RATE_HZ = 10.0
"""Row rate of the robot marker ``/runs/<token>/robot``."""
IDENTITY_KEYS = ("scenario", "estimator", "imm_models", "controller", "policy", "sensing", "rate_penalty", "seed")
"""Metrics that tell runs apart; default labels use the ones that differ."""
SUMMARY_KEYS = (("outcome", ""), ("status", ""), ("detection_delay", "s"), ("isolated_wheel", ""),
                ("radius_final_error_R", "m"), ("radius_final_error_L", "m"), ("reconfig_handover_delay", "s"),
                ("cross_track_rms", "m"), ("cross_track_max_recovered", "m"))
"""Columns of the ``/summary`` table."""


@dataclass
class RunData:
    """What the comparison needs of one run directory."""

    path: Path
    trace: dict[str, np.ndarray]
    metrics: dict[str, Any] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)
    reference: np.ndarray | None = None
    label: str = ""


def read_run_data(run_dir: Path | str) -> RunData:
    """What the comparison shows of a run directory (:mod:`ftc_mj.rundir`): its trace (required,
    :class:`BadInput` naming ``RUN_DIR`` if missing or unreadable), metrics and reference path if readable,
    and events."""
    d = Path(run_dir)
    trace = read_run_trace(d)
    metrics: dict[str, Any] = {}
    try:
        metrics = read_metrics(d)
    except (OSError, ValueError):
        pass
    return RunData(d, trace, metrics, _events_of(d, trace), _reference_of(d))


def _events_of(d: Path, trace: dict[str, np.ndarray]) -> list[Event]:
    """The ``/events`` of the run's recording, else the decision and reconfiguration changes in the trace."""
    rrd = d / RECORDING
    if rrd.is_file():
        try:
            return read_events(rrd)
        except (RuntimeError, OSError, KeyError, ValueError):
            pass
    return trace_events(trace)


def _reference_of(d: Path) -> np.ndarray | None:
    """The reference path ``(N, 2)`` (m) of the run's resolved config, or None if it cannot be rebuilt."""
    import tomllib

    try:
        from ftc_mj.wiring.control import build_reference

        return np.asarray(build_reference(read_config(d)).path_points(720), dtype=np.float64)
    except (OSError, ValueError, KeyError, tomllib.TOMLDecodeError):
        return None


def default_labels(runs: Sequence[RunData]) -> list[str]:
    """Short ``key=value`` items of the identity metrics that differ between the runs (an IMM's model
    count joined to its estimator), else the folder names; made unique with ``#k``."""
    def ident(r: RunData) -> dict[str, Any]:
        m = {k: r.metrics.get(k) for k in IDENTITY_KEYS}
        if m.get("imm_models") and str(m.get("estimator", "")).startswith("imm"):
            m["estimator"] = f"{m['estimator']}{m['imm_models']}"
        m.pop("imm_models")
        return m

    ids = [ident(r) for r in runs]
    keys = [k for k in ids[0] if len({json.dumps(i.get(k)) for i in ids}) > 1]
    short = {"estimator": "est", "controller": "ctrl", "rate_penalty": "rp"}
    labels = [" ".join(f"{short.get(k, k)}={i.get(k)}" for k in keys) if keys else r.path.name
              for r, i in zip(runs, ids, strict=True)]
    return _unique(labels)


def _unique(labels: list[str]) -> list[str]:
    """``labels`` with repeats numbered ``#2``, ``#3``, …"""
    out: list[str] = []
    for lb in labels:
        cand, k = lb, 2
        while cand in out:
            cand, k = f"{lb} #{k}", k + 1
        out.append(cand)
    return out


def entity_token(label: str) -> str:
    """A label as one entity-path part: runs of characters other than letters, digits, ``_``, ``-``
    become ``_``."""
    return re.sub(r"[^A-Za-z0-9_-]+", "_", label).strip("_") or "run"


def check_labels(labels: Sequence[str], n: int) -> list[str]:
    """``labels`` if there is one per run, each non-empty and one line, tokens distinct; else BadInput."""
    labels = [str(x) for x in labels]
    if len(labels) != n:
        raise BadInput(f"--labels: {len(labels)} labels for {n} runs")
    for lb in labels:
        if not lb.strip() or len(lb) > 80 or any(c in lb for c in "\n\r\0"):
            raise BadInput(f"--labels: {lb[:40]!r}: a label is one line of 1 to 80 characters")
    tokens = [entity_token(lb) for lb in labels]
    if len(set(tokens)) != n:
        raise BadInput("--labels: labels must differ in their letters and digits (they name entity paths)")
    return labels


def load_runs(run_dirs: Sequence[Path | str], labels: Sequence[str] | None = None) -> list[RunData]:
    """Read the runs and give each its label (``labels``, else :func:`default_labels`)."""
    if len(run_dirs) < 1:
        raise BadInput("RUN_DIR: give at least one run directory")
    if len(run_dirs) > MAX_RUNS:
        raise BadInput(f"RUN_DIR: {len(run_dirs)} runs; a comparison takes at most {MAX_RUNS}")
    runs = [read_run_data(d) for d in run_dirs]
    names = check_labels(labels, len(runs)) if labels else distinct_labels(default_labels(runs))
    for r, lb in zip(runs, names, strict=True):
        r.label = lb
    return runs


def distinct_labels(labels: Sequence[str]) -> list[str]:
    """``labels``, numbered ``1: …`` if two of them would give the same entity token."""
    if len({entity_token(lb) for lb in labels}) == len(labels):
        return list(labels)
    return [f"{k + 1}: {lb}" for k, lb in enumerate(labels)]


# ------------------------------------------------------------------------------------------------ writing
def write_comparison(run_dirs: Sequence[Path | str], out: Path | str, labels: Sequence[str] | None = None,
                     *, recording_id: str = "comparison") -> Path:
    """Write the comparison of ``run_dirs`` to ``out`` (``.rrd``, atomically: temporary name, then rename).

    Raises :class:`BadInput` for a missing or unreadable run or bad labels (before anything is written).
    """
    runs = load_runs(run_dirs, labels)
    out = Path(out)
    with recording_file(out, "ftc-mj-compare", recording_id, comparison_blueprint(runs)) as rec:
        _log_runs(rec, runs)
    return out


def _color(k: int) -> list[int]:
    """RGB colour of the k-th run (:data:`RUN_COLORS`, cycled)."""
    return list(RUN_COLORS[k % len(RUN_COLORS)])


def _lighter(c: list[int], f: float = 0.5) -> list[int]:
    """RGB colour ``c`` moved the fraction ``f`` towards white."""
    return [int(round(v + (255 - v) * f)) for v in c]


def _log_runs(rec: rr.RecordingStream, runs: list[RunData]) -> None:
    """The shared entities (axes, ``/reference``, ``/summary``), then every run under its prefix."""
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    ref = next((r.reference for r in runs if r.reference is not None and len(r.reference)), None)
    if ref is not None:
        ref3 = np.column_stack([ref[:, 0], ref[:, 1], np.zeros(len(ref))])
        rec.log("/reference", rr.LineStrips3D([ref3], radii=[0.08], colors=[[200, 200, 200]]), static=True)
    rec.log("/summary", rr.TextDocument(summary_markdown(runs), media_type=rr.MediaType.MARKDOWN), static=True)
    for k, run in enumerate(runs):
        _log_run(rec, run, f"/runs/{entity_token(run.label)}", _color(k))


def _log_run(rec: rr.RecordingStream, run: RunData, prefix: str, color: list[int]) -> None:
    """One run under ``prefix``: path, robot marker, the series of the module docstring, events."""
    tr, label = run.trace, run.label
    t = tr["t"]
    T = seconds_to_ns(t)

    def at(rows: np.ndarray) -> list[rr.TimeColumn]:
        return [sim_time(T[rows])]

    def series(entity: str, column: str, name: str, c: list[int], width: float) -> None:
        if column in tr:
            send_series(rec, f"{prefix}/{entity}", at(np.arange(len(t))), tr[column], c, f"{label}: {name}", width)

    rows, strips = growing_path(tr["x"], tr["y"], t)
    rec.log(f"{prefix}/path", rr.LineStrips3D.from_fields(radii=[0.06], colors=[color]), static=True)
    rec.send_columns(f"{prefix}/path", indexes=at(rows), columns=strips_column(strips))
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.1
    step = max(1, int(round(1.0 / (POINT_RATE_HZ * max(dt, 1e-9)))))
    prow = np.arange(0, len(t), step, dtype=np.int64)
    rec.log(f"{prefix}/robot", rr.Points3D.from_fields(radii=[0.6], colors=[color], labels=[label],
                                                      show_labels=False), static=True)
    rec.send_columns(f"{prefix}/robot", indexes=at(prow),
                     columns=rr.Points3D.columns(positions=np.column_stack(
                         [tr["x"][prow], tr["y"][prow], np.full(len(prow), 0.3)])))
    pale = _lighter(color)
    for side, s in (("right", "R"), ("left", "L")):
        series(f"radius/{side}/truth", f"R_{s}", f"R_{s} truth", pale, 1.0)
        series(f"radius/{side}/estimate", f"R_{s}_hat", f"R_{s} estimate", color, 2.0)
        series(f"radius/{side}/model", f"R_{s}_model", f"R_{s} controller model", color, 1.0)
        series(f"wheel_rate/{side}", f"omega_{s}", f"ω_{s}", color if s == "R" else pale, 1.5)
    series("cross_track_error", "cross_track_error", "cross-track error", color, 1.5)
    series("reconfig_state", "reconfig_state", "reconfiguration state", color, 1.5)
    k = 1
    while f"mode_prob_{k}" in tr:
        shade = _lighter(color, 0.6 * (k - 1) / max(k, 1))
        series(f"imm/mode_prob_{k}", f"mode_prob_{k}", f"mode {k}", shade, 1.5)
        k += 1
    if run.events:
        et = np.array([e.t for e in run.events], dtype=np.float64)
        send_events(rec, f"{prefix}/events", [sim_time(seconds_to_ns(et))], run.events, f"[{label}] ")


def summary_markdown(runs: Sequence[RunData]) -> str:
    """A markdown table: one row per run with its label, folder, status and key metrics (SI units)."""
    head = ["run", "folder", *(f"{k} ({u})" if u else k for k, u in SUMMARY_KEYS)]
    rows = ([r.label, f"`{r.path.name}`", *(_cell(r.metrics.get(k)) for k, _ in SUMMARY_KEYS)] for r in runs)
    lines = ["# Compared runs", "", *table(head, rows)]
    lines += ["", "Radius errors are estimate − truth; cross-track error is positive left of the path."]
    return "\n".join(lines)


def comparison_text(runs: Sequence[RunData]) -> str:
    """The metrics of :data:`SUMMARY_KEYS` side by side for the terminal: one row per metric (with its
    unit), one column per run (headed by its label), aligned in plain text."""
    rows = [["metric", *(r.label for r in runs)], ["folder", *(r.path.name for r in runs)]]
    rows += [[f"{k} ({u})" if u else k, *(_cell(r.metrics.get(k)) for r in runs)] for k, u in SUMMARY_KEYS]
    widths = [max(len(row[c]) for row in rows) for c in range(len(rows[0]))]
    lines = ["  ".join(cell.ljust(w) if c == 0 else cell.rjust(w) for c, (cell, w) in enumerate(zip(row, widths,
                                                                                                  strict=True)))
             for row in rows]
    return "\n".join(line.rstrip() for line in lines)


def _cell(v: Any) -> str:
    """A summary-table cell: 3 significant digits for floats, an em dash for a missing metric."""
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.3g}"
    return str(v)


# ------------------------------------------------------------------------------------------------ blueprint
def comparison_blueprint(runs: Sequence[RunData]) -> rrb.Blueprint:
    """3D trajectories of all runs over the reference; overlaid time series (one entity of every run per
    view, a legend naming each run); events and the summary table."""
    prefixes = [f"/runs/{entity_token(r.label)}" for r in runs]
    legend = rrb.PlotLegend(corner="RightTop")

    def overlay(sub: str, name: str, **kw: Any) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(origin="/", contents=[f"+ {p}/{sub}/**" for p in prefixes], name=name,
                                  plot_legend=legend, **kw)

    views: list[Any] = [
        overlay("radius/right", "Right radius R_R (m): truth (pale), estimate, controller model"),
        overlay("radius/left", "Left radius R_L (m): truth (pale), estimate, controller model"),
        overlay("cross_track_error", "Cross-track error (m, + = left)"),
        overlay("wheel_rate", "Measured wheel rates (rad/s)"),
    ]
    if any("mode_prob_1" in r.trace for r in runs):
        views.append(overlay("imm", "IMM mode probabilities", axis_y=rrb.ScalarAxis(range=(-0.02, 1.02))))
    views.append(overlay("reconfig_state", "Reconfiguration (0 nominal, 1 hold, 2 handed over, 3 reverted)",
                         axis_y=rrb.ScalarAxis(range=(-0.1, 3.1))))
    paths = ["+ /reference"] + [f"+ {p}/path" for p in prefixes] + [f"+ {p}/robot" for p in prefixes]
    left = rrb.Vertical(
        rrb.Spatial3DView(origin="/", contents=paths, name="Trajectories: " + ", ".join(r.label for r in runs),
                          eye_controls=_overview_eye(runs), line_grid=rrb.LineGrid3D(visible=False)),
        rrb.Tabs(rrb.TextLogView(origin="/", contents=[f"+ {p}/events" for p in prefixes], name="Events"),
                 rrb.TextDocumentView(origin="/summary", name="Runs"), active_tab=1),
        row_shares=[3, 2],
    )
    return rrb.Blueprint(
        rrb.Horizontal(left, rrb.Grid(*views, grid_columns=2), column_shares=[2, 3]),
        rrb.TimePanel(state="collapsed", timeline="sim_time", play_state="following"),
        collapse_panels=True,
    )


def _overview_eye(runs: Sequence[RunData]) -> rrb.EyeControls3D:
    """An eye that sees every run's path and reference (:func:`~ftc_mj.rerun.blueprint.overview_eye`)."""
    pts = [np.column_stack([r.trace["x"], r.trace["y"]]) for r in runs]
    return overview_eye(np.vstack(pts + [r.reference[:, :2] for r in runs if r.reference is not None]))


def claim_run_dirs(claims: Sequence[Any], rows: Sequence[dict[str, Any]]) -> list[tuple[str, list[str], list[Path]]]:
    """For each claim of ``ftc-mj paper``: ``(id, labels, run dirs)`` of the matrix runs its evidence
    table or checks name (a label counts where it stands as a whole word), in matrix order."""
    dirs = {str(r["label"]): Path(r["run_dir"]) for r in rows if r.get("label") and r.get("run_dir")}
    out = []
    for c in claims:
        text = " ".join([json.dumps(row, default=str) for row in getattr(c, "table", [])]
                        + [f"{ch.text} {ch.detail}" for ch in getattr(c, "checks", [])])
        labels = [lb for lb in dirs if re.search(rf"(?<![\w-]){re.escape(lb)}(?![\w-])", text)]
        out.append((str(c.id), labels, [dirs[lb] for lb in labels]))
    return out
