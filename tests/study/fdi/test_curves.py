"""Operating characteristics from first-alarm records: the statistics on hand-made runs, Lorden's bound,
the ``fdi-curves`` command end to end on a tiny study and its bad-input errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.config import RunConfig
from ftc_mj.metrics.fdi import cumulative_kl
from ftc_mj.sim.record import build_record
from ftc_mj.study.fdi.curves import Cell, Run, lorden_bound, operating_point, poisson_rate
from ftc_mj.study.plan import plan_study
from ftc_mj.study.runner import run_study


def _run(key: str, records: list[list[float]], onset: float | None = None, seed: int = 0) -> Run:
    rec = np.asarray(records, float).reshape(-1, 3)
    return Run(key=key, seed=seed, severity=0.5 if onset is not None else 0.0, onset=onset,
               wheel="left" if onset is not None else None, duration=20.0,
               records={"glr": rec})


def test_operating_point_counts_alarms_exposure_delays_and_isolation() -> None:
    """At h = 5: no-fault first alarms at 5, 12, none, 19 s → 3 alarms in 5 + 12 + 20 + 19 = 56 s. Fault runs
    (onset 10 s): detected after 0.05 s (left, right wheel), an early alarm at 3 s, detected after 3 s
    ('unknown'), never: delay (0.05 + 3)/2, within 2 s 1 of the 3 runs without an early alarm."""
    cell = Cell({"estimator": "ukf"})
    cell.nofault = [_run("a", [[5.0, 10.0, 4]]), _run("b", [[2.0, 3.0, 4], [12.0, 20.0, 4]]), _run("c", []),
                    _run("d", [[19.0, 50.0, 4]])]
    cell.faults = {0.5: [_run("A", [[10.05, 40.0, 2]], 10.0), _run("B", [[3.0, 6.0, 4], [10.5, 30.0, 1]], 10.0),
                         _run("C", [[13.0, 8.0, 4]], 10.0), _run("D", [], 10.0)]}
    p = operating_point(cell, "glr", 5.0, horizon=2.0)
    assert p.rate.n == 3 and p.exposure == pytest.approx(56.0) and p.arl0.mean == pytest.approx(56.0 / 3)
    assert p.delay[0.5].mean == pytest.approx(1.525) and p.delay[0.5].n == 2
    assert p.pd[0.5].mean == pytest.approx(1 / 3) and p.early[0.5].mean == pytest.approx(0.25)
    assert p.iso[0.5].mean == pytest.approx(0.5) and p.unknown[0.5].mean == pytest.approx(0.5)
    # no-fault runs without an alarm before the onset (a alarmed at 5 s): b, c, d; only b alarms in [10, 12] s
    assert p.pfa.n == 3 and p.pfa.mean == pytest.approx(1 / 3)
    assert operating_point(cell, "glr", 5.0, 2.0, seeds={1}).rate.n == 0  # restricted to seeds without runs


def test_poisson_interval_with_no_alarm() -> None:
    """Garwood: zero events in E seconds give the upper rate χ²(0.975; 2)/2/E = 3.689/E."""
    r = poisson_rate(0, 100.0)
    assert r.mean == 0.0 and r.lo == 0.0 and r.hi == pytest.approx(3.6889 / 100.0, rel=1e-4)


def test_cumulative_information_and_lorden_bound_of_a_step_puncture() -> None:
    """A 1 m drop of the left radius at ω = (5.1, 4.9) rad/s lowers the true speed by 4.9/2 m/s: with σ
    0.5 m/s the information is ½ (2.45/0.5)² = 12.005 nats per row from the first shifted row, a model
    bias before the onset (here +0.3 m/s) is removed. The bound is then the first row where the
    information reaches log(ARL0/dt): 1 row up to ARL0 = dt·e^12 (16 s at 100 Hz), 2 rows up to dt·e^24."""
    cfg = RunConfig.model_validate({})
    n, k_on = 400, 200
    t = np.arange(n) * 0.01
    v = np.full(n, 0.5 * 2.0 * (5.1 + 4.9) + 0.3)
    v[k_on + 1:] -= 2.45
    trace = {"t": t, "v": v, "yaw_rate": np.zeros(n), "omega_R": np.full(n, 5.1), "omega_L": np.full(n, 4.9)}
    K = np.array(cumulative_kl(build_record(cfg).setup, trace, t[k_on]))
    assert K[0] == pytest.approx(0.0, abs=1e-9) and np.diff(K[:3]) == pytest.approx([12.005, 12.005], rel=1e-9)
    assert K[-1] > 25.0 and K.size == 4  # stops once beyond the cap
    runs = [_run(str(i), [], 10.0) for i in range(3)]
    for r in runs:
        r.kl = K
    cell = Cell({}, faults={0.5: runs}, config=cfg)
    a = np.array([1.0, 100.0, 1e8, 1e13])
    assert list(lorden_bound(cell, 0.5, a, 0.01)) == pytest.approx([0.01, 0.01, 0.02, 0.03])


STUDY = """
name = "tiny"
scenario = "scenario1"
seeds = 2
[base]
duration = 12.0
"reconfiguration.policy" = "none"
"estimator.decision.statistics" = true
"plant.kind" = "kinematic"
"sensors.yaw_rate_sigma" = 0.01
[[axes]]
name = "estimator"
key = "estimator.kind"
values = ["ukf"]
[[axes]]
name = "severity"
labels = [0.0, 0.5]
values = [{}, { "faults.left" = [[10.0, 2.0], [10.0, 1.0]] }]
[analysis]
timeseries_rate = 10.0
"""


def test_fdi_curves_end_to_end_and_bad_input(tmp_path: Path) -> None:
    """A 4-run study: the command writes the table (every section), the CSV and the figures; the GLR detects
    the 50 % puncture with the gyro at its design threshold and isolates it. Bad input: one line, exit 2."""
    sf = tmp_path / "tiny.toml"
    sf.write_text(STUDY)
    out = tmp_path / "study"
    run_study(plan_study(sf), out, serial=True, analyse=False)
    res = CliRunner().invoke(app, ["fdi-curves", str(out)])
    assert res.exit_code == 0, res.output
    md = (out / "fdi" / "fdi.md").read_text()
    for head in ("False alarms at the design thresholds", "Detection at the design thresholds",
                 "matched on development seeds", "Shortest delay", "Radius RMSE over the posterior"):
        assert head in md
    row = next(line for line in md.splitlines() if line.startswith("| ukf | glr |") and "| 0.5 |" in line)
    assert "100 % [" in row.split("|")[9]  # detected within the horizon
    assert (out / "fdi" / "fdi_curves.csv").stat().st_size > 0
    assert {p.name for p in (out / "fdi" / "figures").iterdir()} >= {"delay_all.png", "roc_all.png", "rmse_pcrb.png"}
    bad = (([str(tmp_path / "nope")], "STUDY_DIR"), ([str(tmp_path)], "results.parquet"),
           ([str(out), "--fault-axis", "wheel"], "--fault-axis"), ([str(out), "--horizon", "0"], "--horizon"))
    for args, what in bad:
        r = CliRunner().invoke(app, ["fdi-curves", *args])
        assert r.exit_code == 2 and what in r.output and len(r.output.strip().splitlines()) == 1, r.output
