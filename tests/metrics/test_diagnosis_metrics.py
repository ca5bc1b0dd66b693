"""Diagnosis scored at component-and-mode level: a declaration matching the true fault's class (component,
target, mode) isolates it, a wrong mode does not and counts as a false declaration, the observability rule
reads the sensors the run has, and the confusion matrix and rates pool runs."""

from __future__ import annotations

import numpy as np

from ftc_mj.metrics.diagnosis import (
    confusion,
    diagnosis_metrics,
    diagnosis_scores,
    measurements_of,
    observable,
    summary,
)
from ftc_mj.model.diagnosis import Diagnosis
from ftc_mj.model.sensors import SensorSettings
from ftc_mj.plant.faults import FaultSpec
from ftc_mj.sim.trace import TraceWriter

N, DT = 300, 0.01


class _Step:
    def __init__(self, declared: list[Diagnosis], alarm: bool) -> None:
        self.statistics = {"speed": 20.0 if alarm else 0.0}
        self.alarms = {"speed": alarm}
        self.declared = declared


def trace_with(declarations: list[Diagnosis]) -> dict[str, np.ndarray]:
    """A trace of N rows whose diagnosis columns carry ``declarations`` at their declaration times."""
    w = TraceWriter(N)
    w.columns["t"][:] = np.arange(N) * DT
    w.columns["R_R"][:] = w.columns["R_L"][:] = 2.0
    for k in range(N):
        done = [d for d in declarations if d.declared <= k * DT + 1e-9]
        w.diagnosis(k, _Step(done, alarm=bool(done)))
    return w.columns


def bias(mode: str = "bias", size: float = 0.3) -> Diagnosis:
    return Diagnosis("speed sensor", "speed", mode, size, 0.05, 1.0, 1.5, 20.0, 12.5)


SPEC = FaultSpec("speed_bias", "speed", 1.0, 0.25)
GYRO = SensorSettings(yaw_rate_sigma=0.01)


def test_the_right_component_and_mode_isolates_the_fault_with_its_size_error() -> None:
    m = diagnosis_metrics(trace_with([bias()]), [SPEC], GYRO, 2.0)
    e = m["diagnosis_faults"][0]
    assert e["isolated"] and e["declared"] == "speed sensor/speed/bias"
    assert e["isolation_delay"] == 0.5 and abs(e["size_error"] - 0.05) < 1e-12
    assert m["diagnosis_false_declarations"] == 0 and m["diagnosis_alarms"]["speed"] == 1


def test_a_wrong_mode_is_not_an_isolation_and_counts_as_false() -> None:
    m = diagnosis_metrics(trace_with([bias("drift")]), [SPEC], GYRO, 2.0)
    assert not m["diagnosis_faults"][0]["isolated"]
    assert m["diagnosis_false_declarations"] == 1
    s = diagnosis_scores(trace_with([bias("drift")]), [SPEC], GYRO, 2.0)
    assert s["diag_isolation"] == "wrong" and s["diag_true"] == "speed sensor/speed/bias"


def test_a_declaration_in_a_fault_free_run_is_false() -> None:
    m = diagnosis_metrics(trace_with([bias()]), [], GYRO, 2.0)
    assert m["diagnosis_false_declarations"] == 1 and m["diagnosis_first_false_time"] == 1.5


def test_observability_follows_the_sensors_of_the_run() -> None:
    gyro_fault = FaultSpec("gyro_bias", "yaw_rate", 1.0, 0.05)
    assert observable(gyro_fault, measurements_of(GYRO))
    assert not observable(gyro_fault, measurements_of(SensorSettings()))
    assert observable(FaultSpec("actuator_loss", "left", 1.0, 0.5), measurements_of(SensorSettings(), pose=False))


