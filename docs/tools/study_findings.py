"""Copy the generated findings of the shipped studies into docs/studies.md (between the GENERATED
FINDINGS markers), verbatim from each ``runs/out/studies/<name>/summary.md``.

    .venv/bin/python docs/tools/study_findings.py      # after `ftc-mj study <name>`

A study without an output folder here keeps the section already in docs/studies.md.
"""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
STUDIES = ("observability", "mismatch", "severity", "physical_plant", "reconfiguration", "excitation")
START, END = "<!-- GENERATED FINDINGS START -->", "<!-- GENERATED FINDINGS END -->"


def section(name: str) -> str:
    md = (REPO / "runs" / "out" / "studies" / name / "summary.md").read_text()
    runs = re.search(r"^Runs: (.*?)\.", md, re.M)
    body = md.split("## Findings", 1)[1].split("\n## ", 1)[0].strip()
    return f"#### `{name}` — generated findings (runs: {runs.group(1) if runs else '?'})\n\n{body}\n"


def main() -> None:
    doc = REPO / "docs" / "studies.md"
    text = doc.read_text()
    head, rest = text.split(START, 1)
    tail = rest.split(END, 1)[1]
    old = {m.group(1): m.group(0).strip() + "\n" for m in
           re.finditer(r"^#### `([a-z_]+)`.*?(?=^#### `|\Z)", rest.split(END, 1)[0], re.M | re.S)}
    parts = [section(n) if (REPO / "runs" / "out" / "studies" / n / "summary.md").is_file() else old[n]
             for n in STUDIES if n in old or (REPO / "runs" / "out" / "studies" / n / "summary.md").is_file()]
    doc.write_text(head + START + "\n\n" + "\n".join(parts) + "\n" + END + tail)


if __name__ == "__main__":
    main()
