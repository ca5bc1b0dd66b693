"""Matplotlib for the study figures: the non-interactive backend and an atomic PNG write."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..io import atomic_path


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend (figures are written, never shown)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: Path) -> None:
    """Write ``fig`` as a 110-dpi PNG at ``path`` (atomically) and close it."""
    plt = pyplot()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
