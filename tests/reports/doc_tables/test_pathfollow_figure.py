"""``ftc-mj study pathfollow_figure`` + ``--report``: the study is the four runs the figure script it replaced
(deleted) made, and the figure drawn from the study's rows shows what that script drew from the full traces (the
same arrays, panels, colours and titles). Fast: instantaneous fake runs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.config import RunConfig, load_config
from ftc_mj.errors import BadInput
from ftc_mj.model.kinematics import max_path_speed
from ftc_mj.plant import LIFTOFF, SCRAPE
from ftc_mj.reports.doc_tables import pathfollow_figure as pf
from ftc_mj.study.plan import plan_study
from ftc_mj.study.runner import run_study
from tests.support.fake_runs import FakeOutcome, FakeResult

runner = CliRunner()
SETTINGS = {"estimator.kind": "ukf", "reconfiguration.policy": "safe", "controller.rate_penalty": 1.0,
            "sensors.yaw_rate_sigma": 0.01}
"""The retired script's overrides besides the scenario, controller and seed."""
EXTRA = {"duration": 3.0, "reference.speed": 8.0}
"""``--set`` overrides of the fake study: short runs, and a speed cap the feasible speed crosses."""


def test_the_study_is_the_four_runs_of_the_script() -> None:
    plan = plan_study("pathfollow_figure")
    got = {(r.labels["scenario"], r.labels["controller"]): r for r in plan.runs}
    assert sorted(got) == [(s, c) for s in ("scenario3", "scenario4") for c in ("nmpc", "pf-nmpc")]
    for (scenario, ctl), run in got.items():
        cfg = load_config(scenario, {**SETTINGS, "seed": 1000, "controller.kind": ctl})
        assert run.config == cfg.model_dump(mode="json")  # the same run (name and description included)
        assert plan.spec.analysis.timeseries_rate == cfg.estimator.rate  # every trace row is kept
    assert set(plan.spec.analysis.timeseries_columns) | {"t", "R_R", "R_L", "cross_track_error"} >= set(pf.SERIES)


def _trace(cfg: RunConfig) -> dict[str, np.ndarray]:
    """A trace that differs by scenario and controller: the left radius shrinking to 0.1 m in scenario 4, the
    lift-off bit (with another flag bit and NaN rows around it) on some rows of scenario 3."""
    n = int(round(cfg.duration * cfg.estimator.rate))
    t = np.arange(n) / cfg.estimator.rate
    k = 1.0 if cfg.controller.kind == "nmpc" else 2.0
    flags = np.where((t > 1.0) & (t < 1.5), LIFTOFF | SCRAPE, np.where(t > 2.5, SCRAPE, 0)).astype(float)
    flags[::7] = np.nan
    R_L = np.maximum(2.0 - 0.9 * t, 0.1) if cfg.name == "scenario4" else np.full(n, 2.0)
    return {"t": t, "v": 10.0 - k * t, "yaw_rate": 0.2 + 0.05 * k * np.sin(t), "plant_flags": flags,
            "cross_track_error": 0.1 * k * t ** 2, "R_R": np.full(n, 2.0), "R_L": R_L,
            "omega_R": np.full(n, 5.0)}


def _fake_run(cfg: RunConfig, out_root: Path | None, rrd: bool) -> FakeOutcome:
    return FakeOutcome({"status": "ok"}, FakeResult(_trace(cfg)))


