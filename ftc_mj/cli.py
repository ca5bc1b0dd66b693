"""The ``ftc-mj`` command line (DESIGN §6).

Exit codes: 0 success, 1 a run failed (reason recorded in its metrics), 2 bad input (one line on
stderr naming the problem, nothing written).
"""

from __future__ import annotations

import os
import sys
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer

from .errors import BadInput

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Active fault-tolerant control of a MuJoCo differential-drive robot.")


class EstimatorKind(StrEnum):
    ekf = "ekf"
    ukf = "ukf"
    imm_ekf = "imm-ekf"
    imm_ukf = "imm-ukf"
    none = "none"


class ReconfigPolicy(StrEnum):
    none = "none"
    direct = "direct"
    safe = "safe"
    truth = "truth"


class ControllerKind(StrEnum):
    nmpc = "nmpc"
    lmpc = "lmpc"
    open_loop = "open-loop"
    pf_nmpc = "pf-nmpc"


def _fail(msg: str, code: int = 2) -> None:
    typer.echo(f"ftc-mj: error: {msg}", err=True)
    raise typer.Exit(code)


def _overrides(items: list[str]) -> dict[str, Any]:
    from .config import parse_override

    out: dict[str, Any] = {}
    for it in items:
        k, v = parse_override(it)
        out[k] = v
    return out


@app.command()
def run(
    scenario: Annotated[str, typer.Argument(help="Built-in scenario (scenario1..scenario4) or a TOML file.")],
    estimator: Annotated[EstimatorKind | None, typer.Option(help="FDI filter.")] = None,
    imm_models: Annotated[int | None, typer.Option(help="IMM bank size: 4 or 5.")] = None,
    imm_variant: Annotated[str | None, typer.Option(help="IMM variant: hypothesis or paper.")] = None,
    reconfig: Annotated[ReconfigPolicy | None, typer.Option(
        help="Reconfiguration policy: none (nominal radii), direct (latest estimate, the paper's feedback), "
             "safe (gated, clamped, rate-limited hand-over; the default), truth (oracle).")] = None,
    feedback: Annotated[bool | None, typer.Option("--feedback/--no-feedback",
                                                  help="Aliases of --reconfig direct / --reconfig none.")] = None,
    controller: Annotated[ControllerKind | None, typer.Option(help="Tracking controller.")] = None,
    seed: Annotated[int | None, typer.Option(help="Random seed (noise).")] = None,
    duration: Annotated[float | None, typer.Option(help="Simulated time (s).")] = None,
    out: Annotated[Path | None, typer.Option(help="Output folder (default: output.dir of the config).")] = None,
    set_: Annotated[list[str] | None, typer.Option("--set", help="Override any config key: dotted.key=value.")] = None,
    no_rrd: Annotated[bool, typer.Option("--no-rrd", help="Do not write the Rerun recording.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar or summary table.")] = False,
) -> None:
    """Run one closed-loop simulation and write DIR/<run-id>/ (config.toml, trace.parquet,
    metrics.json, run.rrd)."""
    from .config import load_config

    try:
        ov = _overrides(set_ or [])
        if reconfig is not None and feedback is not None:
            raise BadInput("--feedback/--no-feedback: give either it or --reconfig, not both")
        for key, val in (("estimator.kind", estimator.value if estimator else None),
                         ("estimator.imm_models", imm_models), ("estimator.imm_variant", imm_variant),
                         ("feedback", feedback), ("reconfiguration.policy", reconfig.value if reconfig else None),
                         ("controller.kind", controller.value if controller else None),
                         ("seed", seed), ("duration", duration)):
            if val is not None:
                ov[key] = val
        cfg = load_config(scenario, ov)
    except BadInput as err:
        _fail(str(err))
        return
    out_root = out if out is not None else cfg.output.dir
    if out_root.exists() and not out_root.is_dir():
        _fail(f"--out: {out_root} exists and is not a directory")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from .sim.progress import run_with_progress
    from .sim.summary import print_run_summary

    show = cfg.output.progress and not quiet and sys.stderr.isatty()
    try:
        outcome = run_with_progress(cfg, out_root, rrd=not no_rrd and cfg.output.rrd, show=show)
    except BadInput as err:  # e.g. a model file that does not compile: nothing has been written
        _fail(str(err))
        return
    if not quiet:
        print_run_summary(outcome)
    if outcome.metrics["status"] != "ok":
        typer.echo(f"ftc-mj: run failed: {outcome.metrics['error']}", err=True)
        raise typer.Exit(1)


class RrdMode(StrEnum):
    none = "none"
    failures = "failures"
    all = "all"


