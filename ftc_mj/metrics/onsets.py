"""The scheduled fault onsets of a run: when each wheel's radius schedule first departs from nominal
(:func:`~ftc_mj.plant.faults.schedule_onset`, the one home of that rule), and the distinct onset times
the detection metrics give each their window."""

from __future__ import annotations

from ..config import RunConfig
from ..plant.faults import schedule_onset


def fault_onsets(cfg: RunConfig) -> dict[str, float | None]:
    """First time (s) each wheel's scheduled radius departs from nominal (:func:`schedule_onset`);
    None = no fault."""
    R0 = cfg.plant_wheel_radius
    return {"right": schedule_onset(cfg.faults.right, R0), "left": schedule_onset(cfg.faults.left, R0)}


def onset_groups(onsets: dict[str, float | None]) -> list[tuple[float, tuple[bool, bool]]]:
    """Distinct onset times (s) in order, each with the (right, left) wheels whose fault starts then."""
    times = sorted({o for o in onsets.values() if o is not None})
    return [(o, (onsets["right"] == o, onsets["left"] == o)) for o in times]


def wheel_label(right: bool, left: bool) -> str | None:
    """``both``, ``right``, ``left`` or None for a (right, left) pair of faulty flags."""
    return "both" if right and left else "right" if right else "left" if left else None
