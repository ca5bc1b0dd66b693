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
from typer.core import TyperCommand, TyperGroup

from .errors import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_UNSTABLE, BadInput, RunFailed

# Import laziness (start-up): no command renders, so MuJoCo is imported without its OpenGL context (its glfw
# bindings, ≈ 0.2 s) unless the user chose one in MUJOCO_GL.
os.environ.setdefault("MUJOCO_GL", "disable")

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



class RegistryHelpCommand(TyperCommand):
    """A command whose option help names the registered components: the tokens ``{estimators}``,
    ``{decision_rules}``, ``{controllers}``, ``{policies}`` and ``{references}`` in an option's help are
    replaced by the registry's names when the help is shown (loading the registries imports the
    components, about a second, so not at import)."""

    def format_help(self, ctx: Any, formatter: Any) -> None:
        from .registry import REGISTRIES

        for param in self.params:
            text = getattr(param, "help", None)
            if text and "{" in text:
                for name, reg in REGISTRIES.items():
                    text = text.replace("{" + name + "}", ", ".join(reg.names()))
                param.help = text  # type: ignore[attr-defined]
        super().format_help(ctx, formatter)


app = typer.Typer(add_completion=False, pretty_exceptions_enable=False, cls=OneLineErrorGroup,
                  rich_markup_mode=None, help="Active fault-tolerant control of a MuJoCo differential-drive robot.")


def _version(value: bool) -> None:
    if value:
        from . import __version__

        typer.echo(f"ftc-mj {__version__}")
        raise typer.Exit(0)


@app.callback(invoke_without_command=True)
def _top(ctx: typer.Context, version: Annotated[bool, typer.Option(
        "--version", callback=_version, is_eager=True, help="Print the version and exit.")] = False) -> None:
    """Active fault-tolerant control of a MuJoCo differential-drive robot.

    Exit codes: 0 success; 1 a run failed or could not be written; 2 bad input (one line naming the
    option or field, nothing written); 3 the physics of a run became unstable; 130 interrupted.
    """
    if ctx.invoked_subcommand is None:
        typer.echo(ctx.get_help())


class ImmModels(StrEnum):
    four = "4"
    five = "5"


class ImmVariant(StrEnum):
    hypothesis = "hypothesis"
    paper = "paper"


PLUGIN_HELP = ("Module to import first (repeatable): the estimators, decision rules, controllers, policies and "
               "references it registers can then be named; added to the config's plugins (Dask workers import it "
               "too).")
Plugins = Annotated[list[str] | None, typer.Option("--plugin", metavar="MODULE", help=PLUGIN_HELP)]


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


def _imm_default(key: str) -> Any:
    """The default of an IMM bank's setting ``key`` (the ``[estimator]`` section of an IMM kind only)."""
    from .estimation.imm import IMMSettings

    return IMMSettings.model_fields[key].default


def _named_by_flag(err: BadInput, flags: list[tuple[str, str, Any]]) -> BadInput:
    """``err`` about a config key that a given flag set, reworded to name the flag."""
    msg = str(err)
    for flag, key, val in flags:
        if val is not None and msg.startswith(f"{key}: "):
            return BadInput(f"{flag}: {msg[len(key) + 2:]}")
    return err


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


