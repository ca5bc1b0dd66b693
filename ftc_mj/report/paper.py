"""``ftc-mj paper``: run the paper's matrix, then write ``summary.csv``, ``claims.md``, ``figures/``.

Layout of ``OUT``::

    OUT/runs/<run-id>/{config.toml,trace.parquet,metrics.json,run.rrd}
    OUT/summary.csv        one row per run (identity + flattened metrics + derived metrics)
    OUT/claims.md          the paper's §4 claims with our numbers and verdicts
    OUT/figures/*.png      the figures
    OUT/paper_run.json     wall times, jobs, the invocation

Everything is written atomically; runs already finished in ``OUT/runs`` are reused.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import BadInput
from ..io import atomic_path, write_json
from .claims import Claim, evaluate_claims
from .matrix import full_matrix, make_label, select
from .pathfollow_claims import evaluate_pathfollow_claims
from .policy_claims import evaluate_policy_claims
from .render import render_claims
from .runner import RunTask, row_from_run_dir, run_tasks
from .summary import write_summary_csv


@dataclass
class PaperResult:
    out: Path
    rows: list[dict[str, Any]]
    claims: list[Claim]
    figures: list[Path] = field(default_factory=list)
    wall_time_s: float = 0.0
    """Wall time of the runs (s)."""
    report_time_s: float = 0.0
    """Wall time of summary, claims and figures (s)."""

    @property
    def failed(self) -> list[str]:
        return [r["label"] for r in self.rows if r.get("status") != "ok"]

    @property
    def exit_code(self) -> int:
        return 1 if self.failed else 0


def _progress_callbacks(n: int, show: bool, echo: Callable[[str], None] | None
                        ) -> tuple[Callable[[dict[str, Any], int, int], None], Callable[[], None]]:
    """(on_done, close) for a rich progress bar when ``show``, else plain lines via ``echo``."""
    if show:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        bar = Progress(TextColumn("[bold]paper"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                       TextColumn("{task.description}"), transient=False, console=Console(stderr=True))
        task = bar.add_task("", total=n)
        bar.start()

        def done(row: dict[str, Any], i: int, total: int) -> None:
            tag = "" if row.get("status") == "ok" else " [red]FAILED[/red]"
            bar.update(task, completed=i, description=f"{row.get('label')}{tag}")

        return done, bar.stop

    def done_plain(row: dict[str, Any], i: int, total: int) -> None:
        if echo is not None:
            how = "reused" if row.get("reused") else f"{row.get('task_wall_s', float('nan')):.1f} s"
            echo(f"[{i}/{total}] {row.get('label')}: {row.get('status')} ({how})"
                 + (f" — {row.get('error')}" if row.get("status") != "ok" else ""))

    return done_plain, lambda: None


def label_of_run(run_dir: Path) -> str | None:
    """The matrix label of a finished run directory, from its ``metrics.json`` identity."""
    import json

    try:
        m = json.loads((run_dir / "metrics.json").read_text())
    except (OSError, ValueError):
        return None
    est = m.get("estimator")
    if not isinstance(est, str) or not isinstance(m.get("scenario"), str):
        return None
    policy = m.get("policy") or ("direct" if m.get("feedback") else "none")
    return make_label(m["scenario"], est, str(policy), str(m.get("controller")),
                      int(m.get("imm_models") or 4), str(m.get("imm_variant") or "hypothesis"),
                      str(m.get("sensing") or "speed"), float(m.get("rate_penalty") or 0.0))


def collect_existing(runs_dir: Path, tasks: list[RunTask]) -> list[dict[str, Any]]:
    """Rows for ``tasks`` from the newest finished run of each label found in ``runs_dir`` (whatever its
    config hash); labels without a run get a row with status ``missing``."""
    newest: dict[str, tuple[float, Path]] = {}
    if runs_dir.is_dir():
        for d in runs_dir.iterdir():
            if d.is_dir() and (d / "metrics.json").is_file() and (d / "trace.parquet").is_file():
                lb = label_of_run(d)
                if lb is not None:
                    mt = (d / "metrics.json").stat().st_mtime
                    if lb not in newest or mt > newest[lb][0]:
                        newest[lb] = (mt, d)
    rows = []
    for task in tasks:
        if task.label in newest:
            rows.append(row_from_run_dir(task, newest[task.label][1], reused=True))
        else:
            rows.append(dict(task.identity, status="missing", error="no finished run in " + str(runs_dir)))
    return rows


def run_paper(out: Path, *, jobs: int = 2, duration: float | None = None, only: list[str] | None = None,
              extras: bool = True, rrd: bool = True, fresh: bool = False, figures: bool = True,
              show_progress: bool | None = None, echo: Callable[[str], None] | None = None,
              report_only: bool = False) -> PaperResult:
    """Run the matrix into ``out`` and write the report. Raises :class:`BadInput` for bad arguments
    (before anything is written)."""
    if jobs < 1:
        raise BadInput(f"--jobs: must be ≥ 1 (got {jobs})")
    if duration is not None and not duration > 0:
        raise BadInput(f"--duration: must be > 0 (got {duration})")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise BadInput(f"--out: {out} exists and is not a directory")
    entries = select(full_matrix(extras), only)
    if not entries:
        raise BadInput(f"--only: no matrix label matches {', '.join(only or [])} (e.g. 's2-*', 's4-imm-ukf5-fb-nmpc')")
    runs_dir = out / "runs"
    tasks = [RunTask.of(e, runs_dir, duration, rrd, fresh) for e in entries]
    show = sys.stderr.isatty() if show_progress is None else show_progress
    on_done, close = _progress_callbacks(len(tasks), show, echo)
    t0 = time.perf_counter()
    if report_only:
        close()
        rows = collect_existing(runs_dir, tasks)
    else:
        try:
            rows = run_tasks(tasks, jobs, on_done)
        finally:
            close()
    wall = time.perf_counter() - t0

    prev_wall: float | None = None
    prev_reused: int | None = None
    if report_only:  # keep the wall time of the matrix run that produced these runs
        import json

        try:
            prev = json.loads((out / "paper_run.json").read_text())
            prev_wall = prev.get("wall_time_s")
            jobs = int(prev.get("jobs") or jobs)
            prev_reused = prev.get("reused")
        except (OSError, ValueError):
            pass
    t1 = time.perf_counter()
    write_summary_csv(out / "summary.csv", rows)
    by_label = {r["label"]: r for r in rows}
    claims = evaluate_claims(by_label) + evaluate_policy_claims(by_label) + evaluate_pathfollow_claims(by_label)
    figs: list[Path] = []
    if figures:
        from .figures import make_figures

        figs = make_figures({r["label"]: (Path(r["run_dir"]) if r.get("run_dir") else None) for r in rows},
                            out / "figures", jobs=jobs)
    matrix_wall = prev_wall if report_only else wall
    meta = {"duration": duration, "wall_time_s": matrix_wall, "jobs": jobs,
            "reused": prev_reused if report_only else sum(1 for r in rows if r.get("reused"))}
    md = render_claims(claims, by_label, meta)
    if figs:
        md += "\n## Figures\n\n" + "\n".join(f"- [`figures/{p.name}`](figures/{p.name})" for p in figs) + "\n"
    with atomic_path(out / "claims.md") as tmp:
        tmp.write_text(md)
    report_time = time.perf_counter() - t1
    write_json(out / "paper_run.json", {
        "runs": len(rows), "failed": [r["label"] for r in rows if r.get("status") != "ok"],
        "reused": meta["reused"], "jobs": jobs, "duration": duration, "only": only, "extras": extras,
        "wall_time_s": matrix_wall, "report_only": report_only, "report_time_s": report_time,
        "run_wall_time_s": {r["label"]: r.get("wall_time_s") for r in rows},
        "verdicts": {c.id: c.verdict for c in claims},
    })
    return PaperResult(out, rows, claims, figs, wall, report_time)
