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
from .ceiling import ceiling_lines, classes_of_draws, every_class_table
from .stats import (
    ALPHA,
    CONTINUOUS,
    MIN_EFFECT_PAIRS,
    POWER_DIFFERENCE,
    RATES,
    TAILS,
    Paired,
    achieved_power,
    aggregate,
    holm,
    median_ci,
    paired,
)

QUESTIONS = (("paper", "safe", "does the paper's loop generalise (against the safe loop)"),
             ("safe", "feedback-off", "does the safe policy beat feedback off"),
             ("pathfollow", "safe", "does the path-following NMPC beat the time-parametrised one"),
             ("pathfollow", "paper", "does the path-following NMPC beat the paper's loop"),
             ("hybrid", "safe", "does the hybrid beat active FTC"),
             ("hybrid", "passive", "does the hybrid beat passive FTC"))
"""The project's questions as (method a, method b, question), asked when both methods were run."""


LEADERBOARD_SPLITS = ("test", "private")
"""The splits whose report is a leaderboard."""
VERDICT_SCORES = (("success", True), ("contouring_max", False))
"""The scores each question gets a verdict on, with whether larger is better."""


def report_name(split: str, healthy: bool) -> str:
    """``leaderboard.md`` (test, private), ``dev-report.md`` (dev) or ``healthy-check.md`` (draws without
    faults)."""
    return "healthy-check.md" if healthy else "leaderboard.md" if split in LEADERBOARD_SPLITS else "dev-report.md"


def write_outputs(bp: Any, results: pl.DataFrame, out: Path, *, compare: int = 1, echo: Any = None,
                  record: Any = None) -> Path:
    """Every output of the module docstring; returns the report's path. ``record``: how the comparisons' runs are
    simulated again (:func:`write_comparisons`)."""
    draws = pl.DataFrame([d.factors() for d in bp.draws], infer_schema_length=None)
    with atomic_path(out / "draws.parquet") as tmp:
        draws.write_parquet(tmp)
    scores = score_table(bp, results)
    with atomic_path(out / "scores.parquet") as tmp:
        scores.write_parquet(tmp)
    rows = scores.to_dicts()
    log_scoring(bp, out)
    every = {} if bp.healthy else classes_of_draws(bp.draws)  # a draw in every class of its faults, as the table
    per_class = [{**r, "fault_class": c} for r in rows for c in every.get(r["draw"], (r["fault_class"],))]
    figures = draw_figures(per_class, [m.name for m in bp.methods], out / "figures", bp.classes)
    compared = write_comparisons(bp, rows, out / "compare", compare, record) if compare > 0 else []
    history = scoring_history(bp, out) if bp.split in LEADERBOARD_SPLITS else []
    text = render(bp, rows, figures, compared, computed_line(out), history)
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


def _median(e: Estimate, unit: str) -> str:
    """``median [lo, hi] unit (n=…)``; ``—`` without data; the interval left out below 6 values."""
    if not e.n:
        return "—"
    ci = f" [{e.lo:.3g}, {e.hi:.3g}]" if math.isfinite(e.lo) else ""
    return f"{e.mean:.3g}{ci} {unit} (n={e.n})"


