"""``examples/gym_random_policy.py`` as shipped runs what docs/gym.md describes: the page's duration and seed
are the example's defaults, and at those defaults the tracking law is on the path and a benchmark success while
random wheel rates are not."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.cli.test_examples import _run

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "gym_random_policy.py"


def _defaults() -> dict[str, float]:
    """The example's argparse defaults of ``--duration`` and ``--seed``."""
    found = re.findall(r'add_argument\("--(duration|seed)", type=\w+, default=([\d.]+)\)', EXAMPLE.read_text())
    return {k: float(v) for k, v in found}


def test_the_page_quotes_the_examples_defaults() -> None:
    page = (ROOT / "docs" / "gym.md").read_text()
    quoted = re.search(r"`examples/gym_random_policy\.py`.*?\((\d+) s, seed (\d+)", page, flags=re.S)
    assert quoted, "docs/gym.md no longer quotes the example's run"
    assert _defaults() == {"duration": float(quoted.group(1)), "seed": float(quoted.group(2))}
    assert f"[--duration {quoted.group(1)}]" in EXAMPLE.read_text()  # its usage line too


@pytest.mark.slow
def test_the_example_at_its_defaults_does_what_the_page_says(tmp_path: Path) -> None:
    """docs/gym.md: the law stays within 0.12 m RMS of the circle through the puncture and scores a success;
    random rates 43 m, not a success (a run long enough to be judged: no ``not judged``)."""
    rows = {ln.split()[0]: ln.split() for ln in _run("gym_random_policy.py", [], tmp_path).splitlines()[1:]}
    assert rows["tracking"][3:] == ["True", "on", "the", "path"] and float(rows["tracking"][2]) < 0.13
    assert rows["random"][3] == "False" and float(rows["random"][2]) > 10.0
