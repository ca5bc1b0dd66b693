"""Regenerate docs/paper-claims.md (and its figures in docs/figures/) from an ``ftc-mj paper`` output.

    .venv/bin/ftc-mj paper --quick --out runs/out/paper-quick         # single-seed verdicts (seed 0)
    .venv/bin/ftc-mj paper --out runs/out/paper --tune --baseline docs/paper-claims.md \
        --baseline runs/out/paper-quick                                 # the published and today's seed 0
    .venv/bin/python docs/tools/paper_claims.py runs/out/paper

The head note is generated: the command, commit, date and machine load from ``paper_run.json``, which
seeds are development and which held-out, the tuning results, and the verdicts that changed against
the baseline (``changes.md``, the mechanical comparison of :mod:`ftc_mj.paper.diff`); the body is
``claims.md`` verbatim, with the figure list cut to the figures copied into docs/figures/.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
FIGURES = ("imm_variants_s2.png", "innovations_s2.png", "mode_probs_nofb.png", "policies.png",
           "radius_comparison_s4.png", "radius_s1.png", "trajectory_nmpc_vs_lmpc.png", "trajectory_s2.png",
           "wheel_rates_s2_nmpc_vs_lmpc.png")
"""The figures kept in the repository (the output folder has all of them)."""


def head_note(out: Path) -> str:
    info = json.loads((out / "paper_run.json").read_text())
    load = "/".join(f"{x:.1f}" for x in (info.get("started_load_avg") or [])[:1] + (info.get("finished_load_avg")
                                                                                    or [])[:1])
    runs = info.get("runs_command")
    cmd = f"`{info['command']}`" + (f" from the runs of `{runs}`" if runs and runs != info["command"] else "")
    lines = [f"> Copied from `{out}/claims.md`, written by {cmd} (finished {info.get('finished_at')}, "
             f"commit {info.get('commit')}; {info['runs']} runs, {len(info.get('failed') or [])} failed, in "
             f"{info.get('wall_time_s') or 0:.0f} s + {info.get('report_time_s') or 0:.0f} s report on "
             f"{info.get('cpus')} cores, 1-min load average {load} at start/end). Regenerate with the commands "
             f"in `docs/tools/paper_claims.py`."]
    doc = json.loads((out / "claims.json").read_text())
    seeds = doc.get("seeds") or []
    lines.append(f"> Judged on the {doc.get('seed_set', '?')} seeds {', '.join(map(str, seeds))}; the development "
                 f"seeds 0–9 are where the data-tuned parameters are chosen (section *Seeds*).")
    for key, t in (info.get("tuning") or {}).items():
        lines.append(f"> Tuned on development seeds {', '.join(map(str, t['seeds']))}: `{key}` chosen "
                     f"{t['chosen']}, configured {t['default']} ({t['runs']} runs, section *Data-tuned parameters*).")
    changes = out / "changes.md"
    for section in changes.read_text().split("## Against ")[1:] if changes.is_file() else []:
        src, _, rest = section.partition("\n")
        verdicts = [ln[2:] for ln in rest.splitlines() if ln.startswith("- ") and "→" in ln]
        checks = [ln.strip()[2:] for ln in rest.splitlines() if ln.startswith("  - ") and "→" in ln]
        if checks:
            verdicts.append(f"{len(checks)} check result(s) changed: " + "; ".join(checks))
        lines.append(f"> **What changed against {src.strip()}**{_provenance(src.strip().strip('`'))} (mechanical "
                     f"comparison; every changed check is in the section *What changed against {src.strip()}*): "
                     + ("; ".join(verdicts) if verdicts else "nothing changed") + ".")
    return "\n>\n".join(lines) + "\n"


def _provenance(src: str) -> str:
    """`` (commit …, finished …; N seeds)`` for a baseline output folder that kept its ``paper_run.json``."""
    run = Path(src) / "paper_run.json"
    if not run.is_file():
        return ""
    info = json.loads(run.read_text())
    return f" (the `ftc-mj paper` output of commit {info.get('commit')}, finished {info.get('finished_at')})"


def body(out: Path) -> str:
    md = (out / "claims.md").read_text()
    main, _, figs = md.partition("\n## Figures\n")
    kept = [f for f in FIGURES if (out / "figures" / f).is_file()]
    if not kept:
        return main
    note = figs.strip().splitlines()[0] if figs.strip() and not figs.strip().startswith("- ") else ""
    return (main + "\n## Figures\n\n" + (note + " " if note else "") + "A selection; all of them are in the output "
            "folder.\n\n" + "\n".join(f"- [`figures/{f}`](figures/{f})" for f in kept) + "\n")


def main(argv: list[str]) -> None:
    out = Path(argv[1] if len(argv) > 1 else REPO / "runs" / "out" / "paper")
    (REPO / "docs" / "paper-claims.md").write_text(head_note(out) + "\n" + body(out))
    for f in FIGURES:
        if (out / "figures" / f).is_file():
            shutil.copyfile(out / "figures" / f, REPO / "docs" / "figures" / f)


if __name__ == "__main__":
    main(sys.argv)
