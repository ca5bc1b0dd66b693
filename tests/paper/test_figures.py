"""Figures and the report metrics of ``ftc-mj paper`` on fake run directories (a kinematic robot with
made-up filter outputs), written like real runs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from ftc_mj.config import validate_config
from ftc_mj.paper.claims import evaluate_all
from ftc_mj.paper.derived import onsets_of_config, report_metrics
from ftc_mj.paper.figures import make_figures, read_run_dir
from ftc_mj.paper.matrix_study import kept_columns
from ftc_mj.paper.render import render_claims
from ftc_mj.paper.verdicts import combine


def test_report_metrics_and_claims_from_run_dirs(fake_run_dirs: dict[str, Path]) -> None:
    rows = {}
    for lb, d in fake_run_dirs.items():
        trace, cfg = read_run_dir(d)
        assert trace is not None and cfg
        rows[lb] = {"status": "ok", **json.loads((d / "metrics.json").read_text()),
                    **report_metrics(validate_config(cfg), trace)}
    r = rows["s2-ukf-fb-nmpc"]
    assert r["settle_delay_L"] is not None and 0.5 < r["settle_delay_L"] < 3.0
    assert rows["s2-imm-ukf-fb-nmpc"]["mode_delay_1"] is not None
    assert read_run_dir(None) == (None, {})
    assert onsets_of_config(json.loads(json.dumps({"faults": {"left": [[10.0, 2.0], [10.0, 1.0]]}}))) == {
        "right": None, "left": 10.0}
    md = render_claims(combine({0: evaluate_all(rows)}, single_seed=True), {0: rows}, {}, single_seed=True)
    assert "s2-ukf-fb-lmpc" in md


def test_figures_sequential_and_in_worker_processes(fake_run_dirs: dict[str, Path], tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """Every figure whose runs exist is drawn (the others skipped, not an error); worker processes
    write the same PNGs as the sequential rendering. Run folders without a recording keep
    :func:`~ftc_mj.paper.matrix_study.kept_columns` of the trace: every column a figure asks for (noted
    during the sequential rendering) is among them."""
    from ftc_mj.paper import figures

    real = figures.read_run_dir

    def noting(run_dir: Path | None) -> tuple[Any, dict[str, Any]]:
        trace, cfg = real(run_dir)
        return (None if trace is None else _Reads(trace)), cfg

    with monkeypatch.context() as m:
        m.setattr(figures, "read_run_dir", noting)
        figs = make_figures(fake_run_dirs, tmp_path / "seq")
    assert _Reads.asked and set(kept_columns(sorted(_Reads.asked))) == _Reads.asked
    names = {p.name for p in figs}
    for expected in ("innovations_s2.png", "radius_s2.png", "trajectory_s2.png", "wheel_rates_s2_nmpc_vs_lmpc.png",
                     "radius_comparison_s4.png", "mode_probs_fb.png", "imm_variants_s2.png",
                     "trajectory_nmpc_vs_lmpc.png"):
        assert expected in names
    for p in figs:
        assert p.stat().st_size > 5_000
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "radius_s1.png" not in names  # no scenario 1 runs: skipped, not an error
    two = {lb: fake_run_dirs[lb] for lb in ("s2-ukf-fb-nmpc", "s2-ukf-fb-lmpc")}  # a few figures, in workers
    seq = make_figures(two, tmp_path / "seq2")
    par = make_figures(two, tmp_path / "par", jobs=2)
    assert [p.name for p in par] == [p.name for p in seq] and len(seq) >= 3
    for a, b in zip(seq, par, strict=True):
        assert a.read_bytes() == b.read_bytes()


class _Reads(dict):
    """A trace that notes every column asked for (read or tested)."""

    asked: set[str] = set()

    def __getitem__(self, k: str) -> Any:
        self.asked.add(k)
        return super().__getitem__(k)

    def get(self, k: str, default: Any = None) -> Any:
        self.asked.add(k)
        return super().get(k, default)

    def __contains__(self, k: object) -> bool:
        self.asked.add(str(k))
        return super().__contains__(k)
