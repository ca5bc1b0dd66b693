"""Tests of :mod:`ftc_mj.rerun.viewer`: the native viewer is started on a run's recording (the
subprocess is replaced; ``ftc-mj view`` itself is tested in tests/test_run.py and
tests/test_bad_input_cases.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ftc_mj.errors import BadInput
from ftc_mj.rerun import viewer
from ftc_mj.rerun.viewer import open_viewer


def test_open_viewer(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(BadInput):
        open_viewer(tmp_path / "missing.rrd")
    with pytest.raises(BadInput):
        open_viewer(tmp_path)                            # a run dir without run.rrd
    (tmp_path / "run.rrd").write_bytes(b"x")
    seen: list[list[str]] = []

    class Done:
        returncode = 0

    def fake_run(cmd: list[str], check: bool = False) -> Done:
        seen.append(cmd)
        return Done()

    monkeypatch.setattr(viewer.subprocess, "run", fake_run)
    open_viewer(tmp_path)
    assert seen and seen[0][1] == str(tmp_path / "run.rrd") and Path(seen[0][0]).name == "rerun"
    assert seen[0][2:4] == ["--bind", "127.0.0.1"]  # the viewer's gRPC server: this machine only
