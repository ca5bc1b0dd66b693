"""The report's figures (matplotlib, Agg backend), one PNG per figure, from the runs' ``trace.parquet``.

They stand in for the paper's missing figures: speed innovations with ±2σ, radius estimates vs truth
with ±2σ, wheel rates with commands and limits, trajectories against the reference circle, the
scenario 4 filter comparison, IMM mode probabilities, and the two IMM variants side by side.
Every figure is skipped (not an error) when none of its runs is available.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from ..io import atomic_path  # noqa: E402
from .claims.paper import EST_NAMES, FILTERS, lbl  # noqa: E402
from .claims.policy import SENSING, plabel  # noqa: E402
from .derived import onsets_of_config  # noqa: E402

DPI = 90
FB_TITLE = {False: "feedback off", True: "feedback on"}
COLORS = {"ekf": "tab:red", "ukf": "tab:blue", "imm-ekf": "tab:orange", "imm-ukf": "tab:green",
          "imm-ekf5": "tab:brown", "imm-ukf5": "tab:purple", "lmpc": "tab:gray"}


def read_run_dir(run_dir: Path | None) -> tuple[dict[str, np.ndarray] | None, dict[str, Any]]:
    """The trace (numpy columns, :func:`ftc_mj.rundir.read_trace`; None without one) and the resolved
    config (as a dict; empty when absent or unreadable) of a run directory."""
    from ..rundir import CONFIG, TRACE, read_trace

    if run_dir is None:
        return None, {}
    trace = read_trace(run_dir / TRACE) if (run_dir / TRACE).is_file() else None
    try:
        cfg = tomllib.loads((run_dir / CONFIG).read_text()) if (run_dir / CONFIG).is_file() else {}
    except (OSError, tomllib.TOMLDecodeError):
        cfg = {}
    return trace, cfg


class RunStore:
    """Traces and resolved configs of the runs, loaded lazily by label (:func:`read_run_dir`)."""

    def __init__(self, run_dirs: Mapping[str, Path | None]):
        self.run_dirs = {k: Path(v) for k, v in run_dirs.items() if v is not None}
        self._runs: dict[str, tuple[dict[str, np.ndarray] | None, dict[str, Any]]] = {}

    def __contains__(self, label: str) -> bool:
        return self.trace(label) is not None

    def _load(self, label: str) -> tuple[dict[str, np.ndarray] | None, dict[str, Any]]:
        if label not in self._runs:
            self._runs[label] = read_run_dir(self.run_dirs.get(label))
        return self._runs[label]

    def trace(self, label: str) -> dict[str, np.ndarray] | None:
        return self._load(label)[0]

    def config(self, label: str) -> dict[str, Any]:
        return self._load(label)[1]

    def onsets(self, label: str) -> list[float]:
        o = onsets_of_config(self.config(label))
        return sorted({v for v in o.values() if v is not None})

    def omega_max(self, label: str) -> float:
        return float((self.config(label).get("robot") or {}).get("omega_max", math.radians(1000.0)))

    def circle(self, label: str) -> tuple[float, float, float]:
        """(cx, cy, radius) of the reference circle of a run."""
        cfg = self.config(label)
        ref = cfg.get("reference") or {}
        R = float(ref.get("radius", 50.0))
        x0, y0, psi0 = (cfg.get("plant") or {}).get("initial_pose", (0.0, 0.0, 0.0))
        s = -1.0 if ref.get("direction", "ccw") == "cw" else 1.0
        return x0 - s * R * math.sin(psi0), y0 + s * R * math.cos(psi0), R


def _save(fig: Figure, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=DPI)
    plt.close(fig)
    return path


def _finish(fig: Figure, suptitle: str, path: Path, bottom: Sequence[Any] = ()) -> Path:
    """Label the time axis of the ``bottom`` row's axes, title the figure, lay it out and save it
    to ``path``."""
    for ax in bottom:
        ax.set_xlabel("t [s]")
    fig.suptitle(suptitle)
    fig.tight_layout()
    return _save(fig, path)


def _vlines(ax: Any, onsets: Sequence[float]) -> None:
    for o in onsets:
        ax.axvline(o, color="k", ls=":", lw=0.8)


def _row_spec(sc: int, with5: bool) -> list[tuple[str, Callable[[bool], str]]]:
    rows: list[tuple[str, Callable[[bool], str]]] = [
        (EST_NAMES[e], (lambda fb, e=e: lbl(sc, e, fb))) for e in FILTERS]
    if with5:
        rows += [(f"{EST_NAMES[e]}-5", (lambda fb, e=e: lbl(sc, e, fb, models=5))) for e in ("imm-ekf", "imm-ukf")]
    return rows


def _filter_grid(store: RunStore, sc: int, suptitle: str, out: Path, ylabel: str, legend: bool,
                 draw: Callable[[Any, Mapping[str, np.ndarray], str], None]) -> Path | None:
    """A figure with one row per filter of scenario ``sc`` and the columns feedback off/on: ``draw(ax,
    trace, label)`` fills each panel that has a run, titled ``<filter>, feedback on|off`` (the first
    with the legend when ``legend``)."""
    spec = [(n, f) for n, f in _row_spec(sc, sc == 4) if any(f(fb) in store for fb in (False, True))]
    if not spec:
        return None
    fig, axes = plt.subplots(len(spec), 2, figsize=(11, 1.9 * len(spec) + 0.8), sharex=True, squeeze=False)
    for i, (name, f) in enumerate(spec):
        for j, fb in enumerate((False, True)):
            ax = axes[i][j]
            lb = f(fb)
            tr = store.trace(lb)
            if tr is None:
                ax.text(0.5, 0.5, "no run", ha="center", transform=ax.transAxes)
                continue
            draw(ax, tr, lb)
            ax.set_title(f"{name}, {FB_TITLE[fb]}", fontsize=9)
            ax.set_ylabel(ylabel, fontsize=8)
            if legend and i == 0 and j == 0:
                ax.legend(fontsize=7, loc="lower left", ncol=3)
    return _finish(fig, suptitle, out, axes[-1])


def fig_innovations(store: RunStore, sc: int, out: Path) -> Path | None:
    """Speed innovation (blue) with ±2σ (red) per filter (rows) and feedback off/on (columns)."""

    def draw(ax: Any, tr: Mapping[str, np.ndarray], lb: str) -> None:
        t, inn, sd = tr["t"], tr["innovation"], tr["innovation_std"]
        ax.plot(t, inn, color="tab:blue", lw=0.5)
        ax.plot(t, 2 * sd, color="tab:red", lw=0.9)
        ax.plot(t, -2 * sd, color="tab:red", lw=0.9)
        _vlines(ax, store.onsets(lb))
        lim = np.nanpercentile(np.abs(inn), 99.5) if np.isfinite(inn).any() else 1.0
        lim = max(lim, np.nanmax(2 * sd[np.isfinite(sd)]) if np.isfinite(sd).any() else 1.0)
        ax.set_ylim(-1.2 * lim, 1.2 * lim)

    return _filter_grid(store, sc, f"Scenario {sc}: speed innovations (blue) and ±2σ bounds (red)",
                        out / f"innovations_s{sc}.png", "m/s", False, draw)


def _radius_axes(ax: Any, tr: Mapping[str, np.ndarray], wheel: str, color: str, label: str | None = None,
                 band: bool = True) -> None:
    t = tr["t"]
    est, sd = tr[f"R_{wheel}_hat"], tr[f"R_{wheel}_std"]
    ax.plot(t, est, color=color, lw=1.0, label=label)
    if band:
        ax.fill_between(t, est - 2 * sd, est + 2 * sd, color=color, alpha=0.15, lw=0)


def fig_radius(store: RunStore, sc: int, out: Path) -> Path | None:
    """Radius estimates (R right, L left) with ±2σ bands against the truth (black dashed)."""

    def draw(ax: Any, tr: Mapping[str, np.ndarray], lb: str) -> None:
        _radius_axes(ax, tr, "R", "tab:blue", "R_R est.")
        _radius_axes(ax, tr, "L", "tab:orange", "R_L est.")
        ax.plot(tr["t"], tr["R_R"], "k--", lw=0.8, label="truth")
        ax.plot(tr["t"], tr["R_L"], "k:", lw=0.8)
        _vlines(ax, store.onsets(lb))
        ax.set_ylim(-0.2, 4.0)

    return _filter_grid(store, sc, f"Scenario {sc}: wheel-radius estimates ±2σ (R_R blue, R_L orange) vs truth "
                        f"(black)", out / f"radius_s{sc}.png", "m", True, draw)


def fig_wheel_rates(store: RunStore, sc: int, out: Path) -> Path | None:
    """Wheel rates (measured) with the commands and the limits, NMPC vs LMPC (UKF, feedback on)."""
    runs = [("NMPC", lbl(sc, "ukf", True)), ("LMPC", lbl(sc, "ukf", True, "lmpc"))]
    if not any(lb in store for _, lb in runs):
        return None
    fig, axes = plt.subplots(2, 2, figsize=(11, 5.5), sharex=True, squeeze=False)
    for j, (ctrl, lb) in enumerate(runs):
        tr = store.trace(lb)
        for i, (wheel, name) in enumerate((("R", "right"), ("L", "left"))):
            ax = axes[i][j]
            if tr is None:
                ax.text(0.5, 0.5, "no run", ha="center", transform=ax.transAxes)
                continue
            wmax = store.omega_max(lb)
            ax.plot(tr["t"], tr[f"omega_{wheel}"], color="tab:blue", lw=0.8, label="wheel rate")
            ax.step(tr["t"], tr[f"omega_{wheel}_cmd"], where="post", color="tab:orange", lw=0.8, label="command")
            ax.axhline(wmax, color="tab:red", ls="--", lw=0.8, label="limits")
            ax.axhline(-wmax, color="tab:red", ls="--", lw=0.8)
            _vlines(ax, store.onsets(lb))
            ax.set_ylim(-1.15 * wmax, 1.15 * wmax)
            ax.set_title(f"{ctrl}: {name} wheel", fontsize=9)
            ax.set_ylabel("rad/s", fontsize=8)
            if i == 0 and j == 0:
                ax.legend(fontsize=7, loc="lower left", ncol=3)
    return _finish(fig, f"Scenario {sc}, UKF with feedback: wheel rates, commands and limits — NMPC vs LMPC",
                   out / f"wheel_rates_s{sc}_nmpc_vs_lmpc.png", axes[-1])


def _circle(ax: Any, store: RunStore, lb: str) -> None:
    cx, cy, R = store.circle(lb)
    a = np.linspace(0, 2 * np.pi, 361)
    ax.plot(cx + R * np.cos(a), cy + R * np.sin(a), "k--", lw=0.9, label="reference")


def _path(ax: Any, tr: Mapping[str, np.ndarray], color: str, label: str, onsets: Sequence[float]) -> None:
    ax.plot(tr["x"], tr["y"], color=color, lw=1.0, label=label)
    for o in onsets:
        k = int(np.searchsorted(tr["t"], o))
        if k < tr["t"].size:
            ax.plot(tr["x"][k], tr["y"][k], "x", color=color, ms=6)


def fig_trajectories(store: RunStore, sc: int, out: Path) -> Path | None:
    """Trajectories of all filters against the reference circle, feedback off/on (× = fault onset)."""
    spec = [(n, f) for n, f in _row_spec(sc, sc == 4) if any(f(fb) in store for fb in (False, True))]
    if not spec:
        return None
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.6), squeeze=False)
    keys = list(FILTERS) + ["imm-ekf5", "imm-ukf5"]
    for j, fb in enumerate((False, True)):
        ax = axes[0][j]
        drew_ref = False
        for (name, f), key in zip(spec, keys, strict=False):
            lb = f(fb)
            tr = store.trace(lb)
            if tr is None:
                continue
            if not drew_ref:
                _circle(ax, store, lb)
                drew_ref = True
            _path(ax, tr, COLORS[key], name, store.onsets(lb))
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(FB_TITLE[fb], fontsize=10)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="best")
    return _finish(fig, f"Scenario {sc}: trajectories vs the reference circle (× = fault onset)",
                   out / f"trajectory_s{sc}.png")


def fig_trajectories_mpc(store: RunStore, out: Path) -> Path | None:
    """NMPC vs LMPC trajectories (UKF, feedback on), scenarios 2 and 4."""
    if not any(lbl(sc, "ukf", True, "lmpc") in store for sc in (2, 4)):
        return None
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.6), squeeze=False)
    for j, sc in enumerate((2, 4)):
        ax = axes[0][j]
        first = True
        for ctrl, color in (("nmpc", "tab:blue"), ("lmpc", "tab:gray")):
            lb = lbl(sc, "ukf", True, ctrl)
            tr = store.trace(lb)
            if tr is None:
                continue
            if first:
                _circle(ax, store, lb)
                first = False
            _path(ax, tr, color, ctrl.upper(), store.onsets(lb))
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"scenario {sc}", fontsize=10)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    return _finish(fig, "UKF with feedback: NMPC vs LMPC trajectories (× = fault onset)",
                   out / "trajectory_nmpc_vs_lmpc.png")


def fig_radius_comparison(store: RunStore, out: Path) -> Path | None:
    """Scenario 4 left-radius estimates: UKF and 5-model IMMs (top), EKF and 4-model IMMs (bottom)."""
    groups = [("UKF and 5-model IMMs", [("UKF", "ukf", 4), ("IMM-EKF-5", "imm-ekf", 5), ("IMM-UKF-5", "imm-ukf", 5)]),
              ("EKF and 4-model IMMs (omitted in the paper)", [("EKF", "ekf", 4), ("IMM-EKF-4", "imm-ekf", 4),
                                                              ("IMM-UKF-4", "imm-ukf", 4)])]
    if not any(lbl(4, e, fb, models=m) in store for _, g in groups for _, e, m in g for fb in (False, True)):
        return None
    fig, axes = plt.subplots(2, 2, figsize=(11, 6.5), sharex=True, squeeze=False)
    for i, (gname, members) in enumerate(groups):
        for j, fb in enumerate((False, True)):
            ax = axes[i][j]
            truth_drawn = False
            for name, est, models in members:
                lb = lbl(4, est, fb, models=models)
                tr = store.trace(lb)
                if tr is None:
                    continue
                key = est + ("5" if models == 5 else "")
                _radius_axes(ax, tr, "L", COLORS[key], name)
                if not truth_drawn:
                    ax.plot(tr["t"], tr["R_L"], "k--", lw=1.0, label="truth")
                    truth_drawn = True
            ax.set_ylim(-0.5, 3.5)
            ax.set_title(f"{gname}, {FB_TITLE[fb]}", fontsize=9)
            ax.set_ylabel("R_L [m]")
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7, loc="upper right")
    return _finish(fig, "Scenario 4 (linear left puncture from 10 s): left-radius estimates ±2σ",
                   out / "radius_comparison_s4.png", axes[-1])


def fig_mode_probs(store: RunStore, fb: bool, out: Path) -> Path | None:
    """IMM mode probabilities per scenario (rows) and IMM kind (columns)."""
    rows = [(f"scenario {sc}", sc, 4) for sc in (1, 2, 3, 4)] + [("scenario 4, 5 models", 4, 5)]
    rows = [r for r in rows if any(lbl(r[1], e, fb, models=r[2]) in store for e in ("imm-ekf", "imm-ukf"))]
    if not rows:
        return None
    fig, axes = plt.subplots(len(rows), 2, figsize=(11, 1.9 * len(rows) + 0.8), sharex=True, squeeze=False)
    names = ["1 no fault", "2 right 50 %", "3 left 50 %", "4 both 50 %", "5 left ramp"]
    for i, (title, sc, models) in enumerate(rows):
        for j, est in enumerate(("imm-ekf", "imm-ukf")):
            ax = axes[i][j]
            lb = lbl(sc, est, fb, models=models)
            tr = store.trace(lb)
            if tr is None:
                ax.text(0.5, 0.5, "no run", ha="center", transform=ax.transAxes)
                continue
            for k in range(models):
                col = f"mode_prob_{k + 1}"
                if col in tr:
                    ax.plot(tr["t"], tr[col], lw=1.0, label=names[k])
            _vlines(ax, store.onsets(lb))
            ax.set_ylim(-0.05, 1.05)
            ax.set_title(f"{title}: {EST_NAMES[est]}", fontsize=9)
            if i == 0 and j == 0 or (models == 5 and j == 0):
                ax.legend(fontsize=7, loc="center right", ncol=1)
    return _finish(fig, f"IMM mode probabilities, {FB_TITLE[fb]}",
                   out / f"mode_probs_{'fb' if fb else 'nofb'}.png", axes[-1])


def fig_imm_variants(store: RunStore, out: Path) -> Path | None:
    """Scenario 2 IMM-UKF: the default `hypothesis` variant vs the literal `paper` variant."""
    cols = [(v, fb) for v in ("hypothesis", "paper") for fb in (False, True)
            if lbl(2, "imm-ukf", fb, variant=v) in store]
    if not any(v == "paper" for v, _ in cols):
        return None
    fig, axes = plt.subplots(2, len(cols), figsize=(3.2 * len(cols) + 1, 5.6), sharex=True, squeeze=False)
    names = ["1 no fault", "2 right 50 %", "3 left 50 %", "4 both 50 %"]
    for j, (variant, fb) in enumerate(cols):
        lb = lbl(2, "imm-ukf", fb, variant=variant)
        tr = store.trace(lb)
        assert tr is not None
        ax = axes[0][j]
        for k in range(4):
            if f"mode_prob_{k + 1}" in tr:
                ax.plot(tr["t"], tr[f"mode_prob_{k + 1}"], lw=1.0, label=names[k])
        ax.set_ylim(-0.05, 1.05)
        ax.set_title(f"{variant}, {FB_TITLE[fb]}", fontsize=9)
        _vlines(ax, store.onsets(lb))
        if j == 0:
            ax.set_ylabel("mode probability")
            ax.legend(fontsize=7)
        ax = axes[1][j]
        _radius_axes(ax, tr, "R", "tab:blue", "R_R est.")
        _radius_axes(ax, tr, "L", "tab:orange", "R_L est.")
        ax.plot(tr["t"], tr["R_R"], "k--", lw=0.8)
        ax.plot(tr["t"], tr["R_L"], "k:", lw=0.8)
        ax.set_ylim(-0.2, 4.0)
        ax.set_xlabel("t [s]")
        if j == 0:
            ax.set_ylabel("radius [m]")
            ax.legend(fontsize=7)
    return _finish(fig, "Scenario 2, IMM-UKF (4 models): hypothesis variant (default) vs the paper's literal IMM",
                   out / "imm_variants_s2.png")


POLICY_COLORS = {"none": "tab:gray", "direct": "tab:red", "safe": "tab:blue"}


def fig_policies(store: RunStore, out: Path) -> Path | None:
    """Reconfiguration-policy axis: |cross-track error| over time for none / direct / safe, scenarios 2–4
    (rows) × speed only / speed + yaw rate (columns); dots mark the safe policy's hand-overs."""
    scs = [sc for sc in (2, 3, 4) if any(plabel(f"scenario{sc}", p, s) in store for p in POLICY_COLORS
                                          for s, _ in SENSING)]
    if not scs:
        return None
    fig, axes = plt.subplots(len(scs), 2, figsize=(11, 2.8 * len(scs)), squeeze=False, sharex=True)
    for i, sc in enumerate(scs):
        for j, (sens, sname) in enumerate(SENSING):
            ax = axes[i][j]
            for pol, color in POLICY_COLORS.items():
                lb = plabel(f"scenario{sc}", pol, sens)
                tr = store.trace(lb)
                if tr is None:
                    continue
                ax.semilogy(tr["t"], np.maximum(np.abs(tr["cross_track_error"]), 1e-3), color=color, lw=1.0,
                            label=pol)
                if pol == "safe" and "reconfig_state" in tr:
                    st = np.nan_to_num(tr["reconfig_state"])
                    k = np.flatnonzero((st[1:] == 2) & (st[:-1] != 2)) + 1
                    ax.plot(tr["t"][k], np.maximum(np.abs(tr["cross_track_error"][k]), 1e-3), "o", color=color,
                            ms=3, label="safe hand-over" if len(k) else None)
                _vlines(ax, store.onsets(lb))
            ax.set_title(f"scenario {sc}, {sname}", fontsize=9)
            ax.set_ylabel("|cross-track| [m]")
            if i == len(scs) - 1:
                ax.set_xlabel("t [s]")
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7, loc="best")
    return _finish(fig, "Reconfiguration policies (UKF, NMPC with the actuation-rate term): cross-track error",
                   out / "policies.png")


