"""``ftc-mj paper --publish DOCS``: the report of an output folder published as ``DOCS/paper-claims.md``, with
the figure selection :data:`FIGURES` copied into ``DOCS/figures/``.

The head note is generated: the command, commit, date and machine load from ``paper_run.json``, which
seeds are development and which held-out, the tuning results, and the verdicts that changed against
the baseline (``changes.md``, the mechanical comparison of :mod:`ftc_mj.paper.diff`); the body is ``claims.md``
verbatim, with the figure list cut to the figures copied.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from ..io import atomic_path
from ..paper.run import check_target

FIGURES = ("imm_variants_s2.png", "innovations_s2.png", "mode_probs_nofb.png", "policies.png",
           "radius_comparison_s4.png", "radius_s1.png", "trajectory_nmpc_vs_lmpc.png", "trajectory_s2.png",
           "wheel_rates_s2_nmpc_vs_lmpc.png")
"""The figures kept in the repository (the output folder has all of them)."""

REGENERATE = ("Regenerate with `ftc-mj paper --quick --out runs/out/paper-quick` (the single-seed baseline), then "
              "`ftc-mj paper --out runs/out/paper --tune --baseline docs/paper-claims.md --baseline "
              "runs/out/paper-quick --publish docs` (add `--report-only` to rebuild from finished runs).")
"""The last sentence of the head note's first paragraph: the commands that make the published file."""


def head_note(out: Path) -> str:
    """The generated block quote that opens ``paper-claims.md``: provenance of the output folder ``out``,
    the seed sets, the tuned parameters and what changed against each baseline."""
    info = json.loads((out / "paper_run.json").read_text())
    load = "/".join(f"{x:.1f}" for x in (info.get("started_load_avg") or [])[:1] + (info.get("finished_load_avg")
                                                                                    or [])[:1])
    runs = info.get("runs_command")
    cmd = f"`{info['command']}`" + (f" from the runs of `{runs}`" if runs and runs != info["command"] else "")
    lines = [f"> Copied from `{out}/claims.md`, written by {cmd} (finished {info.get('finished_at')}, "
             f"commit {info.get('commit')}; {info['runs']} runs, {len(info.get('failed') or [])} failed, in "
             f"{info.get('wall_time_s') or 0:.0f} s + {info.get('report_time_s') or 0:.0f} s report on "
             f"{info.get('cpus')} cores, 1-min load average {load} at start/end). {REGENERATE}"]
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
    """`` (the `ftc-mj paper` output of commit …, finished …)`` for a baseline output folder (a path as given on
    the command line, relative to the working directory) that kept its ``paper_run.json``; empty otherwise."""
    run = Path(src) / "paper_run.json"
    if not run.is_file():
        return ""
    info = json.loads(run.read_text())
    return f" (the `ftc-mj paper` output of commit {info.get('commit')}, finished {info.get('finished_at')})"


def body(out: Path) -> str:
    """``claims.md`` of ``out`` with its figure list cut to the :data:`FIGURES` the folder has (the list's
    leading note kept)."""
    md = (out / "claims.md").read_text()
    main, _, figs = md.partition("\n## Figures\n")
    kept = [f for f in FIGURES if (out / "figures" / f).is_file()]
    if not kept:
        return main
    note = figs.strip().splitlines()[0] if figs.strip() and not figs.strip().startswith("- ") else ""
    return (main + "\n## Figures\n\n" + (note + " " if note else "") + "A selection; all of them are in the output "
            "folder.\n\n" + "\n".join(f"- [`figures/{f}`](figures/{f})" for f in kept) + "\n")


def publish(out: Path, docs: Path) -> list[Path]:
    """Write ``docs/paper-claims.md`` (:func:`head_note` and :func:`body` of the output folder ``out``) and copy
    the selected figures into ``docs/figures/``; the files written, ``paper-claims.md`` first."""
    check_target(docs)
    out, docs = Path(out), Path(docs)
    text = head_note(out) + "\n" + body(out)
    written = [docs / "paper-claims.md"]
    with atomic_path(written[0]) as tmp:
        tmp.write_text(text)
    for f in FIGURES:
        if (out / "figures" / f).is_file():
            with atomic_path(docs / "figures" / f) as tmp:
                shutil.copyfile(out / "figures" / f, tmp)
            written.append(docs / "figures" / f)
    return written
