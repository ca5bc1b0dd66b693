"""The ``ftc-mj`` command line.

Exit codes (:mod:`ftc_mj.errors`): 0 success; 1 a run failed (its reason is in ``metrics.json``) or
its output could not be written; 2 bad input — one line ``ftc-mj: error: …`` on stderr naming the
option or field, nothing written (also for the usage errors click detects itself: an unknown option,
a bad choice, ``--seed abc``); 3 the physics of the run became unstable (status ``unstable``);
130 interrupted.
"""

from __future__ import annotations

import os
import sys
import tempfile
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer
from typer.core import TyperGroup

from .errors import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_UNSTABLE, BadInput, RunFailed


class OneLineErrorGroup(TyperGroup):
    """The command group: usage errors (those click detects too) become one line on stderr with exit
    code 2 instead of a boxed panel with a usage header; Ctrl-C one line with exit code 130."""

    def main(self, args: Any = None, prog_name: str | None = None, complete_var: str | None = None,
             standalone_mode: bool = True, **extra: Any) -> Any:
        try:
            rv = super().main(args=args, prog_name=prog_name, complete_var=complete_var, standalone_mode=False,
                              **extra)
            code = rv if isinstance(rv, int) else 0
            if code == EXIT_INTERRUPTED:  # a Ctrl-C no command handled (typer maps it to exit 130)
                typer.echo("ftc-mj: interrupted", err=True)
        except typer.Abort as err:  # raised by _interrupted with its line
            typer.echo(f"ftc-mj: {str(err) or 'interrupted'}", err=True)
            code = EXIT_INTERRUPTED
        except typer.TyperException as err:  # click's usage errors (exit code 2) and other command-line errors
            fmt = getattr(err, "format_message", None)
            msg = " ".join((fmt() if callable(fmt) else str(err)).split())
            code = int(getattr(err, "exit_code", EXIT_FAILED))
            ctx = getattr(err, "ctx", None)
            hint = f" (see '{ctx.command_path} --help')" if code == EXIT_BAD_INPUT and ctx is not None else ""
            typer.echo(f"ftc-mj: error: {msg}{hint}", err=True)
        if not standalone_mode:
            return code
        sys.exit(code)


app = typer.Typer(add_completion=False, pretty_exceptions_enable=False, cls=OneLineErrorGroup,
                  rich_markup_mode=None, help="Active fault-tolerant control of a MuJoCo differential-drive robot.")


@app.callback(invoke_without_command=True)
def _top(ctx: typer.Context) -> None:
    """Active fault-tolerant control of a MuJoCo differential-drive robot.

    Exit codes: 0 success; 1 a run failed or could not be written; 2 bad input (one line naming the
    option or field, nothing written); 3 the physics of a run became unstable; 130 interrupted.
    """
    if ctx.invoked_subcommand is None:
        typer.echo(ctx.get_help())


class EstimatorKind(StrEnum):
    ekf = "ekf"
    ukf = "ukf"
    imm_ekf = "imm-ekf"
    imm_ukf = "imm-ukf"
    none = "none"


class ImmModels(StrEnum):
    four = "4"
    five = "5"


class ImmVariant(StrEnum):
    hypothesis = "hypothesis"
    paper = "paper"


class ReconfigPolicy(StrEnum):
    none = "none"
    direct = "direct"
    safe = "safe"
    truth = "truth"


class ControllerKind(StrEnum):
    nmpc = "nmpc"
    lmpc = "lmpc"
    open_loop = "open-loop"


def _fail(msg: str, code: int = EXIT_BAD_INPUT) -> None:
    typer.echo(f"ftc-mj: error: {' '.join(str(msg).split())}", err=True)
    raise typer.Exit(code)


def _interrupted(msg: str = "interrupted") -> None:
    """End the command after a Ctrl-C with one line (printed by :class:`OneLineErrorGroup`), exit 130."""
    raise typer.Abort(msg)


