"""``ftc-mj compare``: one recording overlaying several runs, read back with ``rerun.chunk.RrdReader``;
``ftc-mj view`` of several runs; comparisons of a claim's runs (``paper --rrd compare``) and of a
study's runs (``study --rrd compare``)."""

from __future__ import annotations

import json
import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
from rerun.chunk import RrdReader
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.errors import BadInput
from ftc_mj.rerun.overlay import claim_run_dirs, entity_token, load_runs, write_comparison
from ftc_mj.rerun.read import read_scalar_series


@pytest.fixture(scope="module")
def runs(policy_runs: list[Path]) -> list[Path]:
    """Scenario 2 shortened (puncture at 3 s, 5 s) with a gyro and the rate penalty, policy none vs safe
    (the session's ``policy_runs``: the safe hand-over follows the puncture within a second)."""
    return policy_runs


def entities(path: Path) -> set[str]:
    return {str(c.entity_path) for c in RrdReader(str(path)).stream().to_chunks()}


def test_compare_two_runs_one_recording_with_blueprint(runs: list[Path], tmp_path: Path) -> None:
    out = tmp_path / "cmp.rrd"
    res = CliRunner().invoke(app, ["compare", *map(str, runs), "--out", str(out)])
    assert res.exit_code == 0, res.stderr
    *table, last = res.stdout.strip().splitlines()
    assert last == str(out)
    # the key metrics side by side in the terminal: a column per run, its values from its metrics.json
    assert table[0].split() == ["metric", "policy=none", "policy=safe"]
    row = {ln.split()[0]: ln.split()[1:] for ln in table[1:]}
    metrics = [json.loads((d / "metrics.json").read_text()) for d in runs]
    assert row["folder"] == [d.name for d in runs]
    assert row["status"] == [m["status"] for m in metrics]
    assert row["cross_track_rms"][1:] == [f"{m['cross_track_rms']:.3g}" for m in metrics]
    rd = RrdReader(str(out))
    assert len(rd.recordings()) == 1 and len(rd.blueprints()) == 1
    ents = entities(out)
    for tok in ("policy_none", "policy_safe"):  # default labels: what differs between the runs
        for sub in ("path", "robot", "radius/left/estimate", "radius/left/truth", "radius/right/model",
                    "cross_track_error", "wheel_rate/left", "reconfig_state", "events"):
            assert f"/runs/{tok}/{sub}" in ents, (tok, sub)
    assert "/reference" in ents and "/summary" in ents
    # the series are the runs' traces, on the shared sim_time timeline
    for tok, d in zip(("policy_none", "policy_safe"), runs, strict=True):
        tr = pq.read_table(d / "trace.parquet")
        t, v = read_scalar_series(out, f"/runs/{tok}/radius/left/estimate")
        np.testing.assert_allclose(t, tr.column("t").to_numpy(), atol=1e-9)
        np.testing.assert_array_equal(v, tr.column("R_L_hat").to_numpy())
    # the safe run handed its estimate over after the puncture, the none run never did
    _, s_safe = read_scalar_series(out, "/runs/policy_safe/reconfig_state")
    _, s_none = read_scalar_series(out, "/runs/policy_none/reconfig_state")
    assert np.nanmax(s_safe) == 2.0 and np.nanmax(s_none) == 0.0


def test_labels_name_the_entities(runs: list[Path], tmp_path: Path) -> None:
    out = tmp_path / "l.rrd"
    res = CliRunner().invoke(app, ["compare", *map(str, runs), "--out", str(out), "--labels", "feedback off,safe"])
    assert res.exit_code == 0, res.stderr
    ents = entities(out)
    assert "/runs/feedback_off/path" in ents and "/runs/safe/path" in ents
    for labels, msg in ((["a"], "--labels: 1 labels for 2 runs"), (["x,x"], "must differ"),
                        (["a+", "a*"], "must differ")):
        res = CliRunner().invoke(app, ["compare", *map(str, runs), "--out", str(tmp_path / "m.rrd"),
                                       *[a for lb in labels for a in ("--labels", lb)]])
        assert res.exit_code == 2 and msg in res.stderr, res.stderr
    assert not (tmp_path / "m.rrd").exists()
    res = CliRunner().invoke(app, ["compare", *map(str, runs), "--out", str(out)])
    assert res.exit_code == 2 and "exists" in res.stderr
    assert CliRunner().invoke(app, ["compare", *map(str, runs), "--out", str(out), "--overwrite"]).exit_code == 0