def test_confusion_and_rates_pool_runs() -> None:
    good = diagnosis_metrics(trace_with([bias()]), [SPEC], GYRO, 2.0)
    wrong = diagnosis_metrics(trace_with([bias("drift")]), [SPEC], GYRO, 2.0)
    clean = {**diagnosis_metrics(trace_with([]), [], GYRO, 2.0), "sim_time_s": 3600.0}
    c = confusion([good, wrong, clean])
    key = ("speed sensor", "speed", "bias")
    assert c[(key, "speed sensor/speed/bias")] == 1 and c[(key, "speed sensor/speed/drift")] == 1
    assert c[(("none", "", ""), "none")] == 1
    s = summary([good, wrong, clean])
    assert s["isolation_rate"] == 0.5 and s["false_declarations_per_hour"] == 0.0


def test_a_declaration_of_another_true_fault_is_not_this_ones() -> None:
    """Two faults in a run: the one declared is isolated; the other, never declared, is ``none``, not ``wrong``
    with the first's declaration."""
    servo = FaultSpec("actuator_loss", "right", 0.5, 0.3)
    m = diagnosis_metrics(trace_with([bias()]), [servo, SPEC], GYRO, 2.0)
    first, second = m["diagnosis_faults"]
    assert first["declared"] is None and not first["isolated"]
    assert second["isolated"]
    assert diagnosis_scores(trace_with([bias()]), [servo, SPEC], GYRO, 2.0)["diag_isolation"] == "none"


def acting_trace(**changes: tuple[int, str, float]) -> dict[str, np.ndarray]:
    """A diagnosed trace whose controller-side columns hold their start values, changed from row ``k`` on as
    ``changes`` say (column → (k, value))."""
    tr = trace_with([])
    for name, start in (("reconfig_state", 0.0), ("R_R_model", 2.0), ("R_L_model", 2.0), ("excitation", 0.0),
                        ("accommodation_mode", 0.0), ("actuator_effectiveness_R", 1.0),
                        ("actuator_effectiveness_L", 1.0)):
        tr[name] = np.full(N, start)
    for name, (k, value) in changes.items():
        tr[name][k:] = value
    return tr


def test_nothing_is_acted_upon_when_no_alarm_moves_the_controller() -> None:
    m = diagnosis_metrics(acting_trace(), [], GYRO, 2.0)
    assert m["diagnosis_alarms_acted_upon"] == 0 and set(m["diagnosis_acted_upon"].values()) == {0}
    assert diagnosis_scores(acting_trace(), [], GYRO, 2.0)["diag_acted_upon"] == 0


def test_every_change_of_the_controllers_model_or_mode_is_counted() -> None:
    tr = acting_trace(reconfig_state=(100, 2.0), R_L_model=(120, 1.5), actuator_effectiveness_R=(150, 0.5))
    tr["excitation"][50:60] = 0.02  # a dither while a fault was suspected
    events = [{"t": 0.9, "level": "warn", "text": "degraded mode from the first alarm: R_R in [1.8, 2.0] m"}]
    m = diagnosis_metrics(tr, [], GYRO, 2.0, events)
    assert m["diagnosis_acted_upon"] == {"policy": 1, "model_radii": 1, "degraded": 1, "accommodation": 1,
                                         "excitation": 1}
    assert m["diagnosis_alarms_acted_upon"] == 5


def test_no_alarm_moves_the_controller_of_a_healthy_benchmark_draw() -> None:
    """A healthy ftc-v2 draw under the ``safe`` method (policy, degraded mode, accommodation of every mode): no
    declaration, no alarm, nothing acted upon."""
    import ftc_mj
    from ftc_mj.benchmark.draws import draw
    from ftc_mj.benchmark.methods import load_method

    cfg = load_method("safe").apply(draw("dev", 0, "ftc-v2").scenario(with_faults=False))
    m = ftc_mj.run(cfg.model_copy(update={"duration": 12.0}), rrd=False).metrics
    assert m["diagnoses"] == [] and m["diagnosis_alarm_episodes"] == 0
    assert m["diagnosis_alarms_acted_upon"] == 0, m["diagnosis_acted_upon"]