def _overrides(items: list[str]) -> dict[str, Any]:
    from .config import parse_override

    out: dict[str, Any] = {}
    for it in items:
        k, v = parse_override(it)
        out[k] = v
    return out


def _folder(value: str | None, option: str = "--out") -> Path | None:
    """A folder option as a Path; an empty value is refused (``Path("")`` would be the working directory)."""
    if value is None:
        return None
    if not value.strip() or "\0" in value:
        raise BadInput(f"{option}: expected a folder path, got {value!r} (use '.' for the current folder)")
    return Path(value)


def _defaults() -> Any:
    from .config import RunConfig

    return RunConfig()


_D = _defaults()


def _flag_overrides(ov: dict[str, Any], flags: list[tuple[str, str, Any]]) -> dict[str, Any]:
    """Add each given flag's value under its config key; a ``--set`` of the same key with another value is
    a contradiction (BadInput naming the flag)."""
    for flag, key, val in flags:
        if val is None:
            continue
        if key in ov and ov[key] != val:
            raise BadInput(f"{flag}: {val!r} contradicts --set {key}={ov[key]!r}")
        ov[key] = val
    return ov


@app.command()
def run(
    scenario: Annotated[str, typer.Argument(help="Built-in scenario (scenario1..scenario4) or a TOML file.",
                                            metavar="SCENARIO", show_default=False)],
    estimator: Annotated[EstimatorKind | None, typer.Option(
        help=f"FDI filter. [default: the scenario's estimator.kind, else {_D.estimator.kind}]")] = None,
    imm_models: Annotated[ImmModels | None, typer.Option(
        help=f"IMM bank size (imm-ekf/imm-ukf only). [default: {_D.estimator.imm_models}]")] = None,
    imm_variant: Annotated[ImmVariant | None, typer.Option(
        help=f"IMM variant (imm-ekf/imm-ukf only). [default: {_D.estimator.imm_variant}]")] = None,
    reconfig: Annotated[ReconfigPolicy | None, typer.Option(
        help="Reconfiguration policy: none (nominal radii), direct (latest estimate, the paper's feedback), "
             "safe (gated, clamped, rate-limited hand-over), truth (oracle). "
             f"[default: the scenario's reconfiguration.policy, else {_D.reconfiguration.policy}]")] = None,
    feedback: Annotated[bool | None, typer.Option("--feedback/--no-feedback",
                                                  help="Aliases of --reconfig direct / --reconfig none.",
                                                  show_default=False)] = None,
    controller: Annotated[ControllerKind | None, typer.Option(
        help=f"Tracking controller. [default: the scenario's controller.kind, else {_D.controller.kind}]")] = None,
    seed: Annotated[int | None, typer.Option(help=f"Random seed of the noise. [default: {_D.seed}]")] = None,
    duration: Annotated[float | None, typer.Option(
        help=f"Simulated time (s), at most 3600. [default: the scenario's, else {_D.duration:g}]")] = None,
    out: Annotated[str | None, typer.Option(help=f"Output folder. [default: output.dir, {_D.output.dir}]",
                                            show_default=False)] = None,
    set_: Annotated[list[str] | None, typer.Option("--set", help="Override any config key: dotted.key=value "
                                                   "(the value is read as TOML, else as a string).")] = None,
    no_rrd: Annotated[bool, typer.Option("--no-rrd", help="Do not write the Rerun recording.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar or summary table (the run folder "
                                                              "is still printed).")] = False,
) -> None:
    """Run one closed-loop simulation and write OUT/<run-id>/ (config.toml, trace.parquet,
    metrics.json, run.rrd).

    Exit codes: 0 ok; 1 the run failed (reason in metrics.json) or could not be written; 2 bad input
    (one line naming the field, nothing written); 3 the physics became unstable (status unstable: the
    robot froze where MuJoCo's state blew up, so its metrics are not results).
    """
    from .config import load_config

    try:
        ov = _overrides(set_ or [])
        if reconfig is not None and feedback is not None:
            raise BadInput("--feedback/--no-feedback: give either it or --reconfig, not both")
        _flag_overrides(ov, [
            ("--estimator", "estimator.kind", estimator.value if estimator else None),
            ("--imm-models", "estimator.imm_models", int(imm_models.value) if imm_models else None),
            ("--imm-variant", "estimator.imm_variant", imm_variant.value if imm_variant else None),
            ("--feedback/--no-feedback", "feedback", feedback),
            ("--reconfig", "reconfiguration.policy", reconfig.value if reconfig else None),
            ("--controller", "controller.kind", controller.value if controller else None),
            ("--seed", "seed", seed), ("--duration", "duration", duration)])
        cfg = load_config(scenario, ov)
        if not cfg.estimator.kind.startswith("imm"):
            for flag, key in (("--imm-models", "estimator.imm_models"), ("--imm-variant", "estimator.imm_variant")):
                if key in ov:
                    raise BadInput(f"{flag}: only for the imm-ekf and imm-ukf estimators (estimator.kind is "
                                   f"{cfg.estimator.kind!r})")
        out_root = _folder(out) or cfg.output.dir
    except BadInput as err:
        _fail(str(err))
        return
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from .sim.progress import run_with_progress
    from .sim.summary import print_run_summary

    show = cfg.output.progress and not quiet and sys.stderr.isatty()
    try:
        outcome = run_with_progress(cfg, out_root, rrd=not no_rrd and cfg.output.rrd, show=show)
    except BadInput as err:  # an unwritable --out, a model MuJoCo cannot simulate: nothing has been written
        _fail(str(err))
        return
    except RunFailed as err:  # the results could not be written (nothing was kept)
        _fail(str(err), EXIT_FAILED)
        return
    except KeyboardInterrupt:
        _interrupted("interrupted; nothing of this run was written")
        return
    if quiet:
        typer.echo(str(outcome.run_dir))
    else:
        print_run_summary(outcome, cfg.reconfiguration.max_sigma)
    status = outcome.metrics["status"]
    if status == "unstable":
        typer.echo(f"ftc-mj: physics unstable: {outcome.metrics['error']}", err=True)
        raise typer.Exit(EXIT_UNSTABLE)
    if status != "ok":
        typer.echo(f"ftc-mj: run failed: {outcome.metrics['error']}", err=True)
        raise typer.Exit(EXIT_FAILED)


