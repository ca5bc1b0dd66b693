"""Study analysis of filter consistency: per-run NEES/NIS averages pooled over seeds with χ² bounds."""

from __future__ import annotations

import numpy as np
import polars as pl

from ftc_mj.config import load_config
from ftc_mj.estimation.consistency import anees_bounds
from ftc_mj.metrics.run import compute_metrics
from ftc_mj.sim.record import build_record
from ftc_mj.study.rows import flatten_metrics
from ftc_mj.study.tables import consistency_table, run_tests
from ftc_mj.telemetry.columns import BASE_COLUMNS

STD = 0.1


def _run_metrics(rng: np.random.Generator, scale: float) -> dict:
    """Metrics of a 10 s no-fault run whose state errors are N(0, (scale·σ)²) with σ = 0.1 reported:
    scale 1 is a consistent filter (NEES ~ χ²_5, radius NEES ~ χ²_2, NIS ~ χ²_1), 1.15 an overconfident one."""
    cfg = load_config("scenario1", {"duration": 10.0})
    n = 1000
    tr = {c: np.zeros(n) for c in BASE_COLUMNS}
    tr["t"] = np.arange(n) * 0.01
    for s in ("x", "y", "psi", "R_R", "R_L"):
        tr[s][:] = 2.0 if s.startswith("R_") else 0.0
        tr[f"{s}_hat"] = tr[s] + scale * STD * rng.normal(size=n)
        tr[f"{s}_std"][:] = STD
    tr["nis"] = scale**2 * rng.chisquare(1, size=n)
    tr["nis_dof"][:] = 1.0
    tr["solve_time_ms"][:] = np.nan
    return flatten_metrics(compute_metrics(build_record(cfg), tr, {}))


def test_consistency_table_pools_seeds_with_chi2_bounds() -> None:
    rng = np.random.default_rng(11)
    rows = [{"filter": f, "seed": s, **_run_metrics(rng, scale)}
            for f, scale in (("consistent", 1.0), ("overconfident", 1.15)) for s in range(20)]
    df = pl.DataFrame(rows)
    good = run_tests(df.filter(pl.col("filter") == "consistent"), "radius_nees")
    assert len(good) == 20 and all(t.samples == 1000 for t in good)
    table = consistency_table(df, "filter", ["consistent", "overconfident"])
    lines = table.splitlines()
    print(table)
    assert lines[0].startswith("| filter | runs | ANIS per dimension")
    # consistent: 20 runs × 1000 white steps = 20 000 samples per statistic, all inside. Each run's τ
    # is estimated from its 1000 steps (standard error ≈ 0.15) and floored at 1, so n_eff comes out a
    # little below 20 000, never above
    assert lines[2].count("inside") == 3 and "outside" not in lines[2]
    n_eff = sum(t.n_eff for t in good)
    assert 16000 < n_eff <= 20000 and f"n_eff {n_eff:.0f}" in lines[2]
    lo, hi = anees_bounds(n_eff, 2)
    assert f"[{lo:.3g}, {hi:.3g}]" in lines[2]
    # 15 % too large errors: every statistic 32 % high, far outside bounds of about ±3 %
    assert lines[3].count("**outside**") == 3
