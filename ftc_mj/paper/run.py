"""``ftc-mj paper``: run the paper's matrix and judge its claims — one pipeline, two modes.

- **over seeds** (the default): every matrix entry on ``--seeds N`` seeds of ``--seed-set``
  (held-out seeds by default, :mod:`.seeds`), every check counted over the seeds and judged with a
  Wilson interval (:mod:`.verdicts`); ``--tune`` also runs the tuning studies on the development
  seeds (:mod:`.tuning`); ``--baseline`` (repeatable) compares the verdicts with earlier results
  (:mod:`.diff`), e.g. a ``--quick`` output of the same code (check by check) and the published
  ``docs/paper-claims.md`` (claim verdicts);
- **single-seed quick look** (``--quick``): the same run with the one seed 0 (a development seed),
  each check pass/fail on that run — labelled as such, not a verdict over seeds.

Both run the matrix as a study (:mod:`.matrix_study`: one persisted row per run, resumable).

Layout of ``OUT``::

    OUT/study/<hash>/      the matrix as a study (rows/, log.jsonl, results.parquet, matrix.toml;
                           over seeds also runs/: the run directories of the first seed, for the figures)
    OUT/runs/<run-id>/     the quick look's run directories (config, metrics, events and the trace columns the
                           figures need; with --rrd runs|compare also run.rrd and the whole trace)
    OUT/tuning/<study>/<hash>/   the tuning studies (--tune)
    OUT/summary.csv        one row per run and seed: identity + flattened metrics + report metrics
    OUT/claims.md          the claims, checks, verdicts; OUT/claims.json the same, machine-readable
    OUT/changes.md         what changed against each --baseline
    OUT/figures/*.png      the figures
    OUT/paper_run.json     the invocation, wall times, machine load, verdicts

``--publish DOCS`` then writes ``DOCS/paper-claims.md`` and copies the figure selection into ``DOCS/figures/``
(:mod:`ftc_mj.reports.paper_claims`, called by the CLI after :func:`run_paper`; the folder is checked here,
before any run).

Everything is written atomically; finished runs are reused (the study's persisted rows; the quick
look recomputes its failed runs, over seeds a failed row is kept).
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ..config import RunConfig, one_line
from ..errors import BadInput
from ..io import atomic_path, write_json
from .claims import evaluate_all
from .diff import claims_document, compare, load_baseline
from .matrix import MatrixEntry, full_matrix, select
from .matrix_study import AXIS, load_matrix_study, run_matrix_study
from .render import render_claims
from .seeds import DEV_SEEDS, seed_set
from .summary import write_summary_csv
from .verdicts import Claim, combine

QUICK_SEED = 0
"""The quick look's seed (the config default; a development seed)."""


@dataclass
class PaperOptions:
    """Everything an invocation of ``ftc-mj paper`` asks for (validated by :meth:`check`)."""

    jobs: int = 2
    duration: float | None = None
    """Every run shortened to this many seconds (None: the scenario's)."""
    only: list[str] | None = None
    extras: bool = True
    rrd: bool = False
    """Quick look: a recording and the whole trace in each run directory (else the trace columns the
    figures need, :func:`~ftc_mj.paper.matrix_study.kept_columns`)."""
    fresh: bool = False
    figures: bool = True
    report_only: bool = False
    quick: bool = False
    seeds: int | None = None
    """Seeds per cell (default 10); not with ``quick``."""
    seed_set: str = "held-out"
    tune: bool = False
    baselines: list[Path] = field(default_factory=list)
    publish: Path | None = None
    """Docs folder that receives ``paper-claims.md`` and the figure selection after the report
    (:mod:`ftc_mj.reports.paper_claims`)."""

    def check(self) -> None:
        if self.jobs < 1:
            raise BadInput(f"--jobs: must be ≥ 1 (got {self.jobs})")
        if self.duration is not None:
            check_duration(self.duration)
        if self.quick and (self.seeds is not None or self.seed_set != "held-out" or self.tune or self.baselines):
            raise BadInput("--quick: a single-seed look at seed 0; --seeds, --seed-set, --tune and --baseline need the "
                           "seeded mode")
        if not self.quick and self.fresh:
            raise BadInput("--fresh: only with --quick (over seeds, finished rows are kept; use another --out)")
        if not self.quick:
            seed_set(self.seed_set, self.n_seeds)
        if self.publish is not None:
            if self.quick:
                raise BadInput("--publish: publishes verdicts over seeds; not with --quick")
            check_target(self.publish)

    @property
    def n_seeds(self) -> int:
        return 10 if self.seeds is None else self.seeds

    @property
    def seed_list(self) -> tuple[int, ...]:
        """The seeds this invocation runs: seed 0 for the quick look, else the seed set's first ``n_seeds``."""
        return (QUICK_SEED,) if self.quick else seed_set(self.seed_set, self.n_seeds)

    def command(self, out: Path) -> str:
        """The equivalent command line."""
        parts = ["ftc-mj paper", f"--out {out}", f"--jobs {self.jobs}"]
        parts += ["--quick"] if self.quick else [f"--seeds {self.n_seeds}", f"--seed-set {self.seed_set}"]
        parts += [f"--duration {self.duration:g}"] if self.duration is not None else []
        parts += [f"--only '{p}'" for p in self.only or []]
        parts += [flag for flag, on in (("--no-extras", not self.extras), ("--rrd runs", self.quick and self.rrd),
                                        ("--fresh", self.fresh), ("--report-only", self.report_only),
                                        ("--tune", self.tune)) if on]
        parts += [f"--baseline {b}" for b in self.baselines]
        parts += [f"--publish {self.publish}"] if self.publish is not None else []
        return " ".join(parts)


