"""The ``cli-reference`` directive: every ``ftc-mj`` command's ``--help`` text, rendered from the typer
application at build time, so the command-line reference cannot drift from the CLI (``docs/cli.md``).

Typer bundles its own click, which sphinx-click does not recognise; the help texts here are the ones the
terminal prints (``ftc-mj COMMAND --help``), at a fixed width of 100 columns.
"""

from __future__ import annotations

from docutils import nodes
from sphinx.application import Sphinx
from sphinx.util.docutils import SphinxDirective

WIDTH = 100
"""Columns of the rendered help texts."""


def help_texts() -> dict[str, str]:
    """``{"": top-level help, "run": ftc-mj run --help, …}``, as the terminal prints them."""
    import typer

    from ftc_mj.cli import app

    group = typer.main.get_command(app)
    ctx = group.make_context("ftc-mj", [], resilient_parsing=True, terminal_width=WIDTH, max_content_width=WIDTH)
    texts = {"": group.get_help(ctx)}
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        sub = cmd.make_context(name, [], parent=ctx, resilient_parsing=True, terminal_width=WIDTH,
                               max_content_width=WIDTH)
        texts[name] = cmd.get_help(sub)
    return texts


class CLIReference(SphinxDirective):
    """``cli-reference``: the help of ``ftc-mj`` and of each of its commands, one section each with the help
    text as a literal block (built as nodes: the directive may sit in a Markdown page)."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        sections = []
        for name, text in help_texts().items():
            title = f"ftc-mj {name}".strip()
            section = nodes.section(ids=[nodes.make_id(title)], names=[nodes.fully_normalize_name(title)])
            section += nodes.title(title, title)
            section += nodes.literal_block(text, text, language="none")
            self.state.document.note_implicit_target(section)
            sections.append(section)
        return sections


def setup(app: Sphinx) -> dict[str, bool]:
    app.add_directive("cli-reference", CLIReference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
