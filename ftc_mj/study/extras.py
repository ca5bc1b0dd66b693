"""Per-run computations a study file can ask its workers for (``[analysis] extras = ["NAME"]``), on the
run's resolved config and full trace; their values join the run's row. One registry entry each:

- ``pcrb_split``: the posterior Cramér–Rao bound along the radius split (the direction the speed does
  not see at the current wheel rates) from the puncture on (:data:`PCRB_FROM_S`), for the filters' own
  model (radii a random walk) and for radii known to stay constant after the puncture, at
  :data:`PCRB_TIMES`, the first time it is at most :data:`ISOLATED_SPLIT_M`, and the wheel-rate ratio
  ω_L/ω_R just before the puncture and at 12 s (docs/fdi.md, ``ftc-mj study pcrb --report``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..config import RunConfig

PCRB_FROM_S = 10.0
"""Start of the bound (s): the puncture of scenario 2."""
PCRB_TIMES = (10.2, 10.5, 11.0, 12.0, 20.0, 39.99)
"""Times (s) at which the bound's split σ is reported."""
ISOLATED_SPLIT_M = 0.15
"""Split σ (m) at which the sigma rule isolates (its ``max_split_sigma``)."""
PCRB_MODELS = (("model", None), ("constant", 0.0))
"""(column tag, radius process noise) of the two bounds: the filters' own, and constant radii."""


def time_tag(t: float) -> str:
    """A time (s) as a column-name fragment: ``10.2`` → ``10_2``."""
    return f"{t:g}".replace(".", "_")


def pcrb_split(cfg: RunConfig, trace: dict[str, np.ndarray]) -> dict[str, Any]:
    """See the module docstring; columns ``omega_ratio_9_9``, ``omega_ratio_12``, and per bound
    ``pcrb_split_<tag>_<time>`` (m) and ``pcrb_split_<tag>_isolated_s`` (s, None if never)."""
    from ..estimation.observability import radius_directions
    from ..estimation.pcrb import trace_pcrb
    from ..wiring.estimation import setup_from_config

    t = trace["t"]
    k0 = int(np.searchsorted(t, PCRB_FROM_S - 1e-9))
    omega = np.column_stack([trace["omega_R"], trace["omega_L"]])
    out: dict[str, Any] = {}
    for x in (9.9, 12.0):
        k = int(np.searchsorted(t, x))
        out[f"omega_ratio_{time_tag(x)}"] = float(omega[k, 1] / omega[k, 0])
    for tag, q in PCRB_MODELS:
        B = trace_pcrb(setup_from_config(cfg), trace, q_radius=q, start=k0)
        split = np.array([radius_directions(B[k], omega[k0 + k]).split_std for k in range(B.shape[0])])
        for x in PCRB_TIMES:
            out[f"pcrb_split_{tag}_{time_tag(x)}"] = float(split[int(np.searchsorted(t[k0:], x))])
        ok = t[k0:][split <= ISOLATED_SPLIT_M]
        out[f"pcrb_split_{tag}_isolated_s"] = float(ok[0]) if ok.size else None
    return out


EXTRAS: dict[str, Callable[[RunConfig, dict[str, np.ndarray]], dict[str, Any]]] = {"pcrb_split": pcrb_split}
"""Name → ``fn(cfg, trace) -> {column: value}``."""


def run_extras(names: list[str], cfg: RunConfig, trace: dict[str, np.ndarray]) -> dict[str, Any]:
    """The columns of every named extra for one run."""
    out: dict[str, Any] = {}
    for name in names:
        out.update(EXTRAS[name](cfg, trace))
    return out
