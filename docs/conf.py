"""Sphinx configuration of the ftc-mj documentation site (``sphinx-build -W --keep-going -b html docs OUT``).

The Markdown pages of ``docs/`` are read by MyST; the API reference is generated from the docstrings by
autodoc (``docs/api/``: one page per package, every module listed, which ``tests/docs/test_site.py``
checks); the CLI reference from the typer application by the ``cli-reference`` directive of
``docs/_cli.py`` (``docs/cli.md``). The build is offline (no intersphinx) and warning-free.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from sphinx.ext import napoleon

DOCS = Path(__file__).resolve().parent
sys.path[:0] = [str(DOCS.parent), str(DOCS)]  # this checkout's package, and _cli (the CLI reference directive)

import ftc_mj  # noqa: E402

project = "ftc-mj"
author = "ftc-mj contributors"
copyright = "ftc-mj contributors"  # noqa: A001
release = version = ftc_mj.__version__

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.mathjax", "_cli"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build"]  # where the README builds the site
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

autodoc_default_options = {"members": True, "ignore-module-all": True}  # each object once: where it is defined
autodoc_member_order = "bysource"
autodoc_typehints = "none"
autodoc_inherit_docstrings = False
napoleon_numpy_docstring = True
napoleon_google_docstring = True  # both styles occur (Args: and Parameters)
nitpicky = False

html_theme = "alabaster"
html_title = f"ftc-mj {release}"
html_static_path: list[str] = []

_LITERAL = re.compile(r"(``.+?``|`[^`]+`)")
_BARS = re.compile(r"(?<![\w|])\|(?=\S)([^|`]+?)(?<=\S)\|(?![\w|])")


def escape_bars(text: str) -> str:
    """``|x|`` outside inline literals as plain bars: the docstrings write absolute values so
    (``|cross-track error|``), which reStructuredText would read as substitution references."""
    parts = _LITERAL.split(text)
    return "".join(p if i % 2 else _BARS.sub(r"\\|\1\\|", p) for i, p in enumerate(parts))


_RELATIVE = re.compile(r"(:(?:mod|func|class|meth|data|attr|exc|obj):`)(~?)\.(?!\.)([A-Za-z_][\w.]*`)")


def package_of(name: str) -> str:
    """The package a documented object's relative names start from, as in ``from .x import y``: the
    package itself for a package's docstring, else the package of the module that defines the object."""
    parts = name.split(".")
    module = next(m for m in (".".join(parts[:i]) for i in range(len(parts), 0, -1)) if m in sys.modules)
    return module if hasattr(sys.modules[module], "__path__") else module.rpartition(".")[0]


def absolute_roles(text: str, package: str) -> str:
    """``:mod:`.report``` written in a module of ``ftc_mj.benchmark`` names ``ftc_mj.benchmark.report``, as a
    relative import would; Sphinx would read the leading dot as "any object of that name" (ambiguous)."""
    return _RELATIVE.sub(lambda m: f"{m[1]}~{package}.{m[3]}", text)


def click_literal(lines: list[str]) -> list[str]:
    """Click's no-rewrap marker (a line holding only ``\\b``, which keeps a CLI command's help example as
    written) as reStructuredText's ``::`` and a blank line: the indented block after it is a literal block on the
    page too."""
    out: list[str] = []
    for ln in lines:
        out += ["::", ""] if ln.strip() == "\b" else [ln]
    return out


def _process_docstring(app, what, name, obj, options, lines: list[str]) -> None:  # noqa: ANN001
    package = package_of(name)
    lines[:] = [absolute_roles(escape_bars(ln), package) for ln in click_literal(lines)]


def _napoleon_except_attributes(app, what, name, obj, options, lines: list[str]) -> None:  # noqa: ANN001
    """Napoleon on functions, classes and modules only: on an attribute or property it reads a first line
    ``text: more`` as ``type: description``, and the docstrings here write such lines as prose."""
    if what not in ("attribute", "data", "property"):
        napoleon._process_docstring(app, what, name, obj, options, lines)


def setup(app) -> None:  # noqa: ANN001
    app.setup_extension("sphinx.ext.napoleon")
    listeners = app.events.listeners["autodoc-process-docstring"]
    listeners[:] = [lst for lst in listeners if lst.handler is not napoleon._process_docstring]
    app.connect("autodoc-process-docstring", _napoleon_except_attributes)
    app.connect("autodoc-process-docstring", _process_docstring)
