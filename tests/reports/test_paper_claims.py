"""``ftc-mj paper --publish DOCS``: ``DOCS/paper-claims.md`` and the figure selection from a fake output folder.
The published text is what the paper-claims script this option replaced (deleted with the other docs tools) wrote
from the same folder, kept below as :data:`SCRIPT_TEXT`, but for the sentence that says how to regenerate it; bad
input is one line naming ``--publish``, exit 2, nothing written. Fast: nothing runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.errors import BadInput
from ftc_mj.paper import run as paper_run
from ftc_mj.reports.paper_claims import REGENERATE, publish

runner = CliRunner()
KEPT = ("policies.png", "radius_s1.png", "trajectory_s2.png")
"""Figures of the published selection present in the fake folder."""
OTHER = ("nis_s2.png",)
"""A figure of the output folder that is not published."""

SCRIPT_TEXT = """\
> Copied from `{out}/claims.md`, written by `ftc-mj paper --out {out} --jobs 2 --seeds 3 --seed-set held-out \
--report-only --tune` from the runs of `ftc-mj paper --out {out} --jobs 2 --seeds 3 --seed-set held-out --tune` \
(finished 2026-12-02 04:53 UTC, commit 5233819-dirty; 12 runs, 1 failed, in 1273 s + 26 s report on 2 cores, 1-min \
load average 2.3/3.3 at start/end). {regenerate}
>
> Judged on the held-out seeds 1000, 1001, 1002; the development seeds 0–9 are where the data-tuned parameters are \
chosen (section *Seeds*).
>
> Tuned on development seeds 0, 1, 2: `estimator.decision.dwell` chosen 0.5, configured 0.5 (45 runs, section \
*Data-tuned parameters*).
>
> Tuned on development seeds 0, 1, 2: `reconfiguration.max_growth_rate` chosen 0.2, configured 0.05 (21 runs, \
section *Data-tuned parameters*).
>
> **What changed against `{base}`** (the `ftc-mj paper` output of commit abc1234, finished 2026-11-30 10:00 UTC) \
(mechanical comparison; every changed check is in the section *What changed against `{base}`*): claim 1: refuted → \
supported; 2 check result(s) changed: check 1a: fail → pass; check 1b: 2/3 → 3/3.
>
> **What changed against `docs/paper-claims.md`** (mechanical comparison; every changed check is in the section \
*What changed against `docs/paper-claims.md`*): nothing changed.

# The paper's claims

Some text.

## Verdicts

| claim | verdict |
|---|---|
| 1 | supported |

## Figures

Drawn from the runs of seed 1000 (one seed; the verdicts above use all 3). A selection; all of them are in the \
output folder.

- [`figures/policies.png`](figures/policies.png)
- [`figures/radius_s1.png`](figures/radius_s1.png)
- [`figures/trajectory_s2.png`](figures/trajectory_s2.png)
"""
"""What the deleted paper-claims script wrote to docs/paper-claims.md from :func:`fake_paper_out`'s folder
(``{out}``, ``{base}``: its paths), its sentence pointing to the script's own instructions now ``{regenerate}``."""


def fake_paper_out(root: Path) -> tuple[Path, Path]:
    """``root/paper``, a seeded ``ftc-mj paper`` output rebuilt with ``--report-only`` (tuning, two baselines,
    one failed run, figures), and its first baseline ``root/base``, an output folder that kept its
    ``paper_run.json``."""
    out, base = root / "paper", root / "base"
    (out / "figures").mkdir(parents=True)
    base.mkdir()
    (base / "paper_run.json").write_text(json.dumps({"commit": "abc1234", "finished_at": "2026-11-30 10:00 UTC"}))
    (out / "paper_run.json").write_text(json.dumps({
        "command": f"ftc-mj paper --out {out} --jobs 2 --seeds 3 --seed-set held-out --report-only --tune",
        "runs_command": f"ftc-mj paper --out {out} --jobs 2 --seeds 3 --seed-set held-out --tune",
        "finished_at": "2026-12-02 04:53 UTC", "commit": "5233819-dirty", "runs": 12, "failed": ["s2-x (seed 1001)"],
        "wall_time_s": 1273.4, "report_time_s": 25.6, "cpus": 2, "started_load_avg": [2.31, 2.0, 1.5],
        "finished_load_avg": [3.27, 2.5, 2.0],
        "tuning": {"estimator.decision.dwell": {"chosen": 0.5, "default": 0.5, "seeds": [0, 1, 2], "runs": 45},
                   "reconfiguration.max_growth_rate": {"chosen": 0.2, "default": 0.05, "seeds": [0, 1, 2],
                                                       "runs": 21}}}))
    (out / "claims.json").write_text(json.dumps({"mode": "seeded", "seed_set": "held-out", "seeds": [1000, 1001, 1002],
                                                 "claims": []}))
    (out / "claims.md").write_text("# The paper's claims\n\nSome text.\n\n## Verdicts\n\n| claim | verdict |\n"
                                   "|---|---|\n| 1 | supported |\n\n## Figures\n\nDrawn from the runs of seed 1000 "
                                   "(one seed; the verdicts above use all 3).\n\n"
                                   + "".join(f"- [`figures/{f}`](figures/{f})\n" for f in (*KEPT, *OTHER)))
    (out / "changes.md").write_text(f"## Against `{base}`\n\n- claim 1: refuted → supported\n  - check 1a: fail → "
                                    f"pass\n  - check 1b: 2/3 → 3/3\n- claim 4: unchanged text\n\n"
                                    "## Against `docs/paper-claims.md`\n\n- nothing\n\n")
    for f in (*KEPT, *OTHER):
        (out / "figures" / f).write_bytes(b"\x89PNG " + f.encode())
    return out, base


