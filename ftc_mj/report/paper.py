"""``ftc-mj paper``: run the paper's matrix and judge its claims.

Two modes:

- **over seeds** (the default): every matrix entry on ``--seeds N`` seeds of ``--seed-set``
  (held-out seeds by default, :mod:`.seeds`) through the study machinery (:mod:`.matrix_study`),
  every check counted over the seeds and judged with a Wilson interval (:mod:`.seeded`);
  ``--tune`` also runs the tuning studies on the development seeds (:mod:`.tuning`);
  ``--baseline`` (repeatable) compares the verdicts with earlier results (:mod:`.compare`), e.g. a
  ``--quick`` output of the same code (check by check) and the published ``docs/paper-claims.md``
  (claim verdicts);
- **single-seed quick look** (``--quick``): one run per entry at the config's seed 0 (a
  development seed), each check pass/fail on that run — labelled as such, not a verdict over seeds.

Layout of ``OUT``::

    OUT/study/<hash>/      the seeded matrix as a study (rows/, log.jsonl, results.parquet, matrix.toml,
                           runs/ of the first seed for the figures)
    OUT/tuning/<study>/<hash>/   the tuning studies (--tune)
    OUT/runs/<run-id>/     the quick look's run directories (reused by the next quick look)
    OUT/summary.csv        one row per run (and seed): identity + flattened metrics + report metrics
    OUT/claims.md          the claims, checks, verdicts; OUT/claims.json the same, machine-readable
    OUT/changes.md         what changed against each --baseline
    OUT/figures/*.png      the figures
    OUT/paper_run.json     the invocation, wall times, machine load, verdicts

Everything is written atomically; finished runs are reused (quick look: ``OUT/runs``; over seeds:
the study's persisted rows).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import BadInput
from ..io import atomic_path, write_json
from .checks import Claim
from .claims import evaluate_claims
from .compare import claims_document
from .matrix import MatrixEntry, full_matrix, select
from .pathfollow_claims import evaluate_pathfollow_claims
from .policy_claims import evaluate_policy_claims
from .render import render_claims
from .runner import RunTask, collect_existing, run_tasks
from .seeds import seed_set
from .summary import write_summary_csv


@dataclass
class PaperOptions:
    """Everything an invocation of ``ftc-mj paper`` asks for (validated by :meth:`check`)."""

    jobs: int = 2
    duration: float | None = None
    only: list[str] | None = None
    extras: bool = True
    rrd: bool = True
    fresh: bool = False
    figures: bool = True
    report_only: bool = False
    quick: bool = False
    seeds: int | None = None
    """Seeds per cell (default 10); not with ``quick``."""
    seed_set: str = "held-out"
    tune: bool = False
    baselines: list[Path] = field(default_factory=list)

    def check(self) -> None:
        if self.jobs < 1:
            raise BadInput(f"--jobs: must be ≥ 1 (got {self.jobs})")
        if self.duration is not None and not self.duration > 0:
            raise BadInput(f"--duration: must be > 0 (got {self.duration})")
        if self.quick and (self.seeds is not None or self.seed_set != "held-out" or self.tune or self.baselines):
            raise BadInput("--quick: a single-seed look at seed 0; --seeds, --seed-set, --tune and --baseline need the "
                           "seeded mode")
        if not self.quick and self.fresh:
            raise BadInput("--fresh: only with --quick (over seeds, finished rows are kept; use another --out)")
        if not self.quick:
            seed_set(self.seed_set, self.n_seeds)

    @property
    def n_seeds(self) -> int:
        return 10 if self.seeds is None else self.seeds

    def command(self, out: Path) -> str:
        """The equivalent command line."""
        parts = ["ftc-mj paper", f"--out {out}", f"--jobs {self.jobs}"]
        parts += ["--quick"] if self.quick else [f"--seeds {self.n_seeds}", f"--seed-set {self.seed_set}"]
        parts += [f"--duration {self.duration:g}"] if self.duration is not None else []
        parts += [f"--only '{p}'" for p in self.only or []]
        parts += [flag for flag, on in (("--no-extras", not self.extras), ("--no-rrd", not self.rrd),
                                        ("--fresh", self.fresh), ("--report-only", self.report_only),
                                        ("--tune", self.tune)) if on]
        parts += [f"--baseline {b}" for b in self.baselines]
        return " ".join(parts)


@dataclass
class PaperResult:
    out: Path
    rows: list[dict[str, Any]]
    claims: list[Any]
    """:class:`~ftc_mj.report.checks.Claim` (quick look) or :class:`~ftc_mj.report.seeded.SeededClaim`."""
    figures: list[Path] = field(default_factory=list)
    wall_time_s: float = 0.0
    """Wall time of the runs (s)."""
    report_time_s: float = 0.0
    """Wall time of summary, claims and figures (s)."""
    tuning: list[Any] = field(default_factory=list)
    """:class:`~ftc_mj.report.tuning.TuningOutcome` s of ``--tune``."""

    @property
    def failed(self) -> list[str]:
        return [r["label"] + (f" (seed {r['seed']})" if r.get("seed") is not None else "")
                for r in self.rows if r.get("status") != "ok"]

    @property
    def exit_code(self) -> int:
        return 1 if self.failed else 0


def run_paper(out: Path, opts: PaperOptions, *, show_progress: bool | None = None,
              echo: Callable[[str], None] | None = None) -> PaperResult:
    """Run the matrix into ``out`` and write the report. Raises :class:`BadInput` for bad arguments
    (before anything is written)."""
    opts.check()
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise BadInput(f"--out: {out} exists and is not a directory")
    entries = select(full_matrix(opts.extras), opts.only)
    if not entries:
        raise BadInput(f"--only: no matrix label matches {', '.join(opts.only or [])} (e.g. 's2-*', "
                       f"'s4-imm-ukf5-fb-nmpc')")
    show = sys.stderr.isatty() if show_progress is None else show_progress
    load0 = os.getloadavg()
    if opts.quick:
        res = run_quick(out, entries, opts, show, echo)
    else:
        from .paper_seeded import run_seeded

        res = run_seeded(out, entries, opts, show, echo)
    info = {"command": opts.command(out), "mode": "quick" if opts.quick else "seeded", "commit": source_commit(),
            "cpus": os.cpu_count(), "started_load_avg": list(load0), "finished_load_avg": list(os.getloadavg()),
            "finished_at": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "runs": len(res.rows),
            "failed": res.failed, "jobs": opts.jobs, "duration": opts.duration, "only": opts.only,
            "extras": opts.extras, "report_only": opts.report_only, "report_time_s": res.report_time_s,
            "tuning": {o.tuned.key: {"chosen": o.selection.value, "default": o.tuned.default(), "seeds": o.seeds,
                                     "runs": o.runs, "failed": o.failed, "wall_time_s": o.wall_time_s}
                       for o in res.tuning},
            "verdicts": {c.id: c.verdict for c in res.claims}}
    prev = out / "paper_run.json"
    if opts.report_only and prev.is_file():  # keep the wall time of the invocation that computed the runs
        import json

        try:
            before = json.loads(prev.read_text())
        except (OSError, ValueError):
            before = {}
        info["wall_time_s"] = before.get("wall_time_s")
        info["runs_command"] = before.get("runs_command") or (None if before.get("report_only")
                                                              else before.get("command"))
    info.setdefault("wall_time_s", res.wall_time_s)
    info["reused"] = sum(1 for r in res.rows if r.get("reused"))
    write_json(prev, info)
    return res


def source_commit() -> str | None:
    """``git describe --always --dirty`` of the checkout the package is imported from, or None when it is
    not in one (an installed wheel)."""
    import subprocess

    checkout = Path(__file__).resolve().parents[2]
    try:
        res = subprocess.run(["git", "-C", str(checkout), "describe", "--always", "--dirty"], capture_output=True,
                             text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return res.stdout.strip() or None if res.returncode == 0 else None


def write_report(out: Path, md: str, doc: dict[str, Any], figs: list[Path], figs_note: str = "") -> None:
    """``claims.md`` (with the figure list) and ``claims.json``, atomically."""
    if figs:
        links = "\n".join(f"- [`figures/{p.name}`](figures/{p.name})" for p in figs)
        md += "\n## Figures\n\n" + (figs_note + "\n\n" if figs_note else "") + links + "\n"
    with atomic_path(out / "claims.md") as tmp:
        tmp.write_text(md)
    write_json(out / "claims.json", doc)


# ------------------------------------------------------------------------------------- quick look
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


def run_quick(out: Path, entries: list[MatrixEntry], opts: PaperOptions, show: bool,
              echo: Callable[[str], None] | None) -> PaperResult:
    """The single-seed quick look: one run per entry (seed 0), reused from ``OUT/runs``."""
    runs_dir = out / "runs"
    tasks = [RunTask.of(e, runs_dir, opts.duration, opts.rrd, opts.fresh) for e in entries]
    on_done, close = _progress_callbacks(len(tasks), show, echo)
    t0 = time.perf_counter()
    try:
        rows = collect_existing(runs_dir, tasks) if opts.report_only else run_tasks(tasks, opts.jobs, on_done)
    finally:
        close()
    wall = time.perf_counter() - t0
    t1 = time.perf_counter()
    write_summary_csv(out / "summary.csv", rows)
    by_label = {r["label"]: r for r in rows}
    claims: list[Claim] = (evaluate_claims(by_label) + evaluate_policy_claims(by_label)
                           + evaluate_pathfollow_claims(by_label))
    figs: list[Path] = []
    if opts.figures:
        from .figures import make_figures

        figs = make_figures({r["label"]: (Path(r["run_dir"]) if r.get("run_dir") else None) for r in rows},
                            out / "figures", jobs=opts.jobs)
    md = render_claims(claims, by_label, {"duration": opts.duration, "wall_time_s": None if opts.report_only
                                          else wall, "jobs": opts.jobs, "seed": 0})
    write_report(out, md, claims_document(claims, [0], "single-seed"), figs)
    return PaperResult(out, rows, claims, figs, wall, time.perf_counter() - t1)
