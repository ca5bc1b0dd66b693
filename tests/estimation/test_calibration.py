"""Thresholds of the change detectors: the null innovations, Siegmund's ARL0, the log(ARL0) growth and the
threshold the factory calibrates and passes to the change rules."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.disk_cache import CACHE_ENV, SWITCH_ENV
from ftc_mj.estimation import Measurement, calibration
from ftc_mj.estimation.calibration import (
    OFFSETS_FILE,
    THRESHOLD_FOLDER,
    _null_threshold,
    null_threshold,
    package_data,
    physical_offset,
    siegmund_arl0,
    threshold_key,
)
from ftc_mj.estimation.decision import ChangeRule
from ftc_mj.estimation.rule_statistics import DecisionSettings
from ftc_mj.metrics.alarm_rates import Rate, chosen_offset
from ftc_mj.registry import decision_rules
from ftc_mj.wiring.decision import (
    build_change_detectors,
    build_decision_rule,
    calibrated_threshold,
    nominal_point_of,
    nominal_points_of,
    nominal_threshold,
    reference_operating_points,
)
from tests.estimation.filters import decision_cfg, excited_data, make_filter


def test_residual_generator_innovations_are_white_on_a_fault_free_truth() -> None:
    """The detectors' null model: on a fault-free kinematic truth (constant radii, the wheel rates of a
    slowly varying path, speed + gyro noise) the no-fault residual generator's whitened innovations are
    N(0, I) — variance 1 and no lag-1 correlation per channel (6000 samples: standard errors 0.018 and
    0.013; tolerances 0.08 and 0.06, > 4σ) — whatever the estimator, while the UKF's own gyro channel,
    whose random-walk radius model overstates S, has a whitened variance far below 1."""
    cfg = decision_cfg("glr", 0.01, null_model="ideal")
    det = build_change_detectors(cfg)  # the ideal (kinematic) null model, exact on a kinematic truth
    ukf = make_filter("ukf", cfg)
    u_all, v, w = excited_data(6000, seed=3, yaw_sigma=0.01, fault=False)
    E, E_ukf = [], []
    for k in range(len(v)):
        z = Measurement(speed=float(v[k]), yaw_rate=float(w[k]))
        det.step(k * 0.01, u_all[k], z)
        out = ukf.step(u_all[k], z)
        E.append(det.white.copy())
        E_ukf.append(np.linalg.solve(np.linalg.cholesky(out.S), out.innovation))
    E, E_ukf = np.array(E[100:]), np.array(E_ukf[100:])
    assert np.all(np.abs(E.var(axis=0) - 1.0) < 0.08)
    lag1 = np.mean(E[1:] * E[:-1], axis=0) / np.mean(E * E, axis=0)
    assert np.all(np.abs(lag1) < 0.06)
    assert E_ukf[:, 1].var() < 0.3


def test_cusum_calibration_reproduces_siegmund() -> None:
    """Speed only, all three hypotheses have the same signature (every drop lowers the speed), so the
    rule is one CUSUM; on the null model's N(0, 1) innovations its Monte-Carlo threshold must give
    Siegmund's ARL0. ±10 % (1σ) Monte-Carlo rate and a few % approximation error: the bound allows 30 %."""
    cfg = decision_cfg("cusum", None)
    arl0_steps = 5000
    h = null_threshold("cusum", nominal_point_of(cfg), 1.0, 50, arl0_steps)
    assert 0.7 < siegmund_arl0(h, 1.0) / arl0_steps < 1.3


def test_threshold_grows_with_the_log_of_arl0() -> None:
    """Beyond the Monte-Carlo horizon the threshold grows as log(ARL0) (LLR units)."""
    h1 = calibrated_threshold(decision_cfg("cusum", None, arl0=200.0), "cusum")
    h2 = calibrated_threshold(decision_cfg("cusum", None, arl0=2000.0), "cusum")
    assert h2 - h1 == pytest.approx(math.log(10.0), abs=1e-12)


def test_change_rule_gets_its_threshold_from_the_factory() -> None:
    """The rule holds the threshold it is given; the factory calibrates it at the nominal point of the
    run's reference path (a line and a circle give different nominal points)."""
    assert ChangeRule("glr", DecisionSettings(), 7.25).threshold == 7.25
    cfg = decision_cfg("cusum", 0.01)
    rule = build_decision_rule(cfg)
    assert isinstance(rule, ChangeRule) and rule.threshold == calibrated_threshold(cfg, "cusum")
    line = cfg.model_copy(update={"reference": cfg.reference.model_copy(update={"kind": "line"})})
    assert nominal_point_of(line) != nominal_point_of(cfg)
    assert not decision_rules.get("cusum").legacy and decision_rules.get("cusum").meta["calibrate"] == "cusum"


