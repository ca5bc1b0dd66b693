"""The distinct fault onset times the detection metrics give each their window, from the scheduled
onsets per wheel (the run record's ``onsets``, :func:`ftc_mj.sim.record.fault_onsets`)."""

from __future__ import annotations


def onset_groups(onsets: dict[str, float | None]) -> list[tuple[float, tuple[bool, bool]]]:
    """Distinct onset times (s) in order, each with the (right, left) wheels whose fault starts then."""
    times = sorted({o for o in onsets.values() if o is not None})
    return [(o, (onsets["right"] == o, onsets["left"] == o)) for o in times]


def wheel_label(right: bool, left: bool) -> str | None:
    """``both``, ``right``, ``left`` or None for a (right, left) pair of faulty flags."""
    return "both" if right and left else "right" if right else "left" if left else None
