"""The diagnosis in a closed-loop run: the built-in diagnoser's declaration reaches the trace, the events, the
metrics and the summary; ``diagnosis.kind = "none"`` runs without one; a plug-in diagnoser registered by name
replaces it."""

from __future__ import annotations

import numpy as np
import pytest

import ftc_mj
from ftc_mj.estimation.diagnosis import DiagnosisInput, DiagnosisStep
from ftc_mj.model.diagnosis import Diagnosis
from ftc_mj.registry import diagnosers
from ftc_mj.sim.summary import diagnosis_lines


def test_a_servo_loss_is_diagnosed_in_a_mujoco_run_and_reaches_every_record() -> None:
    run = ftc_mj.run(ftc_mj.load_config("actuator_loss", {"duration": 14.0}), rrd=False)
    m = run.metrics
    assert [(d["component"], d["target"], d["mode"]) for d in m["diagnoses"]] == [("servo", "left", "loss")]
    fault = m["diagnosis_faults"][0]
    assert fault["isolated"] and 0.0 < fault["isolation_delay"] < 2.0
    assert abs(fault["size_error"]) <= 0.2 * 0.5  # the size within 20 % of the remaining gain (0.5)
    assert m["diagnosis_false_declarations"] == 0 and m["diagnosis_alarms"]["servo_L"] >= 1
    assert any(e.text.startswith("diagnosis: servo left loss") for e in run.events)
    count = run.trace["diag_count"].to_numpy()
    assert count[0] == 0 and count[-1] == 1
    assert any("servo left loss" in line for line in diagnosis_lines(m))


def test_a_servo_loss_under_the_path_following_nmpc_is_declared_by_the_load_test() -> None:
    """The `pathfollow` method's loop (pf-nmpc, every mode accommodated): its smooth commands give the servo
    regression nothing to identify from, the lag step at the same wheel rates gives the gain (docs/fdi.md)."""
    overrides = {"duration": 13.0, "controller.kind": "pf-nmpc", "controller.rate_penalty": 1.0,
                 "reconfiguration.policy": "safe", "reconfiguration.accommodation.mode": "all"}
    m = ftc_mj.run(ftc_mj.load_config("actuator_loss", overrides), rrd=False).metrics
    fault = m["diagnosis_faults"][0]
    assert fault["declared"] == "servo/left/loss" and 0.0 < fault["isolation_delay"] < 2.0
    assert abs(fault["size_error"]) <= 0.2 * 0.5  # within 20 % of the remaining gain (0.5); measured +0.006
    assert m["diagnosis_false_declarations"] == 0


def test_without_a_diagnoser_nothing_is_declared_nor_scored() -> None:
    run = ftc_mj.run(ftc_mj.load_config("scenario1", {"duration": 1.0, "diagnosis.kind": "none"}), rrd=False)
    assert "diagnoses" not in run.metrics
    assert np.isnan(run.trace["diag_count"].to_numpy()).all()


class _AlwaysLeft:
    """A plug-in diagnoser that declares a left puncture at its first step."""

    def __init__(self, settings: object, context: object) -> None:
        self.declared: list[Diagnosis] = []

    def step(self, z: DiagnosisInput) -> DiagnosisStep:
        new = [] if self.declared else [Diagnosis("tyre", "left", "puncture", 0.5, 0.01, z.t, z.t, 1.0, 0.5)]
        self.declared += new
        return DiagnosisStep({"tyre_L": 1.0}, {"tyre_L": True}, new, list(self.declared))


@pytest.fixture
def plugin():
    diagnosers.register("always-left", _AlwaysLeft)
    yield "always-left"
    diagnosers.unregister("always-left")


def test_a_plugin_diagnoser_replaces_the_built_in_one(plugin: str) -> None:
    run = ftc_mj.run(ftc_mj.load_config("scenario1", {"duration": 1.0, "diagnosis.kind": plugin}), rrd=False)
    assert [d["mode"] for d in run.metrics["diagnoses"]] == ["puncture"]
    assert run.metrics["diagnosis_false_declarations"] == 1  # no fault in scenario 1
    assert run.trace["diag_alarm_tyre_L"].to_numpy()[0] == 1
