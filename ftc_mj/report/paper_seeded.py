"""``ftc-mj paper`` over seeds: the matrix on N seeds through the study machinery, the claims
evaluated per seed and judged over the seeds, the tuning studies, the comparison with a baseline."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import BadInput
from ..io import atomic_path
from .claims import evaluate_claims
from .compare import claims_document, compare, load_baseline
from .matrix import MatrixEntry
from .matrix_study import AXIS, load_matrix_study, run_matrix_study
from .pathfollow_claims import evaluate_pathfollow_claims
from .policy_claims import evaluate_policy_claims
from .render_seeded import render_seeded
from .seeded import combine
from .seeds import DEV_SEEDS, seed_set
from .summary import write_summary_csv

if TYPE_CHECKING:
    from .paper import PaperOptions, PaperResult


def summary_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Study rows as summary rows: ``label`` (the matrix label) first, the down-sampled series dropped."""
    return [{"label": r[AXIS], **{k: v for k, v in r.items() if k != AXIS and not k.startswith("ts_")}}
            for r in rows]


def _echo_rows(echo: Callable[[str], None] | None, total: int) -> Callable[[dict[str, Any]], None]:
    done = [0]

    def on_row(row: dict[str, Any]) -> None:
        done[0] += 1
        if echo is not None:
            err = f" — {row.get('error')}" if row.get("status") != "ok" else ""
            echo(f"[{done[0]}/{total}] {row.get(AXIS)} seed {row.get('seed')}: {row.get('status')} "
                 f"({row.get('task_wall_s') or float('nan'):.1f} s){err}")

    return on_row


def run_seeded(out: Path, entries: list[MatrixEntry], opts: PaperOptions, show: bool,
               echo: Callable[[str], None] | None) -> PaperResult:
    """Run (or read back) the seeded matrix and write the report over seeds."""
    from .paper import PaperResult, write_report

    seeds = seed_set(opts.seed_set, opts.n_seeds)
    baselines = [(b, load_baseline(b)) for b in opts.baselines]
    plan = load_matrix_study(entries, seeds, opts.duration, out, write=not opts.report_only)
    if opts.report_only and not (plan.path.parent / "rows").is_dir():
        raise BadInput(f"--report-only: no seeded results for this selection in {plan.path.parent}")
    tuning = None
    if opts.tune:
        from .tuning import run_tuning

        tuning = run_tuning(out, n_seeds=min(opts.n_seeds, len(DEV_SEEDS)), duration=opts.duration,
                            workers=opts.jobs, progress=show, report_only=opts.report_only)
    t0 = time.perf_counter()
    res = run_matrix_study(plan, workers=opts.jobs, keep_seed=seeds[0], report_only=opts.report_only,
                           progress=show, on_row=None if show else _echo_rows(echo, len(plan.runs)))
    wall = time.perf_counter() - t0
    t1 = time.perf_counter()
    rows_by_seed = res.by_seed()
    claims = combine({s: evaluate_claims(r) + evaluate_policy_claims(r) + evaluate_pathfollow_claims(r)
                      for s, r in rows_by_seed.items()})
    rows = summary_rows(res.rows)
    write_summary_csv(out / "summary.csv", rows)
    figs = _figures(out, rows_by_seed.get(seeds[0], {}), opts.jobs) if opts.figures else []
    doc = claims_document(claims, seeds, "seeded")
    doc["seed_set"] = opts.seed_set
    changes = [(str(b), compare(doc, base)) for b, base in baselines]
    if changes:
        with atomic_path(out / "changes.md") as tmp:
            tmp.write_text("".join(f"## Against `{src}`\n\n" + ("\n".join(lines) or "- nothing") + "\n\n"
                                   for src, lines in changes))
    meta = {"duration": opts.duration, "wall_time_s": None if opts.report_only else wall, "jobs": opts.jobs,
            "computed": res.computed}
    write_report(out, render_seeded(claims, rows_by_seed, meta, tuning, changes), doc, figs,
                 f"Drawn from the runs of seed {seeds[0]} (one seed; the verdicts above use all {len(seeds)}).")
    return PaperResult(out, rows, claims, figs, wall, time.perf_counter() - t1, tuning or [])


def _figures(out: Path, rows: Mapping[str, Mapping[str, Any]], jobs: int) -> list[Path]:
    """The figures, drawn from the runs of the first seed (the only ones whose run directory is kept)."""
    from .figures import make_figures

    return make_figures({lb: (Path(r["run_dir"]) if r.get("run_dir") else None) for lb, r in rows.items()},
                        out / "figures", jobs=jobs)
