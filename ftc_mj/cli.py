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


class ControllerKind(StrEnum):
    nmpc = "nmpc"
    lmpc = "lmpc"
    open_loop = "open-loop"


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
    feedback: Annotated[bool | None, typer.Option("--feedback/--no-feedback",
                                                  help="Reconfigure the controller with estimated radii.")] = None,
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
        for key, val in (("estimator.kind", estimator.value if estimator else None),
                         ("estimator.imm_models", imm_models), ("estimator.imm_variant", imm_variant),
                         ("feedback", feedback), ("controller.kind", controller.value if controller else None),
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


@app.command()
def view(run_dir: Annotated[Path, typer.Argument(help="A run directory (or a .rrd file).")]) -> None:
    """Open a run's Rerun recording in the Rerun viewer."""
    from .recorder import open_viewer

    path = run_dir / "run.rrd" if run_dir.is_dir() else run_dir
    try:
        open_viewer(path)
    except BadInput as err:
        _fail(str(err))


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
