"""docs/benchmark.md's distribution tables are the ones :func:`definition_tables` generates from the
published definition ``ftc-v1``, byte for byte (the page is generated; a change of the table code or of
the definition shows here before the page is republished)."""

from __future__ import annotations

from pathlib import Path

from ftc_mj.benchmark.definition import load_definition
from ftc_mj.reports.benchmark_page import definition_tables

DOCS = Path(__file__).resolve().parents[2] / "docs" / "benchmark.md"


def test_the_published_distributions_are_the_generated_ones() -> None:
    generated = "\n".join(definition_tables(load_definition("ftc-v1")))
    assert generated.count("\n| ") > 15, "the tables are missing"
    assert generated in DOCS.read_text(), "regenerate docs/benchmark.md (ftc-mj bench … --publish docs)"