@app.command(cls=RegistryHelpCommand)
def run(
    scenario: Annotated[str, typer.Argument(help="Built-in scenario (scenario1..scenario4) or a TOML file.",
                                            metavar="SCENARIO", show_default=False)],
    estimator: Annotated[str | None, typer.Option(
        metavar="NAME", help="FDI filter, a registered estimator: {estimators} (or a plug-in's, with --plugin). "
             f"[default: the scenario's estimator.kind, else {_D.estimator.kind}]")] = None,
    imm_models: Annotated[ImmModels | None, typer.Option(
        help=f"IMM bank size (imm-ekf/imm-ukf only). [default: {_imm_default('imm_models')}]")] = None,
    imm_variant: Annotated[ImmVariant | None, typer.Option(
        help=f"IMM variant (imm-ekf/imm-ukf only). [default: {_imm_default('imm_variant')}]")] = None,
    reconfig: Annotated[str | None, typer.Option(
        metavar="NAME", help="Reconfiguration policy, registered: {policies} (none: nominal radii; direct: "
             "the latest estimate, the paper's feedback; safe: gated, clamped, rate-limited hand-over; truth: "
             f"oracle). [default: the scenario's reconfiguration.policy, else {_D.reconfiguration.policy}]")] = None,
    feedback: Annotated[bool | None, typer.Option("--feedback/--no-feedback",
                                                  help="Aliases of --reconfig direct / --reconfig none.",
                                                  show_default=False)] = None,
    controller: Annotated[str | None, typer.Option(
        metavar="NAME", help="Tracking controller, registered: {controllers}. "
             f"[default: the scenario's controller.kind, else {_D.controller.kind}]")] = None,
    seed: Annotated[int | None, typer.Option(help=f"Random seed of the noise. [default: {_D.seed}]")] = None,
    duration: Annotated[float | None, typer.Option(
        help=f"Simulated time (s), at most 3600. [default: the scenario's, else {_D.duration:g}]")] = None,
    out: Annotated[str | None, typer.Option(help=f"Output folder. [default: output.dir, {_D.output.dir}]",
                                            show_default=False)] = None,
    set_: Annotated[list[str] | None, typer.Option("--set", help="Override any config key: dotted.key=value "
                                                   "(the value is read as TOML, else as a string).")] = None,
    name: Annotated[str | None, typer.Option(
        metavar="NAME", help="Name of the run (config key name): its folder, the run id, is NAME_<estimator>_"
                             "<controller>_<policy>_s<seed>_<hash>, so name what differs between runs, e.g. "
                             "--name gyro-0.05. [default: the scenario's name]")] = None,
    plugin: Plugins = None,
    no_rrd: Annotated[bool, typer.Option("--no-rrd", help="Do not write the Rerun recording.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar or summary table (the run folder "
                                                              "is still printed).")] = False,
) -> None:
    """Run one closed-loop simulation and write OUT/<run-id>/ (config.toml, trace.parquet,
    metrics.json with metrics.schema.json, events.json, run.rrd).

    Exit codes: 0 the run completed (whatever the robot did: the first lines of the summary and
    metrics.json's outcome say on the path, off the path or tipped over); 1 the run failed (reason in
    metrics.json) or could not be written; 2 bad input
    (one line naming the field, nothing written); 3 the physics became unstable (status unstable: the
    robot froze where MuJoCo's state blew up, so its metrics are not results).
    """
    from . import api

    flags = [
        ("--estimator", "estimator.kind", estimator),
        ("--imm-models", "estimator.imm_models", int(imm_models.value) if imm_models else None),
        ("--imm-variant", "estimator.imm_variant", imm_variant.value if imm_variant else None),
        ("--feedback/--no-feedback", "feedback", feedback),
        ("--reconfig", "reconfiguration.policy", reconfig),
        ("--controller", "controller.kind", controller),
        ("--seed", "seed", seed), ("--duration", "duration", duration), ("--name", "name", name)]
    try:
        ov = _overrides(set_ or [])
        if reconfig is not None and feedback is not None:
            raise BadInput("--feedback/--no-feedback: give either it or --reconfig, not both")
        cfg = _run_config(scenario, ov, flags, plugin or [])
        out_root = _folder(out) or cfg.output.dir
    except BadInput as err:
        _fail(str(err))
        return
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    show = cfg.output.progress and not quiet and sys.stderr.isatty()
    try:
        outcome = api.simulate_run(cfg, out_root, rrd=not no_rrd and cfg.output.rrd, progress=show)
    except BadInput as err:  # an unwritable --out, a model MuJoCo cannot simulate: nothing has been written
        _fail(str(err))
        return
    except RunFailed as err:  # the results could not be written (nothing was kept)
        _fail(str(err), EXIT_FAILED)
        return
    except KeyboardInterrupt:
        _interrupted("interrupted; nothing of this run was written")
        return
    _report_run(outcome, cfg, quiet, scenario)


def _run_config(scenario: str, ov: dict[str, Any], flags: list[tuple[str, str, Any]], plugins: list[str]) -> Any:
    """The config of ``ftc-mj run``: the scenario, the ``--set`` overrides ``ov`` and the flags' values (a
    flag contradicting a ``--set`` is an error); a :class:`BadInput` about a key a flag set names the flag."""
    from . import api

    _flag_overrides(ov, flags)
    try:
        cfg = api.load_config(scenario, ov, plugins=plugins)
    except BadInput as err:
        raise _named_by_flag(err, [*flags, ("--plugin", "plugins", plugins or None)]) from None
    if not cfg.estimator.kind.startswith("imm"):
        for flag, key in (("--imm-models", "estimator.imm_models"), ("--imm-variant", "estimator.imm_variant")):
            if key in ov:
                raise BadInput(f"{flag}: not a setting of estimator {cfg.estimator.kind!r} (a setting of imm-ekf, "
                               "imm-ukf)")  # as the config words it for a value away from the default
    return cfg