def overall_table(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """One line per method: every aggregate (rates: % [Wilson 95 %]; continuous: median [order-statistic
    95 %]; tail fractions: % of runs above the threshold [Wilson 95 %])."""
    tails = [(k, t) for k, ts in TAILS.items() for t in ts]
    head = ["method", *RATES.values(), "isolation correct", "isolation wrong",
            *(f"{k} median ({u})" for k, u in CONTINUOUS.items()), *(f"{k} > {t:g} {CONTINUOUS[k]}" for k, t in tails)]
    body = []
    for m in methods:
        a = aggregate([r for r in rows if r["method"] == m])
        cells = [_pct(a[k]) for k in RATES] + [_pct(a["isolation_correct"]), _pct(a["isolation_wrong"])]
        cells += [_median(a[k], u) for k, u in CONTINUOUS.items()]
        cells += [_pct(a[f"{k}>{t:g}"]) for k, t in tails]
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


def _interval(p: Paired, unit: str) -> str:
    if not p.n:
        return "—"
    ci = f" [{p.lo:+.3g}, {p.hi:+.3g}]" if math.isfinite(p.lo) else ""
    return f"{p.estimate:+.3g}{ci}{unit}"


def _paired_line(p: Paired, unit: str) -> str:
    pv = f"{p.p_value:.2g}" if math.isfinite(p.p_value) else "—"
    eff = f"{p.effect:+.2f}" if math.isfinite(p.effect) else f"— (< {MIN_EFFECT_PAIRS} discordant)"
    kind = "difference of rates" if p.binary else "median difference"
    return row([f"{p.a} − {p.b}", p.score, p.n, f"{_interval(p, unit)} ({kind})", f"{p.a_larger} / {p.b_larger}",
                pv, eff])


def paired_table(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """Paired comparisons (success, largest contouring error, detection delay) of the asked pairs."""
    lines = []
    for a, b, q in pairs_asked(methods):
        lines += [f"**{q}** ({a} against {b}, same draws):", "",
                  *table(["pair", "score", "pairs", "estimate [95 %]", "a larger / b larger",
                          "exact p (McNemar / sign test)", "rank-biserial r"])]
        for score, unit in (("success", ""), ("contouring_max", " m"), ("detection_delay", " s")):
            lines.append(_paired_line(paired(rows, score, a, b), unit))
        lines.append("")
    return lines


def verdict(p: Paired, larger_is_better: bool, adjusted: float | None = None) -> str:
    """``yes`` when the exact test (McNemar for success, the sign test otherwise) rejects equality at
    :data:`~ftc_mj.benchmark.stats.ALPHA` — with the ``adjusted`` (Holm) p when given, else the question's own —
    and ``a`` is on the better side (more draws won than lost; lower values for a score where lower is
    better), ``no`` when it rejects with ``b`` on the better side, ``not shown`` otherwise."""
    q = p.p_value if adjusted is None else adjusted
    if not (p.n and math.isfinite(q) and q < ALPHA):
        return "not shown"
    a_better = (p.a_larger > p.b_larger) == larger_is_better
    return "yes" if a_better else "no"


def verdicts(rows: list[dict[str, Any]], methods: list[str]) -> list[tuple[str, str, str, list[tuple[Paired, float]]]]:
    """Every asked question with its :data:`VERDICT_SCORES` comparisons and their p-values adjusted by Holm over
    all the verdicts of the page."""
    asked = pairs_asked(methods)
    ps = [paired(rows, score, a, b) for a, b, _q in asked for score, _ in VERDICT_SCORES]
    adj = holm([p.p_value for p in ps])
    k = len(VERDICT_SCORES)
    return [(a, b, q, list(zip(ps[i * k:(i + 1) * k], adj[i * k:(i + 1) * k], strict=True)))
            for i, (a, b, q) in enumerate(asked)]


def answers(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """One line per asked question: the verdicts on success and on the largest contouring error (rule of
    :func:`verdict`, Holm over the page's verdicts) and the question's achieved power."""
    if not any(q[0] in methods and q[1] in methods for q in QUESTIONS):
        return []
    found = verdicts(rows, methods)
    k = sum(len(v) for *_, v in found)
    lines = [f"Rule: **yes** when the exact test rejects equality at {ALPHA:g} after Holm's correction over the page's "
             f"{k} verdicts and the first method is on the better side (success: exact McNemar test of the draws won "
             "and lost; largest contouring error: exact sign test, lower is better), **no** when it rejects with the "
             "other method on the better side, **not shown** otherwise. Success: difference of the rates with an "
             "interval that holds with few discordant draws (Clopper–Pearson for the split of the discordant draws "
             "and for their share, at 97.5 % each); contouring error: median of the paired differences with its "
             "order-statistic interval (equal values count there; the sign test leaves them out, so with many "
             "ties the interval may touch 0 where the test rejects). Power: the exact McNemar test's power to find "
             f"a {100 * POWER_DIFFERENCE:g}-point success difference on these draws at the discordance the question "
             f"showed, at {ALPHA:g}/{k} (Holm's first step).", ""]
    for a, b, q, ((ps, s_adj), (pc, c_adj)) in found:
        power = achieved_power(ps.n, ps.a_larger, ps.b_larger, k)
        lines.append(f"- **{q[0].upper() + q[1:]}?** Success: **{verdict(ps, True, s_adj)}** ({a} − {b} "
                     f"{_interval(ps, '')}, {ps.a_larger} draws won / {ps.b_larger} lost of {ps.n}, p = "
                     f"{ps.p_value:.2g}, Holm {s_adj:.2g}; power {100 * power:.0f} %); largest contouring error: "
                     f"**{verdict(pc, False, c_adj)}** ({_interval(pc, ' m')}, Holm p = {c_adj:.2g}).")
    return [*lines, ""]


def bounds_table(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """Per method: detection delay (the first declaration) and the tyre detectors' first alarm
    (``tyre_alarm_delay``) over Lorden's bound on the draws that have both, and the worse wheel's final radius
    error over its PCRB per draw: each the median over draws with its distribution-free 95 % interval
    (:func:`~.stats.median_ci`; one value per draw, so the draws are the independent units). A bound of 0 (the
    change's information crossed the threshold at its first row: no delay is a finite multiple of it) cannot be
    divided by; such draws are counted apart, in brackets beside the count."""

    def ratios(mine: list[dict[str, Any]], delay: str, bound: str) -> tuple[list[float], int]:
        def b(r: dict[str, Any]) -> Any:  # rows scored before the tyre alarms had their own bound: the rule's
            return r.get(bound) if bound in r else r.get("lorden_delay_bound")
        timed = [r for r in mine if r.get(delay) is not None and b(r) is not None]
        return [r[delay] / b(r) for r in timed if b(r) > 0.0], sum(1 for r in timed if b(r) == 0.0)

    def count(n: int, zero: int) -> str:
        return f"{n} (+{zero} with a zero bound)" if zero else str(n)

    def cell(values: list[float]) -> str:
        m = median_ci(values)
        return "—" if not values else (f"{m.mean:.3g} [{m.lo:.3g}, {m.hi:.3g}]" if math.isfinite(m.lo)
                                       else f"{m.mean:.3g}")

    body = []
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        (lo, lz) = ratios(mine, "detection_delay", "lorden_delay_bound")
        (al, az) = ratios(mine, "tyre_alarm_delay", "tyre_alarm_bound")
        pc = [max(r[f"radius_error_{w}"] / r[f"radius_pcrb_{w}"] for w in "RL") for r in mine
              if all(r.get(f"radius_pcrb_{w}") and r.get(f"radius_error_{w}") is not None for w in "RL")]
        body.append([m, count(len(lo), lz), cell(lo), count(len(al), az), cell(al), cell(pc)])
    return table(["method", "detected draws with a bound", "median delay / Lorden bound [95 %]",
                  "tyre-alarmed draws with a bound", "median tyre alarm delay / Lorden bound [95 %]",
                  "median worse wheel's radius error / PCRB [95 %]"], body)


def replay_command(bp: Any, method: str, draw_index: int) -> str:
    """The ``ftc-mj bench`` command that runs ``method`` (a built-in's name, a method file's absolute path) on
    the one draw ``draw_index`` of the bench ``bp`` again, from any folder."""
    import shlex

    arg = next((m.argument for m in bp.methods if m.name == method), method)
    definition = getattr(bp, "replay", {}).get("definition_file") or bp.version
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
    judged = getattr(getattr(bp, "rule", None), "rule", "") == "progress"
    body = []
    for r in bad[:limit]:
        cm = r.get("contouring_max")
        replay = f"`{replay_command(bp, r['method'], r['draw'])}`"
        extra = [r.get("label"), _progress_cell(r)] if judged else []
        body.append([r["draw"], r["fault_class"], r["method"], r.get("outcome") or r.get("status"),
                     "—" if cm is None else f"{cm:.2f}", r.get("tipped"), *extra, replay])
    head = ["draw", "fault class", "method", "outcome", "contouring max (m)", "tipped"]
    lines = table([*head, *(["label", "progress / needed (m)"] if judged else []), "replay"], body)
    if len(bad) > limit:
        lines.append(f"| … | {len(bad) - limit} more in scores.parquet |" + " |" * (len(head) - 1 + 2 * judged))
    return lines


def _progress_cell(r: dict[str, Any]) -> str:
    """``progress / needed`` (m) of a row judged by the progress rule."""
    p, n = r.get("progress"), r.get("progress_needed")
    return "—" if p is None or n is None else f"{p:.1f} / {n:.1f}"


def computed_line(out: Path) -> str:
    """Which invocations computed the runs, from ``OUT/log.jsonl``: runs, wall time, date (UTC) and the
    sources' commit where it was recorded."""
    ends = [e for e in StudyStore(out).read_log() if e.get("event") == "end" and e.get("computed")]
    parts = [f"{e['computed']} runs in {e['wall_time_s']:.0f} s on "
             f"{time.strftime('%Y-%m-%d', time.gmtime(e['time']))}"
             f"{' at commit ' + e['source'] if e.get('source') else ''}" for e in ends]
    return ("Computed by " + "; ".join(parts) + " (`log.jsonl` of the output folder)." if parts
            else "No run was computed in this output folder's log.")


def log_scoring(bp: Any, out: Path) -> None:
    """Append a ``scored`` line to ``OUT/log.jsonl``: the split, the draws and each method's identity (name →
    digest, which covers its settings and code) — what :func:`scoring_history` counts."""
    StudyStore(out).log("scored", split=bp.split, draws=list(bp.meta["draws"]),
                        methods={m.name: m.digest for m in bp.methods})


def scoring_history(bp: Any, out: Path) -> list[str]:
    """Per method identity (name and digest) ever scored in ``out``: the date (UTC) of its first run there (its
    earliest persisted run, else its first scoring) and how many times it has been scored (``scored`` lines of
    the log). A changed method — settings or code — has another digest: a row of its own."""
    log = StudyStore(out).read_log()
    method_of = {r.key: r.labels["method"] for r in bp.plan.runs}
    first_run: dict[str, float] = {}
    for e in log:
        m = method_of.get(e.get("run_key")) if e.get("event") == "run" else None
        if m is not None:
            first_run[m] = min(first_run.get(m, e["time"]), e["time"])
    seen: dict[tuple[str, str], list[float]] = {}
    for e in log:
        if e.get("event") == "scored" and e.get("split") == bp.split:
            for name, digest in e.get("methods", {}).items():
                seen.setdefault((name, digest), []).append(e["time"])
    current = {(m.name, m.digest) for m in bp.methods}
    day = lambda t: time.strftime("%Y-%m-%d", time.gmtime(t))  # noqa: E731
    body = [[name, f"`{digest}`", day(first_run[name] if (name, digest) in current and name in first_run
                                      else min(times)), len(times), "yes" if (name, digest) in current else "no"]
            for (name, digest), times in sorted(seen.items(), key=lambda kv: min(kv[1]))]
    return table(["method", "digest", f"first run on {bp.split}", "times scored", "on this page"], body)


def draw_count_line(bp: Any) -> str:
    """Whether this report's draw count is the one the version fixed in advance for its leaderboard."""
    from .definition import load_definition

    fixed = load_definition(bp.meta.get("definition_file", bp.version)).leaderboard_draws
    lo, hi = bp.meta["draws"]
    if fixed is None:
        return f"Benchmark {bp.version} fixes no leaderboard draw count (`leaderboard_draws`)."
    if (lo, hi) == (0, fixed):
        return f"Draws 0–{fixed - 1}: the leaderboard's draw count, fixed in advance for {bp.version}."
    return (f"**Not the leaderboard's draws**: {bp.version} fixes draws 0–{fixed - 1} in advance "
            f"(`leaderboard_draws = {fixed}`); these are draws {lo}–{hi - 1}.")


def success_sentence(bp: Any) -> str:
    """What success means under the version's rule (``[judge]``)."""
    rule = getattr(bp, "rule", None)
    if rule is not None and rule.rule == "progress":
        return ("Success: rule `progress` — on a trackable draw, near the path *and* progressing along it at "
                f"{100 * rule.progress_fraction:g} % of the attainable speed; on a stop-only draw, tracking until the "
                "fault, then a safe stop (section \"Trackable and stop-only draws\").")
    return (f"Success: the run completed, did not tip over and its largest |contouring error| from 5 s after the last "
            f"fault onset is ≤ {OFF_PATH_M:g} m.")


def render(bp: Any, rows: list[dict[str, Any]], figures: list[Path], compared: list[Path], computed: str = "",
           history: Sequence[str] = ()) -> str:
    """The report's Markdown; ``computed`` says which invocations computed the runs (:func:`computed_line`),
    ``history`` the scoring history of a leaderboard (:func:`scoring_history`)."""
    methods = [m.name for m in bp.methods]
    lo, hi = bp.meta["draws"]
    kind = {"healthy-check.md": "Healthy-path check (every draw without its faults)",
            "leaderboard.md": "Leaderboard", "dev-report.md": "Development-split report (not a leaderboard)"}
    out = [f"# {kind[report_name(bp.split, bp.healthy)]}: benchmark {bp.version}, {bp.split} split", "",
           f"Draws {lo}–{hi - 1} of the {bp.split} split ({hi - lo} draws), {len(rows)} runs; ftc-mj "
           f"{bp.meta['package_version']}. {success_sentence(bp)} Rates: % [Wilson 95 %] (n runs); "
           "continuous scores: median [distribution-free order-statistic 95 %] (n runs with a value) and the share "
           "of runs beyond thresholds.",
           *([] if not computed else ["", computed]),
           *(["", draw_count_line(bp)] if bp.split in LEADERBOARD_SPLITS and not bp.healthy else []), "",
           *table(["method", "settings digest", "description", f"replay draw {lo}"],
                  ([m.name, f"`{m.digest}`", m.description, f"`{replay_command(bp, m.name, lo)}`"]
                   for m in bp.methods))]
    if history:
        out += ["", f"Scoring history on the {bp.split} split (this output folder's log):", "", *history]
    out += ["", "## Overall", "", *overall_table(rows, methods), "", *ceiling_lines(bp, rows, methods),
            "## Success by fault class", "", "A draw counts in every class of its faults (a draw with two faults in "
            "two rows).", "", *every_class_table(rows, methods, bp.classes, {} if bp.healthy else
                                                   classes_of_draws(bp.draws)), ""]
    if len(methods) > 1:
        ans = answers(rows, methods)
        out += ["## The project's questions", "", *ans] if ans else []
        out += ["## Paired comparisons", "", "Differences a − b on the same draws: success as the difference of the "
                "rates (interval of the rule above) with the exact McNemar p, continuous scores as the median of the "
                "paired differences (order-statistic interval) with the exact sign-test p; the matched-pairs "
                f"rank-biserial correlation only from {MIN_EFFECT_PAIRS} discordant pairs on. p-values here are not "
                "adjusted (the verdicts are).", "",
                *paired_table(rows, methods)]
    out += ["## Bounds", "", "Detection delay (the first declaration) over Lorden's bound at the decision rule's "
            "no-fault alarm rate measured on MuJoCo (`benchmarks/calibration.py` in the source repository; "
            "`estimator.decision.arl0` for a rule not measured), and the diagnoser's tyre detectors' first alarm "
            "after the onset over the bound at their own: with its fast tyre detector (on by default), that "
            "detector's mean time to a false alarm measured on healthy development draws of ftc-v2 "
            "(`benchmarks/tyre_change_calibration.py`), else the rule's. Both bounds are "
            "for the draw's first change, from the information of every measurement a method has: the speed, the "
            "yaw rate and the pose fixes; the filter's final radius error over the PCRB for constant radii since "
            "the last radius change, of the wheel whose ratio is the larger. Medians over draws with their "
            "distribution-free 95 % intervals.", "",
            *bounds_table(rows, methods), "", "## Runs that did not succeed", "",
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


def record_runs(jobs: list[tuple[Any, Path]]) -> list[Path]:
    """Simulate each ``(config, run root)`` with its recording, one after the other in this process; the run
    folders."""
    from ..sim.run import execute

    return [Path(execute(cfg, root, rrd=True).run_dir) for cfg, root in jobs]


def write_comparisons(bp: Any, rows: list[dict[str, Any]], folder: Path, n: int, record: Any = None) -> list[Path]:
    """A Rerun comparison (:func:`~ftc_mj.rerun.overlay.write_comparison`) of every method on each chosen draw:
    the runs are simulated again with recordings (a run is a pure function of its config: the same runs) by
    ``record`` (``[(config, run root)] -> [run folder]``; default :func:`record_runs`, in this process)."""
    from ..rerun.overlay import write_comparison
    from ..sim.run import run_id_for

    if len(bp.methods) < 2:
        return []
    dirs: dict[int, list[Path]] = {}
    jobs: list[tuple[Any, Path]] = []
    slots: list[tuple[int, int]] = []
    for k in chosen_draws(rows, n):
        d = next(x for x in bp.draws if x.index == k)
        dirs[k] = []
        for m in bp.methods:
            cfg = m.apply(d.scenario(with_faults=not bp.healthy))
            done = folder / "runs" / d.name / run_id_for(cfg)
            dirs[k].append(done)
            if not (done / "trace.parquet").is_file():
                jobs.append((cfg, folder / "runs" / d.name))
                slots.append((k, len(dirs[k]) - 1))
    for (k, i), path in zip(slots, (record or record_runs)(jobs) if jobs else [], strict=True):
        dirs[k][i] = path
    names = {x.index: x.name for x in bp.draws}
    return [write_comparison(ds, folder / f"draw-{k:06d}.rrd", [m.name for m in bp.methods],
                             recording_id=f"bench-{names[k]}") for k, ds in dirs.items()]