def test_published_text_is_the_scripts_with_the_real_commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # a baseline path is read relative to the working directory
    out, base = fake_paper_out(tmp_path)
    docs = tmp_path / "docs"
    (docs / "figures").mkdir(parents=True)
    written = publish(out, docs)
    assert (docs / "paper-claims.md").read_text() == SCRIPT_TEXT.format(out=out, base=base, regenerate=REGENERATE)
    assert REGENERATE.startswith("Regenerate with `ftc-mj paper --quick --out runs/out/paper-quick`")
    assert "--publish docs" in REGENERATE
    assert written == [docs / "paper-claims.md", *(docs / "figures" / f for f in KEPT)]
    for f in KEPT:
        assert (docs / "figures" / f).read_bytes() == (out / "figures" / f).read_bytes()
    assert not (docs / "figures" / OTHER[0]).exists()
    # without a figure of the selection the figure list goes; without changes.md no "What changed"
    for f in KEPT:
        (out / "figures" / f).unlink()
    (out / "changes.md").unlink()
    publish(out, docs)
    text = (docs / "paper-claims.md").read_text()
    assert "## Figures" not in text and "What changed" not in text
    assert text.endswith("| 1 | supported |\n")


def test_cli_publishes_after_the_report(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--report-only --publish``: the report (faked here: the folder's files as they are) then the docs."""
    out, _ = fake_paper_out(tmp_path)
    docs = tmp_path / "docs"
    docs.mkdir()
    monkeypatch.setattr(paper_run, "run_matrix_and_report",
                        lambda out, entries, opts, show, echo: paper_run.PaperResult(out, [], [], [], 0.0, 1.0))
    res = runner.invoke(app, ["paper", "--report-only", "--seeds", "3", "--out", str(out), "--publish", str(docs)])
    assert res.exit_code == 0, res.output
    assert f"  published: {docs / 'paper-claims.md'} and 3 figure(s) in {docs / 'figures'}" in res.output
    first = (docs / "paper-claims.md").read_text().splitlines()[0]
    assert first.startswith(f"> Copied from `{out}/claims.md`, written by `ftc-mj paper --out {out} --jobs 2 --seeds 3 "
                            f"--seed-set held-out --report-only --publish {docs}` from the runs of `ftc-mj paper --out "
                            f"{out} --jobs 2 --seeds 3 --seed-set held-out --tune` (finished ")
    assert first.endswith(REGENERATE)
    assert json.loads((out / "paper_run.json").read_text())["command"].endswith(f"--publish {docs}")


def test_bad_publish_target_is_one_line_exit_2_nothing_written(tmp_path: Path) -> None:
    out = tmp_path / "o"
    f = tmp_path / "file"
    f.write_text("x")
    (tmp_path / "docs").mkdir()
    for args, message in (([str(f)], f"--publish: {f} is not a directory"),
                          ([str(tmp_path / "missing")], "--publish: "),
                          ([""], "--publish: expected a folder path"),
                          ([str(tmp_path / "docs"), "--quick"], "--publish: publishes verdicts over seeds")):
        res = runner.invoke(app, ["paper", "--out", str(out), "--publish", *args])
        assert res.exit_code == 2, (args, res.output)
        lines = res.output.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"ftc-mj: error: {message}"), (args, res.output)
        assert not out.exists() and f.read_text() == "x" and not any((tmp_path / "docs").iterdir())
    with pytest.raises(BadInput, match="--publish: .* is not a directory"):
        publish(tmp_path, f)