def test_events_come_from_the_run_recordings(runs: list[Path]) -> None:
    (none, safe) = load_runs(runs)
    assert any("fault injected" in e.text for e in safe.events)
    assert any("hand" in e.text for e in safe.events)  # the safe policy's hand-over event
    assert none.reference is not None and none.reference.shape[1] == 2


def test_view_of_several_runs_opens_their_comparison(runs: list[Path], monkeypatch: pytest.MonkeyPatch) -> None:
    import ftc_mj.rerun.viewer as viewer

    seen: list[tuple[list[str], set[str]]] = []

    class Done:
        returncode = 0

    def fake_viewer(cmd: list[str], check: bool = False) -> Done:
        seen.append((cmd, entities(Path(cmd[1]))))
        return Done()

    monkeypatch.setattr(viewer.subprocess, "run", fake_viewer)
    monkeypatch.setenv("DISPLAY", ":99")
    res = CliRunner().invoke(app, ["view", *map(str, runs)])
    assert res.exit_code == 0, res.stderr
    (cmd, ents), = seen
    assert cmd[1].endswith("comparison.rrd") and "/runs/policy_none/path" in ents
    assert not Path(cmd[1]).exists()  # the temporary comparison is removed when the viewer closes


@dataclass
class _Check:
    text: str
    detail: str = ""


@dataclass
class _Claim:
    id: str
    table: list[dict[str, Any]] = field(default_factory=list)
    checks: list[_Check] = field(default_factory=list)


def test_claim_comparisons(runs: list[Path], tmp_path: Path) -> None:
    rows = [{"label": "s2-ukf-nofb-nmpc", "run_dir": str(runs[0])},
            {"label": "s2-ukf-nofb-nmpc-rp", "run_dir": str(runs[1])}]
    claims = [_Claim("1", table=[{"run": "s2-ukf-nofb-nmpc"}], checks=[_Check("s2-ukf-nofb-nmpc-rp beats it")]),
              _Claim("2", checks=[_Check("no run named")])]
    found = claim_run_dirs(claims, rows)
    assert found == [("1", ["s2-ukf-nofb-nmpc", "s2-ukf-nofb-nmpc-rp"], runs), ("2", [], [])]
    path = write_comparison(found[0][2], tmp_path / "claim-1.rrd", found[0][1])
    assert {f"/runs/{entity_token(lb)}/path" for lb in found[0][1]} <= entities(path)
    # what ``paper --rrd compare`` does with a finished matrix: one file per claim with two or more runs
    from types import SimpleNamespace

    from ftc_mj.cli import _claim_comparisons

    paths = _claim_comparisons(SimpleNamespace(claims=claims, rows=rows), tmp_path / "compare")
    assert paths == [tmp_path / "compare" / "claim-1.rrd"]
    assert RrdReader(str(paths[0])).recordings()[0].recording_id == "claim-1"


def test_study_rrd_compare(tmp_path: Path) -> None:
    p = tmp_path / "s.toml"
    p.write_text(textwrap.dedent("""
        name = "cmp"
        scenario = "scenario1"
        [base]
        duration = 0.5
        "controller.kind" = "open-loop"
        [[axes]]
        key = "controller.open_loop_omega"
        values = [[5.0, 5.0], [5.0, 4.0]]
        labels = ["straight", "turn"]
        [analysis]
        figures = false
    """))
    res = CliRunner().invoke(app, ["study", str(p), "--out", str(tmp_path / "out"), "--serial", "--rrd", "compare",
                                   "-q"])
    assert res.exit_code == 0, res.stderr
    assert "comparison of 2 runs" in res.stderr
    ents = entities(tmp_path / "out" / "compare.rrd")
    assert {"/runs/controller_open_loop_omega_straight/path", "/runs/controller_open_loop_omega_turn/path"} <= ents


def test_not_a_run_directory(tmp_path: Path) -> None:
    with pytest.raises(BadInput, match="RUN_DIR: .* is not a run directory"):
        load_runs([tmp_path])
    (tmp_path / "trace.parquet").write_text("x")
    with pytest.raises(BadInput, match="not a readable Parquet file"):
        load_runs([tmp_path])
