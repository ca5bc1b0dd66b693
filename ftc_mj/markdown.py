"""The one Markdown table helper: every generated table (a study's ``summary.md``, the paper's
``claims.md``, the benchmark's leaderboard, the published tables of ``docs/``) is built here.

A table is a header row, a separator ``|---|---|`` and one row per record; cells are joined as
``| a | b |``. :func:`cell` is the one escaper: a ``|`` inside a cell is written ``\\|`` and a line
break becomes a space, so that a cell never splits its row. The helper sits below every package that
writes Markdown (study, paper, benchmark, reports, rerun, metrics), so that none of them has to import
another for it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any


def cell(text: Any) -> str:
    """``text`` safe inside a Markdown table cell (``|`` escaped, no line breaks)."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def row(cells: Iterable[Any]) -> str:
    """One table row ``| a | b |`` of the cells as given (escape them with :func:`cell` where needed)."""
    return "| " + " | ".join(str(c) for c in cells) + " |"


def separator(n: int) -> str:
    """The separator row of a table of ``n`` columns: ``|---|---|``."""
    return "|" + "---|" * n


def table(header: Sequence[Any], rows: Iterable[Iterable[Any]] = ()) -> list[str]:
    """The lines of a table: the header row, the separator and one line per row (cells as given)."""
    return [row(header), separator(len(header)), *(row(r) for r in rows)]


def dict_table(rows: Sequence[Mapping[str, Any]], fmt: Callable[[Any], str] = str, empty: str = "_no data_") -> str:
    """A table of dict rows (columns: the union of the keys in first-seen order; every cell escaped,
    values shown with ``fmt``), ending in a newline; ``empty`` (and a newline) when there are no rows."""
    if not rows:
        return empty + "\n"
    keys: list[str] = []
    for r in rows:
        keys.extend(k for k in r if k not in keys)
    body = ([cell(fmt(r.get(k))) for k in keys] for r in rows)
    return "\n".join(table([cell(k) for k in keys], body)) + "\n"
