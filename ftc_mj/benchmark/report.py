"""The outputs of ``ftc-mj bench``: ``draws.parquet`` (one row per draw, every factor), ``scores.parquet``
(one row per method × draw, with the method's settings digest and the package version),
the report — ``leaderboard.md`` for the test split (the only split a leaderboard shows), ``dev-report.md``
for the development split, ``healthy-check.md`` for the healthy-path check — the figures (success rate per
fault class per method; paired differences) and Rerun comparisons of chosen draws (``compare/``)."""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import polars as pl

from ..io import atomic_path
from ..markdown import row, table
from ..metrics.outcome import OFF_PATH_M
from ..study.stats import Estimate
from ..study.store import StudyStore
from .stats import CONTINUOUS, RATES, Paired, aggregate, paired

QUESTIONS = (("paper", "safe", "does the paper's loop generalise (against the safe loop)"),
             ("safe", "feedback-off", "does the safe policy beat feedback off"),
             ("pathfollow", "safe", "does the path-following NMPC beat the time-parametrised one"),
             ("pathfollow", "paper", "does the path-following NMPC beat the paper's loop"),
             ("hybrid", "safe", "does the hybrid beat active FTC"),
             ("hybrid", "passive", "does the hybrid beat passive FTC"))
"""The project's questions as (method a, method b, question), asked when both methods were run."""


def report_name(split: str, healthy: bool) -> str:
    """``leaderboard.md`` (test), ``dev-report.md`` (dev) or ``healthy-check.md`` (draws without faults)."""
    return "healthy-check.md" if healthy else "leaderboard.md" if split == "test" else "dev-report.md"


def write_outputs(bp: Any, results: pl.DataFrame, out: Path, *, compare: int = 1, echo: Any = None) -> Path:
    """Every output of the module docstring; returns the report's path."""
    draws = pl.DataFrame([d.factors() for d in bp.draws], infer_schema_length=None)
    with atomic_path(out / "draws.parquet") as tmp:
        draws.write_parquet(tmp)
    scores = score_table(bp, results)
    with atomic_path(out / "scores.parquet") as tmp:
        scores.write_parquet(tmp)
    rows = scores.to_dicts()
    figures = draw_figures(rows, [m.name for m in bp.methods], out / "figures", bp.classes)
    compared = write_comparisons(bp, rows, out / "compare", compare) if compare > 0 else []
    text = render(bp, rows, figures, compared, computed_line(out))
    path = out / report_name(bp.split, bp.healthy)
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    if echo is not None and compared:
        echo(f"Rerun comparison of draw(s) {', '.join(p.stem for p in compared)} in {out / 'compare'}")
    return path


def score_table(bp: Any, results: pl.DataFrame) -> pl.DataFrame:
    """The rows of the plan's runs without their time series, with split, version, method digest and package
    version."""
    keep = [c for c in results.columns if not c.startswith("ts_")]
    digests = {m.name: m.digest for m in bp.methods}
    df = results.select(keep)
    return df.with_columns(pl.lit(bp.split).alias("split"), pl.lit(bp.version).alias("benchmark"),
                           pl.col("method").replace_strict(digests, default=None).alias("method_digest"),
                           pl.lit(bp.meta["package_version"]).alias("package_version"))


def _pct(e: Estimate) -> str:
    return e.fmt(pct=True) + f" (n={e.n})" if e.n else "—"