def test_a_figure_eight_is_calibrated_on_both_lobes() -> None:
    """A figure-eight turns one way on its first lobe and the other way on its second (yaw rate ±V/R), so its
    operating points are both lobes', not a circle's one: the second is the opposite circle's, and the
    detectors' threshold is the larger of the two lobes' (the mean time between false alarms holds on both)."""
    cfg = decision_cfg("glr", 0.01)
    ref = cfg.reference

    def with_reference(**update: object):  # noqa: ANN202 - a RunConfig
        return cfg.model_copy(update={"reference": ref.model_copy(update=update)})

    fig8, cw = with_reference(kind="figure8"), with_reference(direction="cw")
    v, w = ref.speed, ref.speed / ref.radius
    assert reference_operating_points(cfg) == ((v, w),)
    assert reference_operating_points(fig8) == ((v, w), (v, -w))
    assert reference_operating_points(with_reference(kind="line")) == ((v, 0.0),)
    lobes = nominal_points_of(fig8)
    assert lobes == (nominal_point_of(cfg), nominal_point_of(cw)) and lobes[0] != lobes[1]
    h = calibrated_threshold(fig8, "glr")
    assert h == max(calibrated_threshold(cfg, "glr"), calibrated_threshold(cw, "glr"))


def test_the_physical_null_model_adds_the_offset_measured_for_its_sensors() -> None:
    """Under the physical null model a detector's threshold is the N(0, I) one plus the offset measured on the
    MuJoCo robot for the run's sensor set; the ideal null model keeps the N(0, I) one. Speed only the shipped
    offsets are negative: there the physical null model's slip noise made the N(0, I) thresholds' mean time
    between false alarms 4-7 times the design's on the development seeds (docs/fdi.md)."""
    for gyro in (None, 0.01):
        for kind in ("cusum", "glr"):
            cfg, ideal = decision_cfg(kind, gyro), decision_cfg(kind, gyro, null_model="ideal")
            offset = physical_offset(kind, gyro is not None)
            assert calibrated_threshold(cfg, kind) == nominal_threshold(cfg, kind) + offset
            assert calibrated_threshold(ideal, kind) == nominal_threshold(ideal, kind)
    assert physical_offset("cusum", False) < 0.0 and physical_offset("glr", False) < 0.0


def test_the_shipped_offsets_are_the_rule_applied_to_their_own_counts() -> None:
    """The data file keeps, for every offset tried, the after-launch alarms and seconds watched; each shipped
    offset is what :func:`chosen_offset` picks from them, on development seeds only, over >= 1000 s per sensor
    set."""
    data = package_data(OFFSETS_FILE)
    assert data["conditions"]["seeds"][1] < 1000
    for sensors, kinds in data["curves"].items():
        for kind, curve in kinds.items():
            rates = {float(d): Rate(a, e, a / e, 0.0, 0.0) for d, (a, e) in
                     ((d, cells["after_launch"]) for d, cells in curve.items())}
            assert min(r.exposure for r in rates.values()) >= 1000.0
            assert data["offsets"][sensors][kind] == chosen_offset(rates, data["design_arl0"])


def test_the_offset_nearest_the_design_on_the_log_scale_is_chosen() -> None:
    """Mean times 50, 95 and 400 s against a design of 100 s: 95 s is nearest; 50 and 200 s are equally far on
    the log scale and the larger offset (fewer alarms) wins; without any alarm the offset is 0."""
    def rate(arl0: float) -> Rate:
        return Rate(10, 10.0 * arl0, 1.0 / arl0, 0.0, 0.0)
    assert chosen_offset({-1.0: rate(50.0), -0.5: rate(95.0), 0.0: rate(400.0)}, 100.0) == -0.5
    assert chosen_offset({-1.0: rate(50.0), 0.0: rate(200.0)}, 100.0) == 0.0
    assert chosen_offset({-1.0: Rate(0, 900.0, 0.0, 0.0, 0.1)}, 100.0) == 0.0


