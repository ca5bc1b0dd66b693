"""``metrics.json`` says when the robot tipped over (``tip_time_s``: the first sample whose plant flags hold
the tipped bit), not only whether."""

from __future__ import annotations

import numpy as np

from ftc_mj.metrics.run import plant_metrics
from ftc_mj.metrics.schema import schema_lines
from ftc_mj.plant.truth import LIFTOFF, TIPPED


def _trace(flags: np.ndarray, dt: float) -> dict[str, np.ndarray]:
    return {"t": np.arange(flags.size) * dt, "plant_flags": flags.astype(float)}


def test_tip_time_is_the_first_tipped_sample() -> None:
    dt = 0.05
    flags = np.zeros(200, dtype=np.int64)
    flags[40:] |= LIFTOFF  # a wheel lifts first (t = 2 s): not a tip-over
    flags[130:] |= TIPPED  # then the chassis passes the limit at t = 6.5 s and stays over
    m = plant_metrics(_trace(flags, dt), {}, {}, dt)
    assert m["tipped"] is True and m["tip_time_s"] == 130 * dt


def test_no_tip_time_without_a_tip_over() -> None:
    flags = np.full(100, LIFTOFF, dtype=np.int64)
    m = plant_metrics(_trace(flags, 0.05), {}, {}, 0.05)
    assert m["tipped"] is False and m["tip_time_s"] is None


def test_the_tip_time_is_in_the_metrics_schema() -> None:
    assert any(ln.startswith("tip_time_s ") and "[s]" in ln and "tipped over" in ln for ln in schema_lines())
