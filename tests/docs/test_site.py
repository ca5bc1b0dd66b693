"""The documentation site builds from the repository, offline and warning-free (``sphinx-build -W``), with
the API reference generated from the docstrings and the CLI reference generated from the typer app.

The build (about 20 s of CPU) is the one a user runs, in a fresh output folder: a broken link between pages,
a docstring that is not valid reStructuredText or an ambiguous cross-reference fails it."""

from __future__ import annotations

import importlib
import os
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

import ftc_mj

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"


@pytest.fixture(scope="module")
def conf():
    """``docs/conf.py`` as a module (its docstring helpers)."""
    saved = list(sys.path)
    sys.path.insert(0, str(DOCS))
    try:
        yield importlib.import_module("conf")
    finally:
        sys.path[:] = saved  # conf.py puts the checkout and docs/ first


def test_the_site_builds_with_warnings_as_errors(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-E", "-q", "-W", "--keep-going", "-b", "html",
                           "-d", str(tmp_path / "doctrees"), str(DOCS), str(tmp_path / "html")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-5000:]
    html = tmp_path / "html"
    cli = (html / "cli.html").read_text()
    for command in ("ftc-mj run", "ftc-mj bench", "ftc-mj study", "ftc-mj paper"):
        assert f">{command}<" in cli, command  # a section per command, from the live CLI
    assert "--split" in cli and "--reconfig" in cli
    api = (html / "api" / "estimation.html").read_text()
    assert 'id="ftc_mj.estimation.ukf.UKF"' in api  # autodoc rendered the class, not its source text
    assert (html / "performance.html").is_file() and (html / "usage.html").is_file()


def test_every_module_has_its_api_page() -> None:
    """``docs/api/`` documents every module of the package once (a new module needs its line)."""
    listed = re.findall(r"^\.\. automodule:: (\S+)$", "\n".join(p.read_text() for p in (DOCS / "api").glob("*.md")),
                        re.M)
    modules = {"ftc_mj", *(m.name for m in pkgutil.walk_packages(ftc_mj.__path__, "ftc_mj."))}
    assert len(listed) == len(set(listed)) and set(modules) - set(listed) == set() and set(listed) <= modules


def test_relative_roles_resolve_like_relative_imports(conf) -> None:
    """``:mod:`.report``` in a module of ``ftc_mj.benchmark`` names ``ftc_mj.benchmark.report``; in a package's
    own docstring the package is the start."""
    import ftc_mj.benchmark.run  # noqa: F401
    import ftc_mj.sim.loop  # noqa: F401

    assert conf.package_of("ftc_mj.benchmark.run") == "ftc_mj.benchmark"
    assert conf.package_of("ftc_mj.sim.loop.SimResult.record") == "ftc_mj.sim"
    assert conf.package_of("ftc_mj.sim") == "ftc_mj.sim"
    text = "outputs (:mod:`.report`), :func:`~.record.build_record`, :meth:`record`, :mod:`ftc_mj.io`"
    assert conf.absolute_roles(text, "ftc_mj.sim") == ("outputs (:mod:`~ftc_mj.sim.report`), "
                                                      ":func:`~ftc_mj.sim.record.build_record`, :meth:`record`, "
                                                      ":mod:`ftc_mj.io`")


def test_every_relative_role_in_the_docstrings_names_a_real_object(conf) -> None:
    """Each ``:role:`.name``` of the package's sources, read as a relative import, is an object that exists."""
    missing = []
    for path in sorted((ROOT / "ftc_mj").rglob("*.py")):
        module = ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for name in re.findall(r":(?:mod|func|class|meth|data|attr|exc|obj):`~?\.(?!\.)([\w.]+)`", path.read_text()):
            if not _resolves(f"{package}.{name}"):
                missing.append(f"{module}: .{name}")
    assert not missing, missing


def test_no_role_is_split_across_lines() -> None:
    """A target broken at a line end after a dot (``:func:`~a.b.`` / ``c```) names nothing: Sphinx reads ``a.b.``
    and ``c`` as two words (a title with ``<target>`` may wrap)."""
    split = [f"{path.relative_to(ROOT)}:{i}" for path in sorted((ROOT / "ftc_mj").rglob("*.py"))
             for i, line in enumerate(path.read_text().splitlines(), 1)
             if re.search(r":(?:mod|func|class|meth|data|attr|exc|obj):`~?[\w.]*\.$", line)]
    assert not split


def _resolves(dotted: str) -> bool:
    """``dotted`` names a module, or an attribute (class member included) of one."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            if not hasattr(obj, attr) and attr not in getattr(obj, "__annotations__", {}) \
                    and attr not in getattr(obj, "model_fields", {}):
                return False
            obj = getattr(obj, attr, None)
        return True
    return False


@pytest.mark.parametrize(("text", "expected"), [
    ("|cross-track error| from 5 s", r"\|cross-track error\| from 5 s"),
    ("``|x|`` and `|y|`", "``|x|`` and `|y|`"),
    ("``int | None``, a | b", "``int | None``, a | b"),
    ("| a | b |", "| a | b |"),
])
def test_absolute_value_bars_are_not_substitutions(conf, text: str, expected: str) -> None:
    assert conf.escape_bars(text) == expected


def test_clicks_no_rewrap_marker_becomes_a_literal_block(conf) -> None:
    """A CLI command's ``\\b`` line (its help example kept as written) reads as ``::`` and a blank line on the
    page; other lines pass unchanged."""
    assert conf.click_literal(["A file:", "", "\b", "    x = 1"]) == ["A file:", "", "::", "", "    x = 1"]
    assert conf.click_literal(["    \b"]) == ["::", ""] and conf.click_literal(["a b"]) == ["a b"]
