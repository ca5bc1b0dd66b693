"""The documented plug-in command works as printed from the folder holding the module (the current
directory is searched as ``python -m`` does), and every server the tool starts listens on
127.0.0.1 unless the user names another host: the study dashboard given as ``:PORT``, and the
Rerun viewer's gRPC server started by ``ftc-mj view``."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from ftc_mj.rerun.viewer import VIEWER_HOST, viewer_command
from ftc_mj.study.cluster import validate_dashboard

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "my_components.py"


def documented_command() -> list[str]:
    """The command line the example's docstring prints, as argv after ``ftc-mj``."""
    text = EXAMPLE.read_text()
    line = text.split("``ftc-mj ", 1)[1].split("``", 1)[0]
    return line.split()


def test_the_plugin_command_works_as_printed_from_the_module_folder(tmp_path: Path) -> None:
    shutil.copy(EXAMPLE, tmp_path / EXAMPLE.name)
    args = documented_command()
    assert args == ["run", "scenario2", "--plugin", "my_components", "--estimator", "textbook-ekf"]
    # -P: no script or current folder on sys.path, as the installed console script `ftc-mj` starts
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-P", "-c", "from ftc_mj.cli import app; app()", *args,
                           "--duration", "1", "--no-rrd", "-q", "--out", "out"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    (run_dir,) = (tmp_path / "out").iterdir()
    assert "textbook-ekf" in run_dir.name


def test_a_dashboard_without_a_host_listens_on_localhost_only() -> None:
    """``--dashboard :PORT`` names no host: 127.0.0.1 (a named host is kept). The sockets of a cluster
    opened so are checked while it runs by ``test_local_cluster_listens_on_localhost_only``: the suite's
    session cluster is opened with ``":0"``."""
    assert validate_dashboard(":0") == "127.0.0.1:0" and validate_dashboard(":8787") == "127.0.0.1:8787"
    assert validate_dashboard("0.0.0.0:0") == "0.0.0.0:0"


VIEWER_LAUNCHES = 8
"""Launches of the viewer the test makes at most. Without a display its window fails at once, and on a loaded
machine that can end the process before its server has started (3 of 12 launches with three busy loops on two
cores), so a launch that never listened is made again; at that rate 8 all fail about once in 65 000 runs."""


def _launch_viewer(cmd: list[str], env: dict[str, str], psutil: Any) -> tuple[str, list]:
    """Run the viewer ``cmd`` until its server says it listens (at most 20 s): its output and the listening
    sockets sampled meanwhile."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)  # type: ignore[arg-type]
    reader.start()
    seen: list = []
    try:
        viewer = psutil.Process(proc.pid)
        deadline = time.monotonic() + 20
        while proc.poll() is None and time.monotonic() < deadline:
            try:
                seen += [c for c in viewer.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN]
            except psutil.Error:
                break
            if seen and any("Listening for gRPC" in ln for ln in list(lines)):
                break  # listening, and it said where (the window may fail later without a display)
            time.sleep(0.005)
    finally:
        proc.kill()
        proc.wait(timeout=10)
        reader.join(timeout=10)
    return "".join(lines), seen


def test_the_viewer_server_binds_to_localhost(tmp_path: Path) -> None:
    """The command ``ftc-mj view`` starts, run for real: Rerun's gRPC server listens on 127.0.0.1
    (its own log line says where; without a display the window fails right after, so the
    sockets are sampled while it runs, and a launch that ended before its server started is made again,
    :data:`VIEWER_LAUNCHES`)."""
    psutil = pytest.importorskip("psutil")
    from ftc_mj.rerun.record import write_rrd
    from tests.support.synthetic import synthetic_run

    trace, solves, events, ref = synthetic_run(1.0)
    write_rrd(tmp_path / "run.rrd", trace, run_id="r", solves=solves, events=events, reference_path=ref)
    cmd = viewer_command(tmp_path / "run.rrd", ["--port", "0"])
    assert cmd[-4:] == ["--bind", VIEWER_HOST, "--port", "0"] and VIEWER_HOST == "127.0.0.1"
    env = {**os.environ, "XDG_CONFIG_HOME": str(tmp_path), "XDG_DATA_HOME": str(tmp_path),
           "XDG_CACHE_HOME": str(tmp_path)}
    for _ in range(VIEWER_LAUNCHES):
        out, seen = _launch_viewer(cmd, env, psutil)
        if "Listening for gRPC" in out:
            break
    assert "Listening for gRPC connections on 127.0.0.1:" in out, out[-2000:]
    assert "0.0.0.0" not in out
    assert all(c.laddr.ip == "127.0.0.1" for c in seen), seen


def message_strings() -> list[tuple[str, int, str]]:
    """Every string literal of the package that is not a docstring (what the tool can print), with its
    file and line; the paper's report texts (written into claims.md and, by the reports layer, into the
    repository's docs/paper-claims.md) left out."""
    import ast

    import ftc_mj

    pkg = Path(ftc_mj.__file__).parent
    out = []
    for path in pkg.rglob("*.py"):
        if "paper" in path.relative_to(pkg).parts or path.relative_to(pkg) == Path("reports/paper_claims.py"):
            continue
        tree = ast.parse(path.read_text())
        # docstrings, also of attributes: bare string statements
        docstrings = {id(n.value) for n in ast.walk(tree) if isinstance(n, ast.Expr)}
        for n in ast.walk(tree):
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docstrings:
                out.append((str(path.relative_to(pkg)), n.lineno, n.value))
    return out


def test_printed_messages_name_no_file_the_wheel_lacks() -> None:
    """A message naming a repository file (``docs/…``, ``examples/…``, ``benchmarks/…``) says it is in the
    source repository; files the tool itself points at are shipped in the package (``ftc_mj/data``)."""
    import re

    bad = [(f, ln, s) for f, ln, s in message_strings()
           if re.search(r"(?<![\w/])(docs|examples|benchmarks)/\w", s) and "source repository" not in s]
    assert bad == [], bad