FIGURES: tuple[tuple[str, tuple[Any, ...]], ...] = (
    *((name, (sc,)) for sc in (1, 2, 3, 4) for name in ("fig_innovations", "fig_radius", "fig_trajectories")),
    *(("fig_wheel_rates", (sc,)) for sc in (2, 4)),
    ("fig_trajectories_mpc", ()),
    ("fig_radius_comparison", ()),
    ("fig_mode_probs", (False,)),
    ("fig_mode_probs", (True,)),
    ("fig_imm_variants", ()),
    ("fig_policies", ()),
)
"""Every figure as (function name in this module, arguments before ``out``), in report order."""

_SLOW_FIRST = ("fig_radius", "fig_innovations", "fig_mode_probs")
"""The figures with many panels (rendered first when figures are spread over processes)."""


def _render(store: RunStore, name: str, args: tuple[Any, ...], out: Path) -> Path | None:
    return globals()[name](store, *args, out)


def _render_job(run_dirs: Mapping[str, Path | None], name: str, args: tuple[Any, ...], out: Path) -> Path | None:
    """One figure in a worker process (its own lazily loaded traces)."""
    return _render(RunStore(run_dirs), name, args, out)


def make_figures(run_dirs: Mapping[str, Path | None], out: Path, jobs: int = 1) -> list[Path]:
    """Render every figure whose runs are available into ``out``; return the written paths (report order).

    With ``jobs > 1`` the figures are rendered by that many worker processes (each figure is independent and
    written atomically; the PNGs are the same as the sequential ones).
    """
    if jobs <= 1:
        store = RunStore(run_dirs)
        made = [_render(store, name, args, out) for name, args in FIGURES]
        return [p for p in made if p is not None]
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    try:
        ctx = mp.get_context("forkserver")
    except ValueError:  # pragma: no cover - platforms without forkserver
        ctx = mp.get_context("spawn")
    dirs = {k: (Path(v) if v is not None else None) for k, v in run_dirs.items()}
    order = sorted(range(len(FIGURES)), key=lambda i: FIGURES[i][0] not in _SLOW_FIRST)
    with ProcessPoolExecutor(max_workers=min(jobs, len(FIGURES)), mp_context=ctx) as pool:
        futs = {i: pool.submit(_render_job, dirs, FIGURES[i][0], FIGURES[i][1], out) for i in order}
        made = [futs[i].result() for i in range(len(FIGURES))]
    return [p for p in made if p is not None]
