"""The generated findings of a shipped study as published in docs/studies.md (between its GENERATED
FINDINGS markers): the ``## Findings`` section of the study's ``summary.md``, verbatim, under a heading
with the run count.

    ftc-mj study severity --report      # after `ftc-mj study severity`
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from ...errors import BadInput

STUDIES = ("observability", "mismatch", "severity", "physical_plant", "reconfiguration", "excitation")
"""The studies whose findings docs/studies.md publishes, in its order."""


def report(out: Path) -> str:
    """The docs/studies.md section of the study whose output folder is ``out`` (named as its ``plan.json`` says)."""
    summary = Path(out) / "summary.md"
    if not summary.is_file():
        raise BadInput(f"--report: {out} has no summary.md (run the study first)")
    md = summary.read_text()
    runs = re.search(r"^Runs: (.*?)\.", md, re.M)
    body = md.split("## Findings", 1)[1].split("\n## ", 1)[0].strip()
    plan = Path(out) / "plan.json"
    name = json.loads(plan.read_text()).get("study", Path(out).name) if plan.is_file() else Path(out).name
    return f"#### `{name}` — generated findings (runs: {runs.group(1) if runs else '?'})\n\n{body}\n"
