"""The one Markdown table helper (:mod:`ftc_mj.markdown`): the exact bytes of its rows (every generated
page depends on them), and that no cell content can break a row's columns."""

from __future__ import annotations

import re

from ftc_mj.markdown import cell, dict_table, row, separator, table


def columns(line: str) -> int:
    """The number of cells of a table line (``|`` not preceded by a backslash delimit them)."""
    return len(re.split(r"(?<!\\)\|", line)) - 2


def test_rows_and_separator_are_the_published_bytes() -> None:
    assert row(["a", 1, 2.5]) == "| a | 1 | 2.5 |"
    assert separator(3) == "|---|---|---|"
    assert table(["x", "y"], [["1", "2"], ["3", "4"]]) == ["| x | y |", "|---|---|", "| 1 | 2 |", "| 3 | 4 |"]
    assert table(["x"]) == ["| x |", "|---|"]


def test_an_escaped_cell_never_splits_its_row() -> None:
    nasty = ["a|b", "line\nbreak", "|", "||\n|", "plain", "trailing\\"[:-1]]
    lines = table([cell(f"h{i}|") for i in range(len(nasty))], [[cell(t) for t in nasty]])
    assert all(columns(ln) == len(nasty) for ln in lines), lines
    assert all("\n" not in ln for ln in lines)
    assert cell("a|b\nc") == "a\\|b c" and cell(3) == "3"


def test_dict_table_unites_the_keys_in_first_seen_order() -> None:
    rows = [{"b": 1, "a|x": "p|q"}, {"c": None, "b": 2}]
    text = dict_table(rows, fmt=lambda v: "—" if v is None else str(v))
    assert text == ("| b | a\\|x | c |\n|---|---|---|\n| 1 | p\\|q | — |\n| 2 | — | — |\n")
    assert dict_table([]) == "_no data_\n"