class StudyRrd(StrEnum):
    none = "none"
    failures = "failures"
    all = "all"
    compare = "compare"


@app.command()
def study(
    study_file: Annotated[str, typer.Argument(help="Study file (runs/studies/*.toml).", metavar="STUDY_FILE",
                                              show_default=False)],
    out: Annotated[str | None, typer.Option(help="Study output folder. [default: runs/out/studies/<name>]",
                                            show_default=False)] = None,
    workers: Annotated[int, typer.Option(help="Local worker processes (ignored with --address).")] = 2,
    address: Annotated[str | None, typer.Option(
        help="Existing dask scheduler, tcp://HOST:PORT. Use only a scheduler you trust: it receives the run "
             "configs and its workers run code as their user. It must answer within 10 s.")] = None,
    dashboard: Annotated[str, typer.Option(help="Dask dashboard of the local cluster, HOST:PORT (port 0 = any free "
                                                "port); 127.0.0.1 = this machine only.")] = "127.0.0.1:0",
    rrd: Annotated[StudyRrd, typer.Option(help="Per-run folders with recordings under OUT/runs: none, failures, all; "
                                               "compare = all, plus OUT/compare.rrd overlaying the runs.")
                   ] = StudyRrd.none,
    limit: Annotated[int | None, typer.Option(help="Compute at most N of the missing runs now, chosen to cover "
                                                   "every axis value first (the rest on a later call).")] = None,
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
    from .config import existing_file
    from .study.runner import StudyInterruptedError, run_study, validate_address, validate_dashboard
    from .study.spec import load_study

    try:
        path = existing_file(study_file, "STUDY_FILE")
        if address is not None:
            validate_address(address)
        validate_dashboard(dashboard)
        if workers < 1:
            raise BadInput("--workers: must be >= 1")
        if limit is not None and limit < 0:
            raise BadInput("--limit: must be >= 0")
        plan = load_study(path, extra_overrides=_overrides(set_ or []), seeds=seeds)
        out_dir = _folder(out) or Path("runs/out/studies") / plan.spec.name
        report = run_study(plan, out_dir, workers=workers, address=address, serial=serial, rrd=rrd.value,
                           limit=limit, retry_failed=retry_failed, progress=not quiet and sys.stderr.isatty(),
                           dashboard=dashboard, echo=lambda s: typer.echo(f"ftc-mj: {s}", err=True))
    except BadInput as err:
        _fail(str(err))
        return
    except (StudyInterruptedError, KeyboardInterrupt) as err:
        _interrupted(str(err) if isinstance(err, StudyInterruptedError) else "interrupted")
        return
    done = report.already_done + len(report.computed)
    n_bad = len(report.failed) - len(report.unstable)
    typer.echo(f"{plan.spec.name}: computed {len(report.computed)} runs ({n_bad} failed, {len(report.unstable)} "
               f"with unstable physics) in {report.wall_time_s:.1f} s; {done} of {report.planned} done; "
               f"results in {out_dir}")


@app.command()
def view(run_dirs: Annotated[list[str], typer.Argument(
        help="A run directory (or a .rrd file); several run directories open their comparison.",
        metavar="RUN_DIR...", show_default=False)]) -> None:
    """Open a run's Rerun recording in the Rerun viewer, or the comparison of several runs."""
    from .recorder import check_display, check_recording, open_viewer

    try:
        if len(run_dirs) == 1:
            rrd = check_recording(Path(run_dirs[0]))
            check_display(f"docs/screenshot.sh {rrd} OUT.png")
            open_viewer(rrd)
            return
        from .comparison import load_runs

        load_runs(run_dirs)  # bad input first: exit 2 before anything else
        check_display(f"ftc-mj compare {' '.join(run_dirs)} --out compare.rrd && "
                      "docs/screenshot.sh compare.rrd OUT.png")
        with tempfile.TemporaryDirectory(prefix="ftc-mj-view.") as tmp:
            rrd = _compare(run_dirs, Path(tmp) / "comparison.rrd", None)
            open_viewer(rrd)
    except BadInput as err:
        _fail(str(err))
    except RunFailed as err:
        _fail(str(err), code=EXIT_FAILED)


def _compare(run_dirs: list[str], out: Path, labels: list[str] | None) -> Path:
    from .comparison import write_comparison

    return write_comparison([Path(d) for d in run_dirs], out, labels)


def _labels(values: list[str] | None, n: int) -> list[str] | None:
    """``--labels``: repeated, or one comma-separated value for several runs."""
    if not values:
        return None
    if len(values) == 1 and n > 1:
        return [v.strip() for v in values[0].split(",")]
    return list(values)


@app.command()
def compare(
    run_dirs: Annotated[list[str], typer.Argument(help="Run directories (OUT/<run-id>/ of ftc-mj run).",
                                                  metavar="RUN_DIR...", show_default=False)],
    out: Annotated[str, typer.Option(help="The comparison recording to write (.rrd).")] = "compare.rrd",
    labels: Annotated[list[str] | None, typer.Option(
        "--labels", help="One label per run (repeat the option, or one comma-separated value). [default: the "
                         "settings that differ between the runs]", show_default=False)] = None,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace an existing OUT file.")] = False,
) -> None:
    """Write one Rerun recording overlaying several runs: each under /runs/<label>/ on a shared sim_time
    timeline, with a blueprint that plots them together (trajectories, radii, cross-track error, wheel
    rates, IMM mode probabilities, reconfiguration state; legend by run label)."""
    from .sim.run import check_output_root

    try:
        target = _folder(out, "--out")
        assert target is not None
        if target.suffix != ".rrd":
            raise BadInput(f"--out: {out}: the file name must end in .rrd")
        if target.is_dir():
            raise BadInput(f"--out: {out} is a folder; give a file name ending in .rrd")
        if target.exists() and not overwrite:
            raise BadInput(f"--out: {out} exists (give another name, or --overwrite)")
        from .comparison import load_runs

        load_runs(run_dirs, _labels(labels, len(run_dirs)))  # every input checked before writing
        check_output_root(target.parent if str(target.parent) else Path("."), target.name)
        path = _compare(run_dirs, target, _labels(labels, len(run_dirs)))
    except BadInput as err:
        _fail(str(err))
        return
    except OSError as err:
        _fail(f"cannot write {out}: {err.strerror or err}", EXIT_FAILED)
        return
    typer.echo(str(path))


class PaperRrd(StrEnum):
    runs = "runs"
    none = "none"
    compare = "compare"


@app.command()
def paper(
    out: Annotated[str, typer.Option(help="Output folder: runs/, summary.csv, claims.md, figures/.")
                   ] = "runs/out/paper",
    jobs: Annotated[int, typer.Option(help="Parallel worker processes.")] = 2,
    duration: Annotated[float | None, typer.Option(help="Shorten every run to this many seconds.")] = None,
    only: Annotated[list[str] | None, typer.Option("--only", help="Run only labels matching this glob "
                                                   "(repeatable), e.g. 's2-*' or 's4-imm-ukf5-*'.")] = None,
    extras: Annotated[bool, typer.Option("--extras/--no-extras",
                                         help="Add runs beyond the paper's 38: the literal 'paper' IMM (2) "
                                              "and the reconfiguration-policy axis (18).")] = True,
    rrd: Annotated[PaperRrd, typer.Option(help="Recordings: runs (one per run), none, or compare (also "
                                               "OUT/compare/claim-<id>.rrd overlaying each claim's runs).")
                   ] = PaperRrd.runs,
    no_rrd: Annotated[bool, typer.Option("--no-rrd", help="Same as --rrd none.")] = False,
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
    from .io import remove_stale_temporaries
    from .report.paper import run_paper

    try:
        if no_rrd and rrd != PaperRrd.runs and rrd != PaperRrd.none:
            raise BadInput(f"--no-rrd: contradicts --rrd {rrd.value}")
        mode = PaperRrd.none if no_rrd else rrd
        out_dir = _folder(out)
        assert out_dir is not None
        for d in (out_dir, out_dir / "runs", out_dir / "figures", out_dir / "compare"):
            remove_stale_temporaries(d)
        res = run_paper(out_dir, jobs=jobs, duration=duration, only=only, extras=extras, rrd=mode != PaperRrd.none,
                        fresh=fresh, echo=lambda s: typer.echo(s, err=True), report_only=report_only)
        compared = _claim_comparisons(res, out_dir / "compare") if mode == PaperRrd.compare else []
    except BadInput as err:
        _fail(str(err))
        return
    except KeyboardInterrupt:
        _interrupted("interrupted; finished runs are kept and reused next time")
        return
    typer.echo(f"{len(res.rows)} runs in {res.wall_time_s:.1f} s (report {res.report_time_s:.1f} s) → {res.out}")
    for c in res.claims:
        typer.echo(f"  claim {c.id:>2}: {c.verdict:<15} {c.title}")
    for p in compared:
        typer.echo(f"  comparison: {p}")
    if res.failed:
        typer.echo(f"ftc-mj: {len(res.failed)} run(s) failed: {', '.join(res.failed)}", err=True)
        raise typer.Exit(EXIT_FAILED)


def _claim_comparisons(res: Any, out_dir: Path) -> list[Path]:
    from .comparison import claim_run_dirs, write_comparison

    paths = []
    for claim_id, labels, dirs in claim_run_dirs(res.claims, res.rows):
        if len(dirs) >= 2:
            paths.append(write_comparison(dirs, out_dir / f"claim-{claim_id}.rrd", labels,
                                          recording_id=f"claim-{claim_id}"))
    return paths


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
