"""A single run's progress bar says how long is left, estimated from the speed so far."""

from __future__ import annotations

import io

from rich.console import Console

from ftc_mj.sim.progress import run_progress


def test_the_bar_shows_time_elapsed_and_left() -> None:
    now = [0.0]
    out = io.StringIO()
    bar = run_progress(get_time=lambda: now[0], console=Console(file=out, width=120, force_terminal=False),
                       auto_refresh=False)
    task = bar.add_task("scenario2", total=1.0)
    for t, done in ((2.0, 0.1), (5.0, 0.25), (10.0, 0.5)):  # 5 % of the run per second
        now[0] = t
        bar.update(task, completed=done)
    line = "".join(str(c.render(bar.tasks[0])) for c in bar.columns)
    assert "50%" in line and "0:00:10elapsed," in line and "0:00:10left" in line, line