def check_duration(duration: float) -> None:
    """``--duration`` checked by the run config's own rule (a finite number in (0, 3600] s), before the
    matrix is written to a temporary study file that an error would otherwise name."""
    try:
        RunConfig.model_validate({"duration": duration})
    except ValidationError as err:
        raise BadInput(f"--duration: {one_line(err).removeprefix('duration: ')}") from None


@dataclass
class PaperResult:
    out: Path
    rows: list[dict[str, Any]]
    """Summary rows, one per run and seed."""
    claims: list[Claim]
    figures: list[Path] = field(default_factory=list)
    wall_time_s: float = 0.0
    """Wall time of the runs (s)."""
    report_time_s: float = 0.0
    """Wall time of summary, claims and figures (s)."""
    tuning: list[Any] = field(default_factory=list)
    """:class:`~ftc_mj.paper.tuning.TuningOutcome` s of ``--tune``."""
    computed: int = 0
    """Runs computed by this invocation (the others were reused)."""
    quick: bool = False
    published: list[Path] = field(default_factory=list)
    """Files ``--publish`` wrote (``paper-claims.md`` first, then the figures)."""

    @property
    def failed(self) -> list[str]:
        return [r["label"] + ("" if self.quick or r.get("seed") is None else f" (seed {r['seed']})")
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
    res = run_matrix_and_report(out, entries, opts, show, echo)
    write_json(out / "paper_run.json", run_info(out, opts, res, load0))
    return res


def check_target(docs: Path) -> None:
    """``docs`` must be an existing folder (:class:`BadInput` naming ``--publish`` otherwise)."""
    if not Path(docs).is_dir():
        raise BadInput(f"--publish: {docs} is not a directory (the docs folder that receives paper-claims.md "
                       "and figures/)")


def run_info(out: Path, opts: PaperOptions, res: PaperResult, load0: tuple[float, ...]) -> dict[str, Any]:
    """``paper_run.json``: the invocation, machine load (1/5/15-min averages) at start and end, wall
    times (s), tuning results and verdicts; ``--report-only`` keeps the run wall time and command of
    the invocation that computed the runs."""
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
    if opts.report_only and prev.is_file():
        try:
            before = json.loads(prev.read_text())
        except (OSError, ValueError):
            before = {}
        info["wall_time_s"] = before.get("wall_time_s")
        info["runs_command"] = before.get("runs_command") or (None if before.get("report_only")
                                                              else before.get("command"))
    info.setdefault("wall_time_s", res.wall_time_s)
    info["reused"] = len(res.rows) - res.computed
    return info


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


def summary_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Study rows as summary rows: ``label`` (the matrix label) first, the down-sampled series dropped."""
    return [{"label": r[AXIS], **{k: v for k, v in r.items() if k != AXIS and not k.startswith("ts_")}}
            for r in rows]


def _echo_rows(echo: Callable[[str], None] | None, total: int) -> Callable[[dict[str, Any]], None]:
    """A study ``on_row`` printing one line per finished run through ``echo``."""
    done = [0]

    def on_row(row: dict[str, Any]) -> None:
        done[0] += 1
        if echo is not None:
            err = f" — {row.get('error')}" if row.get("status") != "ok" else ""
            robot = f", robot {row['outcome']}" if row.get("outcome") else ""
            echo(f"[{done[0]}/{total}] {row.get(AXIS)} seed {row.get('seed')}: {row.get('status')}{robot} "
                 f"({row.get('task_wall_s') or float('nan'):.1f} s){err}")

    return on_row


def run_matrix_and_report(out: Path, entries: list[MatrixEntry], opts: PaperOptions, show: bool,
                          echo: Callable[[str], None] | None) -> PaperResult:
    """Run (or read back) the matrix on the invocation's seeds and write summary, claims and figures."""
    seeds = opts.seed_list
    baselines = [(b, load_baseline(b)) for b in opts.baselines]
    plan = load_matrix_study(entries, seeds, opts.duration, out, write=not opts.report_only)
    folder = plan.path.parent
    if opts.report_only and not (folder / "rows").is_dir():
        raise BadInput(f"--report-only: no {'quick-look' if opts.quick else 'seeded'} results for this selection "
                       f"in {folder}")
    if opts.fresh:
        shutil.rmtree(folder / "rows", ignore_errors=True)
    tuning = None
    if opts.tune:
        from .tuning import run_tuning

        tuning = run_tuning(out, n_seeds=min(opts.n_seeds, len(DEV_SEEDS)), duration=opts.duration,
                            workers=opts.jobs, progress=show, report_only=opts.report_only)
    t0 = time.perf_counter()
    res = run_matrix_study(plan, workers=opts.jobs, keep_seed=seeds[0], report_only=opts.report_only,
                           progress=show, on_row=None if show else _echo_rows(echo, len(plan.runs)),
                           runs_dir=out / "runs" if opts.quick else None, record=opts.quick and opts.rrd,
                           retry_failed=opts.quick, echo=echo)
    wall = time.perf_counter() - t0
    t1 = time.perf_counter()
    rows_by_seed = res.by_seed()
    claims = combine({s: evaluate_all(r) for s, r in rows_by_seed.items()}, single_seed=opts.quick)
    rows = summary_rows(res.rows)
    write_summary_csv(out / "summary.csv", rows)
    figs = _figures(out, rows_by_seed.get(seeds[0], {}), opts.jobs) if opts.figures else []
    doc = claims_document(claims, seeds, "single-seed" if opts.quick else "seeded")
    if not opts.quick:
        doc["seed_set"] = opts.seed_set
    changes = write_changes(out, doc, baselines)
    meta = {"duration": opts.duration, "wall_time_s": None if opts.report_only else wall, "jobs": opts.jobs,
            "computed": res.computed}
    note = "" if opts.quick else (f"Drawn from the runs of seed {seeds[0]} (one seed; the verdicts above use all "
                                  f"{len(seeds)}).")
    write_report(out, render_claims(claims, rows_by_seed, meta, tuning, changes, single_seed=opts.quick), doc, figs,
                 note)
    return PaperResult(out, rows, claims, figs, wall, time.perf_counter() - t1, tuning or [], res.computed,
                       opts.quick)


def write_changes(out: Path, doc: Mapping[str, Any], baselines: list[tuple[Path, dict[str, Any]]]
                  ) -> list[tuple[str, list[str]]]:
    """``changes.md``: what changed against each baseline (nothing written without one)."""
    changes = [(str(b), compare(doc, base)) for b, base in baselines]
    if changes:
        with atomic_path(out / "changes.md") as tmp:
            tmp.write_text("".join(f"## Against `{src}`\n\n" + ("\n".join(lines) or "- nothing") + "\n\n"
                                   for src, lines in changes))
    return changes


def write_report(out: Path, md: str, doc: dict[str, Any], figs: list[Path], figs_note: str = "") -> None:
    """``claims.md`` (with the figure list) and ``claims.json``, atomically."""
    if figs:
        links = "\n".join(f"- [`figures/{p.name}`](figures/{p.name})" for p in figs)
        md += "\n## Figures\n\n" + (figs_note + "\n\n" if figs_note else "") + links + "\n"
    with atomic_path(out / "claims.md") as tmp:
        tmp.write_text(md)
    write_json(out / "claims.json", doc)


def _figures(out: Path, rows: Mapping[str, Mapping[str, Any]], jobs: int) -> list[Path]:
    """The figures, drawn from the runs of the first seed (the only ones whose run directory is kept)."""
    from .figures import make_figures

    return make_figures({lb: (Path(r["run_dir"]) if r.get("run_dir") else None) for lb, r in rows.items()},
                        out / "figures", jobs=jobs)
