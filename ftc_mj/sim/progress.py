"""A progress bar around a run (rich), shown only on a terminal."""

from __future__ import annotations

from pathlib import Path

from ..config import RunConfig
from .run import RunOutcome, execute


def run_with_progress(cfg: RunConfig, out_root: Path | None, *, rrd: bool, show: bool) -> RunOutcome:
    """Execute a run, with a rich progress bar over simulated time when ``show``."""
    if not show:
        return execute(cfg, out_root, rrd=rrd)
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                  TimeElapsedColumn(), transient=True) as bar:
        task = bar.add_task(cfg.name, total=1.0)
        return execute(cfg, out_root, rrd=rrd, progress=lambda f: bar.update(task, completed=f))