@pytest.fixture(scope="module")
def study_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The built-in study run with the fake runs (``EXTRA`` as ``--set``)."""
    out = tmp_path_factory.mktemp("pathfollow_figure")
    run_study(plan_study("pathfollow_figure", extra_overrides=EXTRA), out, serial=True, run_fn=_fake_run,
              analyse=False)
    return out


def _script_arrays(scenario: str, ctl: str) -> dict[str, np.ndarray]:
    """What the script computed from a run's full trace (its figure's cfg: scenario 4 with the --set)."""
    cfg = load_config(scenario, {**SETTINGS, **EXTRA, "seed": 1000, "controller.kind": ctl})
    tr = _trace(cfg)
    c4 = load_config("scenario4", EXTRA)
    lift = (np.nan_to_num(tr["plant_flags"]).astype(np.int64) & LIFTOFF) != 0
    return {"t": tr["t"], "v": tr["v"], "cte": tr["cross_track_error"], "a": tr["v"] * tr["yaw_rate"], "lift": lift,
            "V_f": np.minimum(max_path_speed(1.0 / c4.reference.radius, tr["R_R"], tr["R_L"], c4.plant_half_track,
                                             c4.robot.omega_max), c4.reference.speed)}


def test_figure_arrays_from_the_rows_equal_the_scripts(study_out: Path) -> None:
    seed, traces, status = pf.run_traces(pl.read_parquet(study_out / "results.parquet"))
    assert seed == 1000 and set(status.values()) == {"ok"}
    arrays = pf.figure_arrays(traces, load_config("scenario4", pf._set_overrides(study_out)))
    for ctl in pf.CONTROLLERS:
        s4, s3, d = _script_arrays("scenario4", ctl), _script_arrays("scenario3", ctl), arrays[ctl]
        assert d["t"].size == 300  # 3 s at 100 Hz: every row
        np.testing.assert_array_equal(d["t"], s4["t"])
        np.testing.assert_array_equal(d["speed"], s4["v"])
        np.testing.assert_array_equal(d["cross_track"], s4["cte"])
        np.testing.assert_array_equal(d["t3"], s3["t"])
        np.testing.assert_array_equal(d["lateral"], s3["a"])
        np.testing.assert_array_equal(d["lift"], s3["lift"])
        assert 0 < d["lift"].sum() < 50
    np.testing.assert_array_equal(arrays["pf-nmpc"]["feasible"], _script_arrays("scenario4", "pf-nmpc")["V_f"])
    assert arrays["pf-nmpc"]["feasible"].max() == 8.0 and arrays["pf-nmpc"]["feasible"].min() < 2.0
    assert "feasible" not in arrays["nmpc"]


def test_report_draws_the_scripts_panels(study_out: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    drawn: list[Any] = []
    real = pf.save_figure
    monkeypatch.setattr(pf, "save_figure", lambda fig, path: (drawn.append(fig), real(fig, path)))
    text = pf.report(study_out)
    png = study_out / "figures" / "pathfollow.png"
    assert text.splitlines()[0] == f"figure: {png} (seed 1000)" and png.read_bytes()[:4] == b"\x89PNG"
    # cte 0.2 t² and v 10 - 2 t at the last row (2.99 s); 42 lift-off rows of 10 ms (the NaN rows not counted)
    assert "| scenario4 | pf-nmpc | ok | 300 | 1.79 at 3.0 s | 4.02 | 0.42 |" in text
    assert "| scenario3 | nmpc | ok | 300 | 0.89 at 3.0 s | 7.01 | 0.42 |" in text
    (fig,) = drawn
    assert tuple(fig.get_size_inches()) == (9, 9)
    ax = fig.axes
    assert [a.get_title() for a in ax] == [
        "scenario 4 (left tyre 2 → 0.1 m, 10–29 s), seed 1000, UKF, safe, speed + yaw rate", "",
        "scenario 3 (left then right tyre 2 → 1 m at 5 s and 10 s)"]
    assert [a.get_ylabel() for a in ax] == ["speed (m/s)", "cross-track error (m)", "v · yaw rate (m/s²)"]
    assert [[(ln.get_label(), ln.get_color()) for ln in a.get_lines()] for a in ax] == [
        [("nmpc: speed", "tab:orange"), ("pf-nmpc: speed", "tab:blue"), ("feasible speed (true radii)", "k")],
        [("nmpc", "tab:orange"), ("pf-nmpc", "tab:blue")],
        [("nmpc: lateral acceleration", "tab:orange"), ("nmpc: wheel off the ground", "tab:orange"),
         ("pf-nmpc: lateral acceleration", "tab:blue"), ("pf-nmpc: wheel off the ground", "tab:blue")]]
    assert ax[0].get_lines()[2].get_linestyle() == "--"


def test_cli_report_and_its_refusals(study_out: Path, tmp_path: Path) -> None:
    res = runner.invoke(app, ["study", "pathfollow_figure", "--report", "--out", str(study_out)])
    assert res.exit_code == 0, res.output
    assert res.output.startswith(f"figure: {study_out / 'figures' / 'pathfollow.png'} (seed 1000)\n")
    df = pl.read_parquet(study_out / "results.parquet")
    for name, rows, message in (("partial", df.head(3), "no run of scenario4, pf-nmpc, seed 1000"),
                                ("short", df.drop("ts_plant_flags"), "the results keep no ts_plant_flags")):
        (tmp_path / name).mkdir()
        rows.write_parquet(tmp_path / name / "results.parquet")
        with pytest.raises(BadInput, match=message):
            pf.report(tmp_path / name)
        res = runner.invoke(app, ["study", "pathfollow_figure", "--report", "--out", str(tmp_path / name)])
        assert res.exit_code == 2 and res.output.startswith("ftc-mj: error: --report: ")
        assert len(res.output.strip().splitlines()) == 1
        assert not (tmp_path / name / "figures").exists()
