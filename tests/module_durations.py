"""Write tests/module_durations.json — each test module's summed duration (s) — from the durations of the last
session in pytest's cache (``.pytest_cache``; run the whole suite first): the order a fresh clone's session
starts its modules in (tests/conftest.py).

    .venv/bin/python tests/module_durations.py
"""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    """Sum the cached per-test durations by module and write them, sorted by module."""
    tests = json.loads((ROOT / ".pytest_cache" / "v" / "ftc-mj" / "durations").read_text())
    modules: dict[str, float] = {}
    for node, seconds in tests.items():
        module = node.split("::", 1)[0]
        modules[module] = modules.get(module, 0.0) + float(seconds)
    out = {m: round(s, 1) for m, s in sorted(modules.items())}
    (ROOT / "tests" / "module_durations.json").write_text(json.dumps(out, indent=0) + "\n")


if __name__ == "__main__":
    main()
