"""The benchmark definition's and the method files' bad input: one line naming the field (in-process),
the built-in methods' digests, the plan of a bench (no simulation) and the tuning studies' seal."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ftc_mj.benchmark.definition import definition_path, load_definition, parse_definition
from ftc_mj.benchmark.methods import BUILTIN, load_method, load_methods
from ftc_mj.benchmark.run import plan_bench
from ftc_mj.cli import app
from ftc_mj.errors import BadInput
from ftc_mj.study.plan import plan_study


def _data() -> dict:
    return tomllib.loads(definition_path("ftc-v1").read_text())


@pytest.mark.parametrize(("edit", "field"), [
    (lambda d: d["fault"]["classes"].update(none=0.5), "fault"),
    (lambda d: d["plant"].update(tyre_friction=[1.2, 0.7]), "plant.tyre_friction"),
    (lambda d: d["seeds"].update(dev=[0, 2000]), "seeds"),
    (lambda d: d["seeds"].update(test=[10, 20]), "seeds"),
    (lambda d: d["path"]["kinds"].update(spiral=0.0), "path"),
    (lambda d: d["splits"].update(test=d["splits"]["dev"]), "splits"),
    (lambda d: d.update(extra=1), "extra"),
])
def test_bad_definitions_name_the_field(edit, field):
    data = _data()
    edit(data)
    with pytest.raises(BadInput) as err:
        parse_definition(data, "benchmark x.toml")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"benchmark x.toml: {field}"), msg


def test_the_shipped_definition_and_an_unknown_version():
    assert load_definition("ftc-v1").version == "ftc-v1"
    with pytest.raises(BadInput, match="ftc-v9"):
        load_definition("ftc-v9")


def _method(tmp_path: Path, text: str) -> str:
    p = tmp_path / "m.toml"
    p.write_text(text)
    return str(p)


@pytest.mark.parametrize(("text", "needle"), [
    ('name = "x"\n[settings]\n"faults.left" = []\n', "settings.faults.left: a method sets only"),
    ('name = "x"\n[settings]\n"estimator.kindd" = "ukf"\n', "settings.estimator.kindd"),
    ('name = "x"\n[settings]\n"controller.kind" = "no-such"\n', "controller.kind"),
    ('name = "../x"\n', "name"),
    ('name = "x"\ncolour = 1\n', "colour"),
])
def test_bad_method_files_name_the_field(tmp_path, text, needle):
    with pytest.raises(BadInput) as err:
        m = load_method(_method(tmp_path, text))
        plan_bench([m], "dev", 1)
    assert needle in str(err.value) and "\n" not in str(err.value)


def test_methods_digests_and_the_plan(tmp_path):
    ms = load_methods(list(BUILTIN))
    assert len({m.digest for m in ms}) == len(ms)
    same = load_method(_method(tmp_path, 'name = "mine"\n[settings]\nestimator = { kind = "ukf" }\n'
                                         '"controller.rate_penalty" = 1.0\n"reconfiguration.policy" = "safe"\n'
                                         '[settings.reconfiguration.accommodation]\nmode = "all"\n'))
    assert same.digest == load_method("safe").digest  # resolved settings, not the way they are written
    with pytest.raises(BadInput, match="given twice"):
        load_methods(["safe", "safe"])
    with pytest.raises(BadInput, match="resolve to the same runs"):
        plan_bench([load_method("safe"), same], "dev", 1)
    bp = plan_bench(ms[:2], "test", 3, start=5, healthy=True)
    assert [r.labels["draw"] for r in bp.plan.runs] == [5, 6, 7, 5, 6, 7]
    assert all(r.seed >= 1000 and r.config["faults"]["left"] == [] for r in bp.plan.runs)
    assert plan_bench(ms[:2], "test", 3, start=5, healthy=True).plan.study_hash == bp.plan.study_hash
    assert plan_bench(ms[:2], "dev", 3, start=5, healthy=True).plan.study_hash != bp.plan.study_hash
    # the methods are not the folder's identity: a method added to an --out computes only its own runs
    assert plan_bench(ms[:1], "test", 3, start=5, healthy=True).plan.study_hash == bp.plan.study_hash


def test_a_folder_of_an_earlier_bench_takes_more_methods(tmp_path):
    """A folder whose plan.json identity still holds the methods (written before they left it) is adopted
    when the rest is this bench's, and then passes the store's check; a folder of other draws is not."""
    import json

    from ftc_mj.benchmark.run import adopt_earlier_bench
    from ftc_mj.study.store import StudyStore

    ms = load_methods(["safe", "feedback-off"])
    bp = plan_bench(ms, "dev", 2)
    for folder, draws in (("same", 2), ("other", 3)):
        old = plan_bench(ms[:1], "dev", draws)
        ident = {**old.plan.identity, "methods": {"safe": ms[0].digest}}
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "plan.json").write_text(json.dumps({**old.plan.to_json(), "study_hash": "0" * 16,
                                                                "identity": ident}))
    assert adopt_earlier_bench(bp, tmp_path / "same") and not adopt_earlier_bench(bp, tmp_path / "other")
    StudyStore(tmp_path / "same").check(bp.plan)
    with pytest.raises(BadInput, match="different study"):
        StudyStore(tmp_path / "other").check(bp.plan)


def test_tuning_studies_refuse_held_out_seeds(tmp_path):
    (tmp_path / "t.toml").write_text('name = "t"\nscenario = "scenario1"\nseeds = [3, 1000]\ntuning = true\n')
    with pytest.raises(BadInput, match="held-out seed 1000"):
        plan_study(tmp_path / "t.toml")
    (tmp_path / "u.toml").write_text('name = "u"\nscenario = "scenario1"\nseeds = [3, 1000]\n')
    assert len(plan_study(tmp_path / "u.toml").runs) == 2  # not a tuning study: judged on held-out seeds
    for name in ("tune_dwell", "tune_growth", "robust_hybrid_dev"):
        with pytest.raises(BadInput, match="tuning study"):
            plan_study(name, seeds=1001)
    res = CliRunner().invoke(app, ["study", "tune_dwell", "--seeds", "1001", "--list"])
    assert res.exit_code == 2
    assert len(res.stderr.strip().splitlines()) == 1 and "tuning study" in res.stderr


def test_bench_command_bad_input_is_one_line(tmp_path):
    for args, needle in ((["no-such-method"], "METHOD"), (["safe", "--draws", "0"], "--draws"),
                         (["safe", "--split", "train"], "--split"), (["safe", "--workers", "0"], "--workers")):
        res = CliRunner().invoke(app, ["bench", *args, "--out", str(tmp_path / "o")])
        assert res.exit_code == 2, (args, res.output)
        assert len(res.stderr.strip().splitlines()) == 1 and needle in res.stderr, res.stderr
    assert not (tmp_path / "o").exists()
