"""A plug-in that fails where ftc-mj cannot see inside it still ends the command with one line: a
controller whose constructor raises (exit 1, not a traceback) and a module that calls ``sys.exit`` on
import (exit 2, not a silent exit 0)."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ftc_mj import registry
from ftc_mj.cli import app
from ftc_mj.sim.loop import STRICT_ENV

RAISING = textwrap.dedent('''
    import ftc_mj


    class Fragile:
        def __init__(self, settings, context, reference):
            raise ValueError("gain schedule file not found: gains.csv")


    ftc_mj.register_controller("fragile-ctor", Fragile)
''')


@pytest.fixture
def plugin_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """A folder on ``sys.path`` for plug-in modules; what they import and register is undone afterwards."""
    folder = tmp_path / "plugins"
    folder.mkdir()
    monkeypatch.syspath_prepend(str(folder))
    before = set(registry.controllers.names())
    yield folder
    for name in ("fragile_ctor_q", "exits_on_import_q"):
        sys.modules.pop(name, None)
        registry._loaded_plugins.discard(name)
    for name in set(registry.controllers.names()) - before:
        registry.controllers.unregister(name)


def test_a_plugin_controller_whose_constructor_raises_is_one_line(plugin_dir: Path, tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    (plugin_dir / "fragile_ctor_q.py").write_text(RAISING)
    monkeypatch.setenv(STRICT_ENV, "0")
    args = ["run", "scenario2", "--plugin", "fragile_ctor_q", "--controller", "fragile-ctor", "--duration", "1",
            "--set", "plant.kind='kinematic'", "--no-rrd", "-q", "--out", str(tmp_path / "out")]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 1, res.stdout + res.stderr
    assert res.stderr.count("\n") == 1 and res.stdout == ""
    assert res.stderr.startswith("ftc-mj: error: the run's components could not be built: ValueError: gain "
                                 "schedule file not found: gains.csv (")
    assert "fragile_ctor_q.py:7 in __init__)" in res.stderr
    # strict mode (the suite's default) re-raises the component's own exception
    monkeypatch.setenv(STRICT_ENV, "1")
    res = CliRunner().invoke(app, args)
    assert isinstance(res.exception, ValueError)


@pytest.mark.parametrize("code", ["0", "None", "3", "'bye'"])
def test_a_plugin_calling_sys_exit_on_import_is_named_in_one_line(plugin_dir: Path, tmp_path: Path,
                                                                  code: str) -> None:
    (plugin_dir / "exits_on_import_q.py").write_text(f"import sys\nsys.exit({code})\n")
    res = CliRunner().invoke(app, ["run", "scenario2", "--plugin", "exits_on_import_q", "--duration", "1",
                                   "--out", str(tmp_path / "out")])
    assert res.exit_code == 2, res.stdout + res.stderr
    assert res.stderr == (f"ftc-mj: error: --plugin: importing 'exits_on_import_q' called sys.exit({eval(code)!r}); "
                          "a plug-in module must only define and register its components\n")
    assert not (tmp_path / "out").exists()