def overall_table(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """One line per method: every aggregate (rates: % [Wilson 95 %]; continuous: mean ± half the bootstrap
    95 % interval)."""
    head = ["method", *RATES.values(), "isolation correct", "isolation wrong",
            *(f"{k} ({u})" for k, u in CONTINUOUS.items())]
    body = []
    for m in methods:
        a = aggregate([r for r in rows if r["method"] == m])
        cells = [_pct(a[k]) for k in RATES] + [_pct(a["isolation_correct"]), _pct(a["isolation_wrong"])]
        cells += [a[k].fmt(u) + f" (n={a[k].n})" if a[k].n else "—" for k, u in CONTINUOUS.items()]
        body.append([m, *cells])
    return table(head, body)


def classes_of(rows: list[dict[str, Any]], order: Sequence[str]) -> list[str]:
    """The fault classes of ``rows``: ``none`` first, then in ``order`` (the definition's)."""
    return [c for c in ("none", *(c for c in order if c != "none")) if any(r["fault_class"] == c for r in rows)]


def class_table(rows: list[dict[str, Any]], methods: list[str], order: Sequence[str], score: str = "success"
                ) -> list[str]:
    """Rate of ``score`` per fault class (rows, in ``order``) and method (columns), Wilson 95 % intervals."""
    body = [[c, *(_pct(aggregate([r for r in rows if r["method"] == m and r["fault_class"] == c])[score])
                  for m in methods)]
            for c in classes_of(rows, order)]
    return table(["fault class", *methods], body)


def pairs_asked(methods: list[str]) -> list[tuple[str, str, str]]:
    """The :data:`QUESTIONS` whose methods were both run, else every pair in command-line order."""
    asked = [q for q in QUESTIONS if q[0] in methods and q[1] in methods]
    return asked or [(a, b, f"{a} against {b}") for a, b in itertools.combinations(methods, 2)]


def _paired_line(p: Paired, unit: str) -> str:
    d = p.diff
    ci = f"{d.mean:+.3g} [{d.lo:+.3g}, {d.hi:+.3g}]{unit}" if d.n > 1 and math.isfinite(d.lo) else (
        f"{d.mean:+.3g}{unit}" if d.n else "—")
    pv = f"{p.p_value:.2g}" if math.isfinite(p.p_value) else "—"
    eff = f"{p.effect:+.2f}" if math.isfinite(p.effect) else "—"
    return row([f"{p.a} − {p.b}", p.score, d.n, ci, f"{p.a_larger} / {p.b_larger}", pv, eff])


def paired_table(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """Paired comparisons (success, largest contouring error, detection delay) of the asked pairs."""
    lines = []
    for a, b, q in pairs_asked(methods):
        lines += [f"**{q}** ({a} against {b}, same draws):", "",
                  *table(["pair", "score", "pairs", "mean difference [paired bootstrap 95 %]", "a larger / b larger",
                          "Wilcoxon p", "rank-biserial r"])]
        for score, unit in (("success", ""), ("contouring_max", " m"), ("detection_delay", " s")):
            lines.append(_paired_line(paired(rows, score, a, b), unit))
        lines.append("")
    return lines


def verdict(p: Paired, larger_is_better: bool) -> str:
    """``yes`` when the paired-bootstrap 95 % interval of ``a − b`` lies wholly on ``a``'s better side, ``no``
    when wholly on ``b``'s, ``not shown`` when it contains 0 (or there is no interval)."""
    d = p.diff
    if d.n < 2 or not (math.isfinite(d.lo) and math.isfinite(d.hi)):
        return "not shown"
    better, worse = (d.lo > 0, d.hi < 0) if larger_is_better else (d.hi < 0, d.lo > 0)
    return "yes" if better else "no" if worse else "not shown"


def answers(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """One line per asked question: the verdict on success and on the largest contouring error, by the rule of
    :func:`verdict`."""
    if not any(q[0] in methods and q[1] in methods for q in QUESTIONS):
        return []
    lines = ["Rule: **yes** when the paired-bootstrap 95 % interval of the difference lies wholly on the first "
             "method's better side (success higher, largest contouring error lower), **no** when wholly on the "
             "other's, **not shown** when it contains 0. Success is the primary score; the contouring error says how "
             "far off the runs end, failed ones included.", ""]
    for a, b, q in pairs_asked(methods):
        ps, pc = paired(rows, "success", a, b), paired(rows, "contouring_max", a, b)
        lines.append(f"- **{q[0].upper() + q[1:]}?** Success: **{verdict(ps, True)}** ({a} − {b} "
                     f"{ps.diff.mean:+.3g} [{ps.diff.lo:+.3g}, {ps.diff.hi:+.3g}], {ps.a_larger} draws won / "
                     f"{ps.b_larger} lost of {ps.diff.n}); largest contouring error: **{verdict(pc, False)}** "
                     f"({pc.diff.mean:+.3g} [{pc.diff.lo:+.3g}, {pc.diff.hi:+.3g}] m).")
    return [*lines, ""]


def bounds_table(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """Per method: detection delay against Lorden's bound on the detected draws that have one, and the final
    radius errors against the PCRB (medians of the ratio)."""
    import numpy as np

    body = []
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        lo = [r["detection_delay"] / r["lorden_delay_bound"] for r in mine if r.get("detection_delay") is not None
              and r.get("lorden_delay_bound")]
        pc = [r[f"radius_error_{w}"] / r[f"radius_pcrb_{w}"] for r in mine for w in "RL"
              if r.get(f"radius_pcrb_{w}") and r.get(f"radius_error_{w}") is not None]
        body.append([m, len(lo), f"{np.median(lo):.3g}" if lo else "—", f"{np.median(pc):.3g}" if pc else "—"])
    return table(["method", "detected draws with a bound", "median delay / Lorden bound",
                  "median radius error / PCRB"], body)


def replay_command(bp: Any, method: str, draw_index: int) -> str:
    """The ``ftc-mj bench`` command that runs ``method`` (a built-in's name, a method file's absolute path) on
    the one draw ``draw_index`` of the bench ``bp`` again, from any folder."""
    import shlex

    arg = next((m.argument for m in bp.methods if m.name == method), method)
    definition = getattr(bp, "replay", {}).get("definition_file") or (None if bp.version == "ftc-v1" else bp.version)
    extra = f" --benchmark {shlex.quote(definition)}" if definition else ""
    return (f"ftc-mj bench {shlex.quote(arg)} --split {bp.split} --start {draw_index} --draws 1{extra}"
            + (" --healthy" if bp.healthy else ""))


def summary_lines(bp: Any, results: pl.DataFrame) -> list[str]:
    """What ``ftc-mj bench`` prints when it ends: per method, the success rate with its Wilson 95 % interval
    and the number of runs (the report's first column)."""
    rows = score_table(bp, results).to_dicts()
    width = max(len(m.name) for m in bp.methods)
    return ["success per method, % [Wilson 95 %] (n runs):",
            *(f"  {m.name:<{width}}  {_pct(aggregate([r for r in rows if r['method'] == m.name])['success'])}"
              for m in bp.methods)]


def failures(rows: list[dict[str, Any]], bp: Any, limit: int = 30) -> list[str]:
    """The runs that did not succeed, named so anyone can replay them (draw index, method, what happened)."""
    bad = sorted((r for r in rows if not r.get("success")), key=lambda r: (r["draw"], r["method"]))
    body = []
    for r in bad[:limit]:
        cm = r.get("contouring_max")
        replay = f"`{replay_command(bp, r['method'], r['draw'])}`"
        body.append([r["draw"], r["fault_class"], r["method"], r.get("outcome") or r.get("status"),
                     "—" if cm is None else f"{cm:.2f}", r.get("tipped"), replay])
    lines = table(["draw", "fault class", "method", "outcome", "contouring max (m)", "tipped", "replay"], body)
    if len(bad) > limit:
        lines.append(f"| … | {len(bad) - limit} more in scores.parquet | | | | | |")
    return lines


def computed_line(out: Path) -> str:
    """Which invocations computed the runs, from ``OUT/log.jsonl``: runs, wall time, date (UTC) and the
    sources' commit where it was recorded."""
    ends = [e for e in StudyStore(out).read_log() if e.get("event") == "end" and e.get("computed")]
    parts = [f"{e['computed']} runs in {e['wall_time_s']:.0f} s on "
             f"{time.strftime('%Y-%m-%d', time.gmtime(e['time']))}"
             f"{' at commit ' + e['source'] if e.get('source') else ''}" for e in ends]
    return ("Computed by " + "; ".join(parts) + " (`log.jsonl` of the output folder)." if parts
            else "No run was computed in this output folder's log.")


def render(bp: Any, rows: list[dict[str, Any]], figures: list[Path], compared: list[Path], computed: str = "") -> str:
    """The report's Markdown; ``computed`` says which invocations computed the runs (:func:`computed_line`)."""
    methods = [m.name for m in bp.methods]
    lo, hi = bp.meta["draws"]
    kind = {"healthy-check.md": "Healthy-path check (every draw without its faults)",
            "leaderboard.md": "Leaderboard", "dev-report.md": "Development-split report (not a leaderboard)"}
    out = [f"# {kind[report_name(bp.split, bp.healthy)]}: benchmark {bp.version}, {bp.split} split", "",
           f"Draws {lo}–{hi - 1} of the {bp.split} split ({hi - lo} draws), {len(rows)} runs; ftc-mj "
           f"{bp.meta['package_version']}. Success: the run completed, did not tip over and its largest |contouring "
           f"error| from 5 s after the last fault onset is ≤ {OFF_PATH_M:g} m. Rates: % [Wilson 95 %] (n runs); "
           "continuous scores: mean ± half the percentile-bootstrap 95 % interval (n runs with a value).",
           *([] if not computed else ["", computed]), "",
           *table(["method", "settings digest", "description", f"replay draw {lo}"],
                  ([m.name, f"`{m.digest}`", m.description, f"`{replay_command(bp, m.name, lo)}`"]
                   for m in bp.methods))]
    out += ["", "## Overall", "", *overall_table(rows, methods), "", "## Success by fault class", "",
            *class_table(rows, methods, bp.classes), ""]
    if len(methods) > 1:
        ans = answers(rows, methods)
        out += ["## The project's questions", "", *ans] if ans else []
        out += ["## Paired comparisons", "", "Differences a − b on the same draws (booleans as 0/1); Wilcoxon "
                "signed-rank test (zero differences dropped) and the matched-pairs rank-biserial correlation.", "",
                *paired_table(rows, methods)]
    out += ["## Bounds", "", "Detection delay over Lorden's bound at the rule's ARL0 (`estimator.decision.arl0`) "
            "for the draw's first change; the filter's final radius error over the PCRB for constant radii since "
            "the last radius change.", "", *bounds_table(rows, methods), "", "## Runs that did not succeed", "",
            *failures(rows, bp), ""]
    out += [f"![{p.stem}](figures/{p.name})" for p in figures]
    if compared:
        out += ["", "Rerun comparisons (`ftc-mj view` opens them): " + ", ".join(f"compare/{p.name}" for p in compared)]
    return "\n".join(out) + "\n"


def draw_figures(rows: list[dict[str, Any]], methods: list[str], folder: Path, order: Sequence[str] = ()
                 ) -> list[Path]:
    """``success_by_class.png`` (success rate per fault class per method, in ``order``, Wilson 95 % bars) and
    ``paired_contouring.png`` (the paired differences of the largest contouring error per asked pair)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    folder.mkdir(parents=True, exist_ok=True)
    classes = classes_of(rows, order)
    fig, ax = plt.subplots(figsize=(min(13.0, max(6.0, 0.9 * len(classes) * max(1, len(methods)) ** 0.5)), 4.2))
    w = 0.8 / max(1, len(methods))
    for j, m in enumerate(methods):
        est = [aggregate([r for r in rows if r["method"] == m and r["fault_class"] == c])["success"] for c in classes]
        x = np.arange(len(classes)) + (j - (len(methods) - 1) / 2) * w
        mean = np.array([e.mean for e in est])
        err = np.array([[e.mean - e.lo for e in est], [e.hi - e.mean for e in est]])
        ax.bar(x, mean, w, yerr=np.nan_to_num(err), capsize=2, label=m)
    ax.set_xticks(np.arange(len(classes)), classes, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("success rate")
    ax.set_ylim(0, 1.05)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    paths = [_save(fig, folder / "success_by_class.png", plt)]
    asked = pairs_asked(methods)
    if len(methods) > 1:
        fig, ax = plt.subplots(figsize=(6.0, 3.4))
        for i, (a, b, _q) in enumerate(asked):
            val = {(r["method"], r["draw"]): r.get("contouring_max") for r in rows}
            d = [val[(a, k)] - val[(b, k)] for (m, k) in val if m == a and val.get((b, k)) is not None
                 and val[(a, k)] is not None]
            ax.scatter(np.full(len(d), i) + np.linspace(-0.2, 0.2, len(d)), d, s=8)
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_xticks(range(len(asked)), [f"{a} − {b}" for a, b, _ in asked], rotation=20, ha="right", fontsize=8)
        ax.set_yscale("symlog", linthresh=0.1)
        ax.set_ylabel("contouring max difference (m)")
        fig.tight_layout()
        paths.append(_save(fig, folder / "paired_contouring.png", plt))
    return paths


def _save(fig: Any, path: Path, plt: Any) -> Path:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


def chosen_draws(rows: list[dict[str, Any]], n: int) -> list[int]:
    """Up to ``n`` draws on which the methods disagree most: some succeed and some do not, the largest spread
    of the largest contouring error first (else the largest spread)."""
    by: dict[int, list[dict[str, Any]]] = {}
    for r in rows:
        by.setdefault(r["draw"], []).append(r)

    def rank(rs: list[dict[str, Any]]) -> tuple[bool, float]:
        ok = {bool(r.get("success")) for r in rs}
        c = [r["contouring_max"] for r in rs if r.get("contouring_max") is not None]
        return (len(ok) > 1, (max(c) - min(c)) if c else 0.0)

    return [d for d, rs in sorted(by.items(), key=lambda kv: rank(kv[1]), reverse=True)][:n]


def write_comparisons(bp: Any, rows: list[dict[str, Any]], folder: Path, n: int) -> list[Path]:
    """A Rerun comparison (:func:`~ftc_mj.rerun.overlay.write_comparison`) of every method on each chosen draw:
    the runs are simulated again with recordings (a run is a pure function of its config: the same runs)."""
    from ..rerun.overlay import write_comparison
    from ..sim.run import execute, run_id_for

    if len(bp.methods) < 2:
        return []
    out = []
    for k in chosen_draws(rows, n):
        d = next(x for x in bp.draws if x.index == k)
        run_root = folder / "runs" / d.name
        dirs = []
        for m in bp.methods:
            cfg = m.apply(d.scenario(with_faults=not bp.healthy))
            done = run_root / run_id_for(cfg)
            dirs.append(done if (done / "trace.parquet").is_file() else execute(cfg, run_root, rrd=True).run_dir)
        out.append(write_comparison(dirs, folder / f"draw-{k:06d}.rrd", [m.name for m in bp.methods],
                                    recording_id=f"bench-{d.name}"))
    return out
