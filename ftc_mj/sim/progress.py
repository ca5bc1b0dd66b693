"""A progress bar around a run (rich), shown only on a terminal: simulated share, time elapsed and
time left (wall clock, estimated from the speed so far)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..config import RunConfig
from .run import RunOutcome, execute


def run_progress(get_time: Callable[[], float] | None = None, **kwargs: Any) -> Any:
    """The rich progress display of a run: description, bar, percentage, elapsed and remaining time
    (``get_time``: the clock, s; rich's monotonic clock if ``None``)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    clock = {"get_time": get_time} if get_time is not None else {}
    return Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                    TimeElapsedColumn(), TextColumn("elapsed,"), TimeRemainingColumn(), TextColumn("left"),
                    **clock, **kwargs)


def run_with_progress(cfg: RunConfig, out_root: Path | None, *, rrd: bool, show: bool) -> RunOutcome:
    """Execute a run, with a rich progress bar over simulated time when ``show``."""
    if not show:
        return execute(cfg, out_root, rrd=rrd)
    with run_progress(transient=True) as bar:
        task = bar.add_task(cfg.name, total=1.0)
        return execute(cfg, out_root, rrd=rrd, progress=lambda f: bar.update(task, completed=f))
