"""A method's identity covers its code: the ftc-mj version and source, and the content of each plug-in
module. An edited plug-in module is another method — a new digest, so a new row of the leaderboard's
scoring history and a bench its old output folder refuses — never a silent replacement."""

from __future__ import annotations

import re

from ftc_mj import __version__
from ftc_mj.benchmark.methods import code_identity, load_method, module_digest
from ftc_mj.benchmark.report import log_scoring, scoring_history
from ftc_mj.benchmark.run import plan_bench, prepare_output
from ftc_mj.identity import source_identity
from ftc_mj.study.store import StudyStore

PLUGIN = "judge_identity_plugin"


def test_a_built_in_method_names_the_package_and_its_source() -> None:
    code = load_method("safe").code
    assert code == {"ftc_mj": __version__, "source": source_identity(), "plugins": {}}
    assert re.fullmatch(r"git [0-9a-f]{7,40}|.+\+sources [0-9a-f]{16}", code["source"])


def test_an_edited_plugin_module_makes_a_new_row(tmp_path, monkeypatch) -> None:
    monkeypatch.syspath_prepend(str(tmp_path))
    module = tmp_path / f"{PLUGIN}.py"
    module.write_text('"""A plug-in module of a method (registers nothing)."""\nGAIN = 1.0\n')
    (tmp_path / "m.toml").write_text(f'name = "mine"\nplugins = ["{PLUGIN}"]\n[settings]\n'
                                     '"reconfiguration.policy" = "none"\n')
    first = load_method(str(tmp_path / "m.toml"))
    assert first.code["plugins"] == {PLUGIN: module_digest(PLUGIN)} == code_identity(first)["plugins"]
    assert load_method(str(tmp_path / "m.toml")).digest == first.digest  # the same code: the same method
    module.write_text('"""A plug-in module of a method (registers nothing)."""\nGAIN = 2.0\n')
    edited = load_method(str(tmp_path / "m.toml"))
    assert edited.settings == first.settings and edited.digest != first.digest

    out = tmp_path / "out"
    bp1 = plan_bench([first], "test", 2)
    prepare_output(bp1, out)
    StudyStore(out).init(bp1.plan)
    log_scoring(bp1, out)
    bp2 = plan_bench([edited], "test", 2)
    StudyStore(out).check(bp2.plan)  # the folder takes the edited method beside the old one ...
    assert not {r.key for r in bp1.plan.runs} & {r.key for r in bp2.plan.runs}  # ... as runs of its own: no replacement
    log_scoring(bp2, out)  # both identities scored in one folder: two rows
    rows = [ln for ln in scoring_history(bp2, out)[2:]]
    assert len(rows) == 2 and all(ln.startswith("| mine | ") for ln in rows)
    assert f"`{first.digest}`" in rows[0] and rows[0].endswith("| 1 | no |")
    assert f"`{edited.digest}`" in rows[1] and rows[1].endswith("| 1 | yes |")
    log_scoring(bp2, out)
    assert scoring_history(bp2, out)[3].endswith("| 2 | yes |")
