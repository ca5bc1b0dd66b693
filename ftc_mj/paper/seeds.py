"""The seeds of ``ftc-mj paper``: development seeds (where data-tuned parameters are chosen) and
held-out seeds (where the claims are judged).

Every single-seed look at the matrix before the seeded verdicts, and the studies that shaped the loop,
used seeds 0–9 (the config default is seed 0; those studies use ``seeds = n`` with n ≤ 10, i.e.
0 … n − 1), and the data-tuned parameters (:mod:`.tuning`) are chosen on them: they are the
development seeds. The held-out seeds start at 1000; no tuning study (``tuning = true`` in its file) may
use them — planning one refuses them — and no study file chooses anything on them (the FDI studies
``fdi``, ``fdi_arl0`` and ``fdi_isolation`` judge on them what was set on development seeds).
"""

from __future__ import annotations

from ..errors import BadInput
from ..study.spec import HELD_OUT_START

DEV_SEEDS: tuple[int, ...] = tuple(range(10))
SEED_SETS = ("held-out", "dev")


def seed_set(name: str, n: int) -> tuple[int, ...]:
    """The first ``n`` seeds of the set ``name`` (``held-out``: 1000, 1001, …; ``dev``: 0 … 9)."""
    if name not in SEED_SETS:
        raise BadInput(f"--seed-set: expected held-out or dev (got {name!r})")
    if n < 1:
        raise BadInput(f"--seeds: must be ≥ 1 (got {n})")
    if name == "dev":
        if n > len(DEV_SEEDS):
            raise BadInput(f"--seeds: the development set has {len(DEV_SEEDS)} seeds (got {n})")
        return DEV_SEEDS[:n]
    return tuple(range(HELD_OUT_START, HELD_OUT_START + n))


def describe(seeds: tuple[int, ...]) -> str:
    """``'held-out seeds 1000–1009'``-style text naming the set the seeds belong to."""
    dev = all(s in DEV_SEEDS for s in seeds)
    held = all(s >= HELD_OUT_START for s in seeds)
    kind = "development" if dev else "held-out" if held else "mixed development and held-out"
    lst = (f"{seeds[0]}–{seeds[-1]}" if len(seeds) > 2 and list(seeds) == list(range(seeds[0], seeds[-1] + 1))
           else ", ".join(str(s) for s in seeds))
    return f"{kind} seed{'s' if len(seeds) != 1 else ''} {lst}"
