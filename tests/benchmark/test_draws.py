"""The benchmark's draws (no simulation): a pure function of (version, split, index), the same in a new
process and pinned against the values this version was published with; the empirical ranges and
frequencies over 1000 draws per split match the definition; the splits' seeds obey the seed policy."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.benchmark.definition import PATH_KINDS, load_definition
from ftc_mj.benchmark.draws import draw
from ftc_mj.config import validate_config
from ftc_mj.errors import BadInput
from ftc_mj.identity import canonical_hash
from ftc_mj.plant.faults import drawn_classes, fault_list

N = 1000
"""Draws per split for the distribution checks."""
SIGMAS = 4.0
"""Tolerance of a frequency: |k − n p| ≤ 4 √(n p (1 − p)) (binomial; a false failure ~6e-5 per check)."""
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def draws() -> dict[str, list]:
    return {s: [draw(s, i) for i in range(N)] for s in ("dev", "test")}


def within_binomial(k: int, n: int, p: float) -> bool:
    return abs(k - n * p) <= SIGMAS * math.sqrt(n * p * (1.0 - p)) + 1e-12


def test_two_draws_differ_in_at_least_six_factors(draws):
    for s, ds in draws.items():
        for a, b in zip(ds[:200], ds[1:201], strict=True):
            fa, fb = a.factors(), b.factors()
            differ = [k for k in fa if k not in ("index", "name") and fa[k] != fb[k]]
            assert len(differ) >= 6, (s, a.index, differ)


def test_the_same_draw_in_a_new_process_and_pinned():
    code = ("import json; from ftc_mj.benchmark.draws import draw; "
            "print(json.dumps([[draw(s, i, 'ftc-v1').factors(), draw(s, i, 'ftc-v1').scenario()] "
            "for s in ('dev', 'test') for i in (0, 7, 123)], default=str))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO,
                         env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"}).stdout
    here = [[draw(s, i, "ftc-v1").factors(), draw(s, i, "ftc-v1").scenario()]
            for s in ("dev", "test") for i in (0, 7, 123)]
    assert json.loads(out) == json.loads(json.dumps(here, default=str))
    # the values ftc-v1 was published with: a change of the drawing code is a new version
    assert canonical_hash([draw("dev", i, "ftc-v1").factors() for i in range(20)], 16) == PINNED_DEV
    assert canonical_hash([draw("test", i, "ftc-v1").factors() for i in range(20)], 16) == PINNED_TEST


PINNED_DEV = "18b774217c07ed13"
"""Hash of the factors of dev draws 0-19 of ftc-v1 (canonical JSON, SHA-256)."""
PINNED_TEST = "207018468768fa4b"


def test_seeds_follow_the_policy_and_the_splits_differ(draws):
    assert all(0 <= d.seed < 1000 for d in draws["dev"])
    assert all(d.seed >= 1000 for d in draws["test"])
    assert draws["dev"][0].factors()["tyre_friction"] != draws["test"][0].factors()["tyre_friction"]
    with pytest.raises(BadInput, match="--split"):
        draw("train", 0)
    with pytest.raises(BadInput, match="index"):
        draw("dev", -1)


def test_fault_class_and_path_frequencies_match_the_definition(draws):
    d = load_definition()
    for ds in draws.values():
        n = len(ds)
        for c in d.fault.classes:
            k = sum(x.fault_class == c for x in ds)
            assert within_binomial(k, n, d.fault.classes[c]), (c, k, n)
        for kind in PATH_KINDS:
            assert within_binomial(sum(x.path == kind for x in ds), n, d.path.kinds[kind]), kind
        faulted = [x for x in ds if x.faults]
        assert within_binomial(sum(len(x.faults) == 2 for x in faulted), len(faulted), d.fault.double)
        p_gyro_fault = sum(d.fault.classes[c] for c in d.fault.classes if c.startswith("gyro"))
        p_gyro = p_gyro_fault + (1 - p_gyro_fault) * d.sensors.gyro  # a second gyro fault adds < 1 %: not modelled
        k = sum(x.gyro_sigma is not None for x in ds)
        assert within_binomial(k, n, p_gyro) or abs(k / n - p_gyro) < 0.02


def _in_range(values, r, edge=0.02):
    """All values in [low, high], and (uniform, n = 1000) the extremes within 2 % of the range of its ends:
    P(min > low + 0.02 (high − low)) = 0.98^n ≈ 2e-9."""
    v = np.asarray(values, float)
    span = r.high - r.low
    assert v.min() >= r.low - 1e-9 and v.max() <= r.high + 1e-9, (v.min(), v.max(), r)
    assert v.min() <= r.low + edge * span and v.max() >= r.high - edge * span, (v.min(), v.max(), r)


def test_factor_ranges_match_the_definition(draws):
    d = load_definition()
    ds = draws["dev"] + draws["test"]
    for name in ("tyre_friction", "actuator_gain", "payload_mass", "speed_sigma", "pose_sigma"):
        _in_range([x.factors()[name] for x in ds], getattr(d.plant, name, None) or getattr(d.sensors, name))
    for i, axis in enumerate("xyz"):
        _in_range([x.payload_offset[i] for x in ds], getattr(d.plant, f"payload_offset_{axis}"))
    _in_range([x.gyro_sigma for x in ds if x.gyro_sigma is not None], d.sensors.gyro_sigma, edge=0.05)
    firsts = [x.faults[0] for x in ds if x.faults]
    _in_range([f.onset for f in firsts], d.fault.onset)
    _in_range([f.size for f in firsts if f.fault_class == "puncture_step"], d.fault.puncture_fraction, 0.05)
    _in_range([f.size for f in firsts if f.fault_class == "actuator_loss"], d.fault.effectiveness, 0.05)
    _in_range([f.duration for f in firsts if f.fault_class.endswith("dropout")], d.fault.dropout_duration, 0.05)
    for x in ds:
        cap = math.sqrt(d.path.max_lateral_accel * x.path_radius)
        assert d.path.speed.low <= x.speed <= min(d.path.speed.high, cap) + 1e-3
        for f in x.faults:
            assert f.target in drawn_classes()[f.fault_class].targets
        if len(x.faults) == 2:
            a, b = x.faults
            assert a.target != b.target and b.onset - a.onset >= d.fault.second_delay.low - 0.01


def test_mean_of_a_uniform_factor(draws):
    """The friction's mean is (low + high) / 2 within 4 σ/√n (σ = span/√12)."""
    r = load_definition().plant.tyre_friction
    v = np.array([x.tyre_friction for x in draws["dev"]])
    assert abs(v.mean() - (r.low + r.high) / 2) <= SIGMAS * (r.high - r.low) / math.sqrt(12 * v.size)


def test_draws_are_valid_scenarios_with_their_faults(draws):
    """Every draw's scenario validates, and the plant's fault list (class, target, onset) is the drawn one."""
    classes = set()
    for x in draws["dev"][:80]:
        cfg = validate_config(x.scenario())
        assert cfg.seed == x.seed and cfg.reference.kind == x.path
        got = sorted((f.fault_class, f.target, f.onset) for f in fault_list(cfg.faults, cfg.plant_wheel_radius))
        want = sorted((drawn_classes()[f.fault_class].name, f.target, f.onset) for f in x.faults)
        assert got == want, x.index
        classes |= {f.fault_class for f in x.faults}
        healthy = validate_config(x.scenario(with_faults=False))
        assert fault_list(healthy.faults, healthy.plant_wheel_radius) == []
    assert len(classes) >= 8  # the first 80 draws cover most classes
