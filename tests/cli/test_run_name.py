"""A run's id shows what differs: ``ftc-mj run --name NAME`` names the run, whose folder (the run id) starts
with it; without ``--name`` the id is the one every earlier run of that config got (``<scenario>_…``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from ftc_mj import api
from ftc_mj.cli import app
from ftc_mj.identity import run_id


def _run(tmp_path: Path, *args: str) -> str:
    res = CliRunner().invoke(app, ["run", "scenario2", "--duration", "0.2", "--no-rrd", "-q", "--out",
                                   str(tmp_path), *args])
    assert res.exit_code == 0, res.output
    return Path(res.stdout.strip().splitlines()[-1]).name


def test_two_runs_differing_in_a_setting_are_told_apart_by_their_names(tmp_path: Path) -> None:
    a = _run(tmp_path, "--name", "gyro-0.01", "--set", "sensors.yaw_rate_sigma=0.01")
    b = _run(tmp_path, "--name", "gyro-0.05", "--set", "sensors.yaw_rate_sigma=0.05")
    assert a.startswith("gyro-0.01_ukf_") and b.startswith("gyro-0.05_ukf_")
    plain = _run(tmp_path)
    assert plain == run_id(api.load_config("scenario2", {"duration": 0.2})) and plain.startswith("scenario2_ukf_")


@pytest.mark.parametrize("bad", ["a b", "../x", ""])
def test_a_name_that_is_no_file_name_is_refused(tmp_path: Path, bad: str) -> None:
    res = CliRunner().invoke(app, ["run", "scenario2", "--duration", "0.2", "--name", bad, "--out", str(tmp_path)])
    assert res.exit_code == 2 and "--name" in res.output and not any(tmp_path.iterdir())