def _report_run(outcome: Any, cfg: Any, quiet: bool, scenario: str) -> None:
    """Print the run folder (``-q``) or the summary table; exit 3 for unstable physics, 1 for a failed run."""
    if quiet:
        typer.echo(str(outcome.run_dir))
    else:
        from .sim.summary import print_run_summary

        print_run_summary(outcome, cfg.reconfiguration.max_sigma, scenario, 1.0 / cfg.estimator.rate, cfg.sensors)
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
    study_file: Annotated[str, typer.Argument(help="Built-in study name (see 'ftc-mj studies') or a study TOML file.",
                                              metavar="STUDY_FILE",
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
    plugin: Plugins = None,
    set_: Annotated[list[str] | None, typer.Option("--set", help="Extra base override dotted.key=value "
                                                   "(part of the study's identity).")] = None,
    retry_failed: Annotated[bool, typer.Option("--retry-failed", help="Recompute runs whose row failed.")] = False,
    serial: Annotated[bool, typer.Option("--serial", help="Run in this process, without dask.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    list_: Annotated[bool, typer.Option("--list", help="Runs nothing: print the plan (one run a line: index, key, "
                                                       "axis labels, seed) and exit.")] = False,
    report: Annotated[bool, typer.Option("--report", help="Runs nothing: print the study's published docs tables "
                                                          "from its output folder (also OUT/doc_tables.md); "
                                                          "pathfollow_figure draws OUT/figures/pathfollow.png.")
                      ] = False,
) -> None:
    """Sweep a study on dask.distributed: every finished run is persisted at once under
    OUT/rows/; re-running the same command computes only the missing runs; OUT/results.parquet,
    OUT/summary.md and OUT/figures/ are written at the end. With --report, the published tables of
    docs/ from a finished output folder instead. One process writes an output folder at a time: a second
    study or bench on it exits 2 at once."""
    from .api import plan_study, run_study
    from .study.cluster import validate_address, validate_dashboard
    from .study.plan import study_path
    from .study.runner import StudyInterruptedError

    try:
        path = study_path(study_file)
        if address is not None:
            validate_address(address)
        validate_dashboard(dashboard)
        if workers < 1:
            raise BadInput("--workers: must be >= 1")
        if limit is not None and limit < 0:
            raise BadInput("--limit: must be >= 0")
        plan = plan_study(path, overrides=_overrides(set_ or []), seeds=seeds, plugins=plugin or [])
        if list_:
            from .study.listing import plan_lines

            typer.echo("\n".join(plan_lines(plan)))
            return
        out_dir = _folder(out) or Path("runs/out/studies") / plan.spec.name
        if report:
            _print_doc_tables(plan.spec.name, out_dir)
            return
        outcome = run_study(plan, out_dir, workers=workers, address=address, serial=serial, rrd=rrd.value,
                            limit=limit, retry_failed=retry_failed, progress=not quiet and sys.stderr.isatty(),
                            dashboard=dashboard, echo=lambda s: typer.echo(f"ftc-mj: {s}", err=True)).report
    except (BadInput, StudyInterruptedError, KeyboardInterrupt) as err:
        _end_study(err)
        return
    except Exception as err:  # noqa: BLE001 - re-raised unless the results could not be written
        _output_failed(err)
    done = outcome.already_done + len(outcome.computed)
    n_bad = len(outcome.failed) - len(outcome.unstable)
    typer.echo(f"{plan.spec.name}: computed {len(outcome.computed)} runs ({n_bad} failed, {len(outcome.unstable)} "
               f"with unstable physics) in {outcome.wall_time_s:.1f} s; {done} of {outcome.planned} done; "
               f"results in {out_dir}")
    if outcome.computed:
        typer.echo(f"{plan.spec.name}: outcomes of the computed runs: {outcome_counts(outcome.outcomes)}")


def _end_study(err: BaseException) -> None:
    """End ``ftc-mj study`` / ``bench`` after bad input (one line, exit 2) or an interruption (one line, 130;
    every finished run is persisted)."""
    if isinstance(err, BadInput):
        _fail(str(err))
    _interrupted(str(err) if not isinstance(err, KeyboardInterrupt) else "interrupted")


def _output_failed(err: Exception) -> None:
    """End ``ftc-mj study`` / ``bench`` whose results could not be written (a full disk: ``OSError``, or
    polars' and pyarrow's own errors saying so; :class:`RunFailed`) with one line and exit 1 (every run
    persisted before is kept); re-raise anything else."""
    from .io import output_failure

    why = str(err) if isinstance(err, RunFailed) else output_failure(err)
    if why is None:
        raise err
    _fail(why, EXIT_FAILED)


def outcome_counts(counts: dict[str, int]) -> str:
    """``"3 on the path, 1 TIPPED OVER"``: the runs per physical outcome, best first, those that did not hold
    the path in capitals."""
    from .metrics.outcome import OUTCOMES

    order = [*OUTCOMES, *sorted(set(counts) - set(OUTCOMES))]
    return ", ".join(f"{counts[k]} {k if k == 'on the path' else k.upper()}" for k in order if counts.get(k))


def _print_doc_tables(name: str, out_dir: Path) -> None:
    """Print the published tables of study ``name`` from ``out_dir`` and write them to OUT/doc_tables.md."""
    from .io import atomic_path
    from .reports.doc_tables import doc_tables

    text = doc_tables(name, out_dir)
    with atomic_path(out_dir / "doc_tables.md") as tmp:
        tmp.write_text(text)
    typer.echo(text, nl=False)


@app.command("fdi-curves")
def fdi_curves(
    study_dir: Annotated[Path, typer.Argument(help="Output folder of a finished study with no-fault and fault runs.")],
    out: Annotated[Path | None, typer.Option(help="Output folder (default: STUDY_DIR/fdi).")] = None,
    fault_axis: Annotated[str, typer.Option(help="Study axis that sets the fault (its no-fault runs have no onset).")]
    = "severity",
    horizon: Annotated[float, typer.Option(help="Detection horizon (s) of the ROC.")] = 2.0,
    arl0: Annotated[float, typer.Option(help="Mean time between false alarms (s) of the matched points.")] = 100.0,
    settle: Annotated[float, typer.Option(help="Start (s) of the RMSE-over-PCRB window.")] = 10.0,
) -> None:
    """Operating characteristics of every filter x rule (delay against mean time between false alarms with
    Lorden's bound, ROC, isolation), radius RMSE against the posterior Cramer-Rao bound: OUT/fdi.md,
    OUT/fdi_curves.csv, OUT/figures/."""
    from .study.fdi.report import fdi_curves as write_curves

    try:
        for name, v in (("--horizon", horizon), ("--arl0", arl0)):
            if not v > 0:
                raise BadInput(f"{name}: must be > 0")
        if not settle >= 0:
            raise BadInput("--settle: must be >= 0")
        if not study_dir.is_dir():
            raise BadInput(f"STUDY_DIR: {study_dir} is not a directory")
        path = write_curves(study_dir, out, fault_axis=fault_axis, horizon=horizon, arl0=arl0, settle=settle)
    except BadInput as err:
        _fail(str(err))
        return
    typer.echo(f"operating characteristics in {path}/fdi.md")


@app.command()
def view(run_dirs: Annotated[list[str], typer.Argument(
        help="A run directory (or a .rrd file); several run directories open their comparison.",
        metavar="RUN_DIR...", show_default=False)]) -> None:
    """Open a run's Rerun recording in the Rerun viewer, or the comparison of several runs."""
    import shlex

    from .rerun.viewer import check_display, check_recording, open_viewer, screenshot_command

    try:
        if len(run_dirs) == 1:
            rrd = check_recording(Path(run_dirs[0]))
            check_display(screenshot_command(str(rrd)))
            open_viewer(rrd)
            return
        from .rerun.overlay import load_runs

        load_runs(run_dirs)  # bad input first: exit 2 before anything else
        check_display(f"ftc-mj compare {shlex.join(run_dirs)} --out compare.rrd && "
                      f"{screenshot_command('compare.rrd')}")
        with tempfile.TemporaryDirectory(prefix="ftc-mj-view.") as tmp:
            rrd = _compare(run_dirs, Path(tmp) / "comparison.rrd", None)
            open_viewer(rrd)
    except BadInput as err:
        _fail(str(err))
    except RunFailed as err:
        _fail(str(err), code=EXIT_FAILED)


def _compare(run_dirs: list[str], out: Path, labels: list[str] | None) -> Path:
    from .rerun.overlay import write_comparison

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
    rates, IMM mode probabilities, reconfiguration state; legend by run label), and print the runs' key
    metrics side by side (one column per run), then the recording's path."""
    from .sim.output import check_output_root

    try:
        target = _folder(out, "--out")
        assert target is not None
        if target.suffix != ".rrd":
            raise BadInput(f"--out: {out}: the file name must end in .rrd")
        if target.is_dir():
            raise BadInput(f"--out: {out} is a folder; give a file name ending in .rrd")
        if target.exists() and not overwrite:
            raise BadInput(f"--out: {out} exists (give another name, or --overwrite)")
        from .rerun.overlay import load_runs

        runs = load_runs(run_dirs, _labels(labels, len(run_dirs)))  # every input checked before writing
        check_output_root(target.parent if str(target.parent) else Path("."), target.name)
        path = _compare(run_dirs, target, _labels(labels, len(run_dirs)))
    except BadInput as err:
        _fail(str(err))
        return
    except OSError as err:
        _fail(f"cannot write {out}: {err.strerror or err}", EXIT_FAILED)
        return
    from .rerun.overlay import comparison_text

    typer.echo(comparison_text(runs))
    typer.echo(str(path))


class PaperRrd(StrEnum):
    runs = "runs"
    none = "none"
    compare = "compare"


class SeedSet(StrEnum):
    held_out = "held-out"
    dev = "dev"


@app.command()
def paper(
    out: Annotated[str, typer.Option(help="Output folder: study/ (the matrix as a study), runs/ (--quick), "
                                          "summary.csv, claims.md, claims.json, figures/.")] = "runs/out/paper",
    jobs: Annotated[int, typer.Option(help="Parallel worker processes.")] = 2,
    seeds: Annotated[int | None, typer.Option(help="Seeds per matrix cell (default 10); every check is "
                                                   "judged over them.")] = None,
    seed_set: Annotated[SeedSet, typer.Option(help="held-out (1000, 1001, …; the default: where claims are "
                                                   "judged) or dev (0-9: where tuned parameters are chosen).")]
    = SeedSet.held_out,
    quick: Annotated[bool, typer.Option("--quick", help="Single-seed quick look (seed 0): one run per entry, "
                                                        "pass/fail per check; not a verdict over seeds.")] = False,
    tune: Annotated[bool, typer.Option("--tune", help="Also run the tuning studies on the development seeds and "
                                                      "report the value each selection rule chooses.")] = False,
    baseline: Annotated[list[Path] | None, typer.Option(help="Earlier output folder, claims.json or claims.md "
                                                             "(repeatable): list what changed against its verdicts "
                                                             "(claims.md, changes.md).")] = None,
    duration: Annotated[float | None, typer.Option(help="Shorten every run to this many seconds.")] = None,
    only: Annotated[list[str] | None, typer.Option("--only", help="Run only labels matching this glob "
                                                   "(repeatable), e.g. 's2-*' or 's4-imm-ukf5-*'.")] = None,
    extras: Annotated[bool, typer.Option("--extras/--no-extras",
                                         help="Add runs beyond the paper's 38: the literal 'paper' IMM (2), "
                                              "the reconfiguration-policy axis (18) and the path-following "
                                              "axis (11).")] = True,
    rrd: Annotated[PaperRrd, typer.Option(help="Quick look: recordings none (the default: run folders keep the "
                                               "trace columns the figures need: 39 MB in all for the 69 runs of 40 s), "
                                               "runs (one per run, with the whole trace; about 300 MB), or compare "
                                               "(also OUT/compare/claim-<id>.rrd overlaying each claim's runs). Over "
                                               "seeds no recordings are written.")] = PaperRrd.none,
    no_rrd: Annotated[bool, typer.Option("--no-rrd", help="Same as --rrd none.")] = False,
    fresh: Annotated[bool, typer.Option("--fresh", help="Quick look: recompute the runs even if finished ones "
                                                        "exist.")] = False,
    list_: Annotated[bool, typer.Option("--list", help="Print the matrix labels and exit.")] = False,
    report_only: Annotated[bool, typer.Option("--report-only", help="Run nothing: rebuild the report from the "
                                              "finished runs of the same selection.")] = False,
    publish: Annotated[str | None, typer.Option(metavar="DOCS", help="After the report, write DOCS/paper-claims.md "
                                                "(a generated head note + claims.md) and copy the figure selection "
                                                "into DOCS/figures/; DOCS must be an existing folder (e.g. docs). "
                                                "Not with --quick.")] = None,
) -> None:
    """Run the paper's test matrix (38 runs + 31 extras) over seeds and judge every claim's checks with
    Wilson intervals (or, with --quick, take a single-seed look); write summary.csv, claims.md,
    claims.json and figures/ (with --publish DOCS also DOCS/paper-claims.md and DOCS/figures/)."""
    from .paper.matrix import full_matrix, select

    if list_:
        for e in select(full_matrix(extras), only):
            typer.echo(f"{e.label}\t{e.scenario}\t" + " ".join(f"{k}={v}" for k, v in e.overrides.items()))
        return
    from .io import remove_stale_temporaries
    from .paper.run import PaperOptions, run_paper

    try:
        if no_rrd and rrd != PaperRrd.none:
            raise BadInput(f"--no-rrd: contradicts --rrd {rrd.value}")
        mode = PaperRrd.none if no_rrd else rrd
        if mode == PaperRrd.compare and not quick:
            raise BadInput("--rrd compare: only with --quick (over seeds no recordings are written)")
        out_dir = _folder(out)
        assert out_dir is not None
        opts = PaperOptions(jobs=jobs, duration=duration, only=only, extras=extras, rrd=mode != PaperRrd.none,
                            fresh=fresh, report_only=report_only, quick=quick, seeds=seeds, seed_set=seed_set.value,
                            tune=tune, baselines=list(baseline or []), publish=_folder(publish, "--publish"))
        opts.check()
        for d in (out_dir, out_dir / "runs", out_dir / "figures", out_dir / "compare"):
            remove_stale_temporaries(d)
        res = run_paper(out_dir, opts, echo=lambda s: typer.echo(s, err=True))
        res.published = _publish_claims(out_dir, opts.publish)
        compared = _claim_comparisons(res, out_dir / "compare") if mode == PaperRrd.compare else []
    except BadInput as err:
        _fail(str(err))
        return
    except KeyboardInterrupt:
        _interrupted("interrupted; finished runs are kept and reused next time")
        return
    _report_paper(res, compared)
    if res.failed:
        typer.echo(f"ftc-mj: {len(res.failed)} run(s) failed: {', '.join(res.failed)}", err=True)
        raise typer.Exit(EXIT_FAILED)


def _publish_claims(out_dir: Path, docs: Path | None) -> list[Path]:
    """``--publish DOCS``: write ``DOCS/paper-claims.md`` and its figures after the report (the files written)."""
    if docs is None:
        return []
    from .reports.paper_claims import publish

    return publish(out_dir, docs)


def _report_paper(res: Any, compared: list[Path]) -> None:
    """What ``ftc-mj paper`` prints at the end: the runs, each claim's verdict, the tuned values, the
    comparison recordings and what ``--publish`` wrote."""
    typer.echo(f"{len(res.rows)} runs in {res.wall_time_s:.1f} s (report {res.report_time_s:.1f} s) → {res.out}"
               + (" [single-seed quick look]" if res.quick else ""))
    for c in res.claims:
        typer.echo(f"  claim {c.id:>2}: {c.verdict:<15} {c.title}")
    for o in res.tuning:
        typer.echo(f"  tuned {o.tuned.key}: {o.selection.value} (default {o.tuned.default():g}) on development seeds "
                   f"{', '.join(map(str, o.seeds))}, {o.runs} runs" + (f" in {o.wall_time_s:.1f} s" if o.wall_time_s
                                                                         else ""))
    for p in compared:
        typer.echo(f"  comparison: {p}")
    if res.published:
        typer.echo(f"  published: {res.published[0]} and {len(res.published) - 1} figure(s) in "
                   f"{res.published[0].parent / 'figures'}")


def _claim_comparisons(res: Any, out_dir: Path) -> list[Path]:
    from .rerun.overlay import claim_run_dirs, write_comparison

    paths = []
    for claim_id, labels, dirs in claim_run_dirs(res.claims, res.rows):
        if len(dirs) >= 2:
            paths.append(write_comparison(dirs, out_dir / f"claim-{claim_id}.rrd", labels,
                                          recording_id=f"claim-{claim_id}"))
    return paths


@app.command("warm-up")
def warm_up(every: Annotated[bool, typer.Option("--all", help="Also the robust and the path-following NMPC (every "
                                                "MPC of the built-in benchmark methods).")] = False) -> None:
    """Compile the numba kernels and build the IPOPT solvers the default run needs, on two processes at once (the
    first run after an install then starts at once; docs/performance.md). Prints the CPU seconds of each part."""
    import time

    from .sim.warmup import WARM_UP, WARM_UP_ALL
    from .sim.warmup import warm_up as run_warm_up

    t = time.perf_counter()
    cpu = [c for _, c in run_warm_up(WARM_UP_ALL if every else WARM_UP)]
    typer.echo(f"warm-up: {time.perf_counter() - t:.1f} s ({' + '.join(f'{c:.1f}' for c in cpu)} s CPU)")


@app.command()
def scenarios() -> None:
    """List the built-in scenarios."""
    from .config import BUILTIN_SCENARIOS, load_config

    for name in BUILTIN_SCENARIOS:
        typer.echo(f"{name}: {load_config(name).description}")


@app.command()
def components(plugin: Plugins = None) -> None:
    """List the registered estimators, decision rules, controllers, policies, references and fault classes
    (built-in, from installed packages' entry points and from --plugin modules), each with its settings: a
    built-in's settings model, a plug-in's ``options`` model (field, type and range, default, what it is);
    then each fault class with its component, mode, targets, parameters' ranges and the measurements that
    observe it."""
    from .plant.faults import all_classes
    from .registry import REGISTRIES, load_plugins, settings_listing

    try:
        load_plugins(plugin or [])
        for reg in REGISTRIES.values():
            typer.echo(f"{reg.config_key}: {', '.join(reg.names())}")
            for line in settings_listing(reg):
                typer.echo(line)
        typer.echo("fault classes:")
        for cls in all_classes():
            drawn = f"; drawn as {', '.join(cls.drawn_as)}" if cls.drawn_as else ""
            typer.echo(f"  {cls.describe()}{drawn}")
    except BadInput as err:
        _fail(str(err))


class BenchSplit(StrEnum):
    dev = "dev"
    test = "test"
    private = "private"


def private_key(split: str, key_file: str | None) -> bytes | None:
    """The private split's key (:func:`~ftc_mj.benchmark.private.read_key`), ``None`` on the other splits (where
    ``--key-file`` is refused: it would be ignored)."""
    from .benchmark.private import read_key

    if split == "private":
        return read_key(key_file)
    if key_file is not None:
        raise BadInput("--key-file: only the private split takes a key")
    return None


def _publish_bench(docs: Path, report: Path, out_dir: Path, options: dict[str, Any], version: str) -> Path:
    """Write ``docs/benchmark.md`` and its figures from the bench's report (:mod:`ftc_mj.reports.benchmark_page`),
    naming the command (its ``options``) that made them."""
    from .reports.benchmark_page import argv_of, publish

    return publish(docs, report, out_dir, argv_of(**options), version)


def _bench_folders(out: str | None, publish: str | None, version: str, split: str, start: int, draws: int,
                   healthy: bool) -> tuple[Path, Path | None]:
    """The bench's output folder (``--out``, else ``runs/out/bench/<version>-<split>-<first>-<last>[-healthy]``)
    and the ``--publish`` docs folder (``None`` without; :class:`BadInput` unless it exists)."""
    label = Path(version).stem if version.endswith(".toml") else version
    out_dir = _folder(out) or Path("runs/out/bench") / (f"{label}-{split}-{start}-{start + draws - 1}"
                                                       + ("-healthy" if healthy else ""))
    docs = _folder(publish, "--publish")
    if docs is not None and not docs.is_dir():
        raise BadInput(f"--publish: {docs} is not an existing folder")
    return out_dir, docs


@app.command()
def bench(
    methods: Annotated[list[str], typer.Argument(metavar="METHOD...", help="Built-in methods (paper, safe, pathfollow, "
                                                 "hybrid, passive, feedback-off), reference rows (oracle, standstill) "
                                                 "or method TOML files.")],
    split: Annotated[BenchSplit, typer.Option(help="dev (develop and tune there), test (public leaderboard) or "
                                              "private (draws from a key given at run time: FTC_MJ_PRIVATE_KEY or "
                                              "--key-file).")] = BenchSplit.dev,
    draws: Annotated[int, typer.Option(help="Number of draws (from --start).")] = 8,
    start: Annotated[int, typer.Option(help="Index of the first draw (replay one draw: --start I --draws 1).")] = 0,
    out: Annotated[str | None, typer.Option(help="Output folder (default runs/out/bench/<version>-<split>-<first>-"
                                              "<last draw>[-healthy]).")] = None,
    workers: Annotated[int, typer.Option(help="Local Dask worker processes.")] = 2,
    address: Annotated[str | None, typer.Option(help="Scheduler of a running Dask cluster, tcp://HOST:PORT.")] = None,
    version: Annotated[str, typer.Option("--benchmark", help="Benchmark definition: a shipped version, or a "
                                         "definition file (*.toml; its plugins may register fault classes).")
                       ] = "ftc-v2",
    healthy: Annotated[bool, typer.Option("--healthy", help="Run every draw without its faults (the check that "
                                                            "the healthy robot follows every drawn path).")] = False,
    compare: Annotated[int, typer.Option(help="Rerun comparisons of this many draws where the methods differ "
                                              "most (OUT/compare/).")] = 1,
    publish: Annotated[str | None, typer.Option(metavar="DOCS", help="Also write DOCS/benchmark.md (the benchmark, "
                                                "its distributions and this report) and DOCS/figures/benchmark/; "
                                                "DOCS must be an existing folder (e.g. docs).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    key_file: Annotated[str | None, typer.Option(help="File holding the private split's key (else the "
                                                 "FTC_MJ_PRIVATE_KEY variable); never written to the outputs.")
                        ] = None,
) -> None:
    """Score methods on draws of the benchmark (faults, conditions, paths, noise from a versioned definition) on
    Dask: OUT/draws.parquet, OUT/scores.parquet, the report (leaderboard.md on the test split), figures and
    Rerun comparisons. Every run is persisted as it finishes; re-running the command computes only the rest,
    and a method added to the same --out computes only its own runs. One process writes an output folder at a
    time: a second bench or study on it exits 2 at once. When it ends it prints the success rate per method.

    A method file (TOML; examples/blend_policy.toml, docs/tutorial-benchmark.md):

    \b
        name = "blend-half"                    # the method's name in the report
        description = "UKF, NMPC, my policy"   # optional
        plugins = ["blend_policy"]             # optional: modules registering plug-in components,
                                               # found beside the method file (or installed)
        [settings]                             # run-config keys of estimator, controller,
        "reconfiguration.policy" = "blend"     # reconfiguration and model only (the draw sets
        "reconfiguration.options.weight" = 0.5 # faults, plant, sensors, path, duration, seed)
    """
    from .benchmark.methods import load_methods
    from .benchmark.report import summary_lines
    from .benchmark.run import plan_bench, run_bench
    from .study.cluster import validate_address
    from .study.runner import StudyInterruptedError

    try:
        if workers < 1:
            raise BadInput("--workers: must be >= 1")
        if compare < 0:
            raise BadInput("--compare: must be >= 0")
        if address is not None:
            validate_address(address)
        out_dir, docs = _bench_folders(out, publish, version, split.value, start, draws, healthy)
        key = private_key(split.value, key_file)
        bp = plan_bench(load_methods(methods), split.value, draws, version=version, start=start, healthy=healthy,
                        private_key=key)
        report, path = run_bench(bp, out_dir, workers=workers, address=address, compare=compare,
                                 progress=not quiet and sys.stderr.isatty(),
                                 echo=lambda s: typer.echo(f"ftc-mj: {s}", err=True))
        if docs is not None:
            argv = dict(methods=methods, split=split.value, draws=draws, start=start or None, out=out,
                        workers=workers, benchmark=version, healthy=healthy,
                        publish=publish)
            typer.echo(f"bench: wrote {_publish_bench(docs, path, out_dir, argv, version)}")
    except (BadInput, StudyInterruptedError, KeyboardInterrupt) as err:
        _end_study(err)
        return
    except Exception as err:  # noqa: BLE001 - re-raised unless the results could not be written
        _output_failed(err)
    typer.echo("\n".join(summary_lines(bp, report.results)))
    typer.echo(f"bench: computed {len(report.computed)} runs ({len(report.failed)} not ok) in "
               f"{report.wall_time_s:.1f} s; {report.already_done + len(report.computed)} of {report.planned} done; "
               f"report {path}")


@app.command()
def metrics(markdown: Annotated[bool, typer.Option(
        "--markdown", help="As a Markdown table (the text of docs/metrics.md in the source repository).")] = False,
            ) -> None:
    """List every key metrics.json can hold with its unit and one-line meaning (also written beside each
    run's metrics.json as metrics.schema.json)."""
    from .metrics.schema import schema_lines, schema_markdown

    typer.echo(schema_markdown() if markdown else "\n".join(schema_lines()), nl=not markdown)


@app.command()
def studies() -> None:
    """List the built-in studies: run count and simulated time (with the expected duration where
    runs/out/studies/NAME records this machine's rate), the whole description, the analyses that apply
    (run one with 'ftc-mj study NAME'; its plan with 'ftc-mj study NAME --list')."""
    import shutil

    from .reports.doc_tables import doc_table_studies
    from .resources import builtin_studies
    from .study.listing import study_entry
    from .study.plan import outline_study

    width = max(60, min(100, shutil.get_terminal_size((100, 24)).columns))
    published = doc_table_studies()
    for name in builtin_studies():
        plan = outline_study(name)  # the runs unresolved: listing does not validate thousands of configs
        typer.echo("\n".join(study_entry(name, plan, width, Path("runs/out/studies") / plan.spec.name, published)))


def main() -> None:  # pragma: no cover - console entry point
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
