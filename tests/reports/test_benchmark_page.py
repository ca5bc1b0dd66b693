"""docs/benchmark.md's distribution tables are the ones :func:`definition_tables` generates from the
published definition ``ftc-v1``, byte for byte (the page is generated; a change of the table code or of
the definition shows here before the page is republished)."""

from __future__ import annotations

from pathlib import Path

from ftc_mj.benchmark.definition import load_definition
from ftc_mj.reports.benchmark_page import definition_tables

DOCS = Path(__file__).resolve().parents[2] / "docs" / "benchmark.md"


def test_the_published_distributions_are_the_generated_ones() -> None:
    generated = "\n".join(definition_tables(load_definition("ftc-v2")))  # the published version
    assert generated.count("\n| ") > 15, "the tables are missing"
    assert generated in DOCS.read_text(), "regenerate docs/benchmark.md (ftc-mj bench … --publish docs)"


def test_the_draw_count_analysis_states_ftc_v1s_fixed_count_and_its_power() -> None:
    """ftc-v1 fixes 200 leaderboard draws; the page's table gives, per discordance, the fewest draws that reach
    80 % power for 5 points after Holm over the 12 verdicts (so that count reaches it) and the power of 200."""
    from ftc_mj.benchmark.stats import mcnemar_power
    from ftc_mj.reports.benchmark_page import POWER_DISCORDANCES, power_section

    d = load_definition("ftc-v1")
    assert d.leaderboard_draws == 200
    lines = power_section(d)
    assert "`leaderboard_draws = 200`" in lines[0] and "0.05/12" in lines[0]
    body = lines[4:]
    assert len(body) == len(POWER_DISCORDANCES)
    for psi, line in zip(POWER_DISCORDANCES, body, strict=True):
        _, share, need, power, _ = line.split("|")
        assert share.strip() == f"{100 * psi:g} %" and mcnemar_power(int(need), 0.05, psi, k=12) >= 0.8
        assert power.strip() == f"{100 * mcnemar_power(200, 0.05, psi, k=12):.0f} %"