@app.command()
def study(
    study_file: Annotated[Path, typer.Argument(help="Study file (runs/studies/*.toml).")],
    out: Annotated[Path | None, typer.Option(help="Study output folder (default: runs/out/studies/<name>).")] = None,
    workers: Annotated[int, typer.Option(help="Local worker processes (ignored with --address).")] = 2,
    address: Annotated[str | None, typer.Option(help="Existing dask scheduler, tcp://HOST:PORT.")] = None,
    rrd: Annotated[RrdMode, typer.Option(help="Per-run Rerun recordings: none, failures or all.")] = RrdMode.none,
    limit: Annotated[int | None, typer.Option(help="Compute at most N of the missing runs now.")] = None,
    seeds: Annotated[int | None, typer.Option(help="Replace the study's seed count (part of its identity).")] = None,
    set_: Annotated[list[str] | None, typer.Option("--set", help="Extra base override dotted.key=value "
                                                   "(part of the study's identity).")] = None,
    retry_failed: Annotated[bool, typer.Option("--retry-failed", help="Recompute runs whose row failed.")] = False,
    serial: Annotated[bool, typer.Option("--serial", help="Run in this process, without dask.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
) -> None:
    """Sweep a study on dask.distributed: every finished run is persisted at once under
    OUT/rows/; re-running the same command computes only the missing runs; OUT/results.parquet,
    OUT/summary.md and OUT/figures/ are written at the end."""
    from .study.runner import StudyInterruptedError, run_study, validate_address
    from .study.spec import load_study

    try:
        if address is not None:
            validate_address(address)
        if workers < 1:
            raise BadInput("--workers: must be >= 1")
        if limit is not None and limit < 0:
            raise BadInput("--limit: must be >= 0")
        plan = load_study(study_file, extra_overrides=_overrides(set_ or []), seeds=seeds)
        out_dir = out if out is not None else Path("runs/out/studies") / plan.spec.name
        report = run_study(plan, out_dir, workers=workers, address=address, serial=serial, rrd=rrd.value,
                           limit=limit, retry_failed=retry_failed, progress=not quiet and sys.stderr.isatty())
    except BadInput as err:
        _fail(str(err))
        return
    except StudyInterruptedError as err:
        typer.echo(f"ftc-mj: {err}", err=True)
        raise typer.Exit(130) from None
    done = report.already_done + len(report.computed)
    typer.echo(f"{plan.spec.name}: computed {len(report.computed)} runs ({len(report.failed)} failed) in "
               f"{report.wall_time_s:.1f} s; {done} of {report.planned} done; results in {out_dir}")


@app.command()
def view(run_dir: Annotated[Path, typer.Argument(help="A run directory (or a .rrd file).")]) -> None:
    """Open a run's Rerun recording in the Rerun viewer."""
    from .errors import RunFailed
    from .recorder import open_viewer

    try:
        open_viewer(run_dir)
    except BadInput as err:
        _fail(f"RUN_DIR: {err}")
    except RunFailed as err:
        _fail(str(err), code=1)


@app.command()
def paper(
    out: Annotated[Path, typer.Option(help="Output folder: runs/, summary.csv, claims.md, figures/.")] = Path(
        "runs/out/paper"),
    jobs: Annotated[int, typer.Option(help="Parallel worker processes.")] = 2,
    duration: Annotated[float | None, typer.Option(help="Shorten every run to this many seconds.")] = None,
    only: Annotated[list[str] | None, typer.Option("--only", help="Run only labels matching this glob "
                                                   "(repeatable), e.g. 's2-*' or 's4-imm-ukf5-*'.")] = None,
    extras: Annotated[bool, typer.Option("--extras/--no-extras",
                                         help="Add runs beyond the paper's 38: the literal 'paper' IMM (2) "
                                              "and the reconfiguration-policy axis (18).")] = True,
    no_rrd: Annotated[bool, typer.Option("--no-rrd", help="Do not write Rerun recordings.")] = False,
    fresh: Annotated[bool, typer.Option("--fresh", help="Recompute runs even if OUT/runs has them.")] = False,
    list_: Annotated[bool, typer.Option("--list", help="Print the matrix labels and exit.")] = False,
    report_only: Annotated[bool, typer.Option("--report-only", help="Run nothing: rebuild summary, claims and "
                                              "figures from the newest run of each label in OUT/runs.")] = False,
) -> None:
    """Run the paper's test matrix (38 runs + 20 extras) and write summary.csv, claims.md and figures/."""
    from .report.matrix import full_matrix, select

    if list_:
        for e in select(full_matrix(extras), only):
            typer.echo(f"{e.label}\t{e.scenario}\t" + " ".join(f"{k}={v}" for k, v in e.overrides.items()))
        return
    from .report.paper import run_paper

    try:
        res = run_paper(out, jobs=jobs, duration=duration, only=only, extras=extras, rrd=not no_rrd, fresh=fresh,
                        echo=lambda s: typer.echo(s, err=True), report_only=report_only)
    except BadInput as err:
        _fail(str(err))
        return
    except KeyboardInterrupt:
        typer.echo("ftc-mj: interrupted; finished runs are kept and reused next time", err=True)
        raise typer.Exit(130) from None
    typer.echo(f"{len(res.rows)} runs in {res.wall_time_s:.1f} s (report {res.report_time_s:.1f} s) → {res.out}")
    for c in res.claims:
        typer.echo(f"  claim {c.id:>2}: {c.verdict:<15} {c.title}")
    if res.failed:
        typer.echo(f"ftc-mj: {len(res.failed)} run(s) failed: {', '.join(res.failed)}", err=True)
        raise typer.Exit(1)


@app.command()
def scenarios() -> None:
    """List the built-in scenarios."""
    from .config import BUILTIN_SCENARIOS, load_config

    for name in BUILTIN_SCENARIOS:
        typer.echo(f"{name}: {load_config(name).description}")


def main() -> None:  # pragma: no cover - console entry point
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