@pytest.mark.parametrize("gyro", [None, 0.01])
def test_null_running_max_equals_the_detector_stepped_one_step_at_a_time(gyro: float | None) -> None:
    """The compiled, block-drawn null run is the reference loop kept here — the detector's own ``step`` on
    innovations drawn one step at a time, the running maximum taken with numpy — bitwise, across a block
    boundary (2500 steps, blocks of 1000)."""
    from ftc_mj.estimation.calibration import null_running_max
    from ftc_mj.estimation.change import InnovationCUSUM

    point = nominal_point_of(decision_cfg("cusum", gyro))
    steps, chains = 2500, 7
    W = point.arrays()[0]
    rng = np.random.default_rng([0, 17, point.m])
    det, run, ref = InnovationCUSUM(0.8, chains), np.zeros(chains), np.empty((chains, steps))
    for k in range(steps):
        run = np.maximum(run, det.step(rng.standard_normal((chains, point.m)), W).max(axis=1))
        ref[:, k] = run
    fast = null_running_max("cusum", point, shift=0.8, window=50, steps=steps, chains=chains)
    assert fast.tobytes() == ref.tobytes()


@pytest.fixture
def threshold_cache(tmp_path, monkeypatch):
    """A fresh disk cache root for the thresholds, and the process's own cache of them emptied."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(SWITCH_ENV, raising=False)
    null_threshold.cache_clear()
    yield tmp_path / THRESHOLD_FOLDER
    null_threshold.cache_clear()


def test_a_threshold_from_the_disk_cache_is_the_computed_one_to_the_bit(threshold_cache, monkeypatch) -> None:
    """The first calibration writes one entry; a process that asks again (the in-memory cache emptied) reads it
    back bitwise, without running the Monte Carlo; another shift or horizon is another entry."""
    point = nominal_point_of(decision_cfg("cusum", 0.01))
    h = null_threshold("cusum", point, 1.0, 50, 3000)
    assert h == _null_threshold("cusum", point, 1.0, 50, 3000)
    assert len(list(threshold_cache.glob("*.json"))) == 1
    null_threshold.cache_clear()
    calls = []
    monkeypatch.setattr(calibration, "_null_threshold", lambda *a: calls.append(a) or _null_threshold(*a))
    assert null_threshold("cusum", point, 1.0, 50, 3000) == h  # from the disk: no computation
    assert calls == []
    null_threshold("cusum", point, 1.0, 50, 2000)
    null_threshold("cusum", point, 0.5, 50, 3000)
    assert len(calls) == 2 and len(list(threshold_cache.glob("*.json"))) == 3


def test_a_damaged_threshold_entry_is_computed_again_and_rewritten(threshold_cache, capsys) -> None:
    """An entry that does not parse, names another key or is not a regular file is not used: one warning line,
    the threshold computed, the entry replaced by a good one."""
    point = nominal_point_of(decision_cfg("cusum", 0.01))
    h = null_threshold("cusum", point, 1.0, 50, 3000)
    (entry,) = threshold_cache.glob("*.json")
    good = entry.read_text()
    for bad in ("{not json", good.replace(entry.stem, "0" * 32)):
        entry.write_text(bad)
        null_threshold.cache_clear()
        assert null_threshold("cusum", point, 1.0, 50, 3000) == h
        assert "cannot be used" in capsys.readouterr().err
        assert entry.read_text() == good
    entry.unlink()
    entry.mkdir()
    null_threshold.cache_clear()
    assert null_threshold("cusum", point, 1.0, 50, 3000) == h
    assert "cannot be used" in capsys.readouterr().err


def test_the_threshold_key_names_the_code_and_the_machine(threshold_cache, monkeypatch) -> None:
    """A changed source tree or another machine (CPU, numpy, numba) is another key, so a stale or foreign
    threshold is never read; with the cache switched off nothing is written."""
    point = nominal_point_of(decision_cfg("cusum", 0.01))
    key = threshold_key("cusum", point, 1.0, 50, 3000)
    monkeypatch.setattr(calibration, "sources_digest", lambda: "0" * 16)
    assert threshold_key("cusum", point, 1.0, 50, 3000) != key
    monkeypatch.undo()
    monkeypatch.setattr(calibration, "machine_tag", lambda: "another machine")
    assert threshold_key("cusum", point, 1.0, 50, 3000) != key
    monkeypatch.setenv(SWITCH_ENV, "off")
    null_threshold("cusum", point, 1.0, 50, 3000)
    assert not threshold_cache.exists()
