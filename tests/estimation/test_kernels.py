"""The compiled filter steps (numba) against the numpy reference implementation (tests/support).

Every filter kind runs on the same data through both backends, with a radius fault, speed only, with a
yaw-rate gyro and with position fixes, bad and gated measurements, divergence resets and covariance
repairs; everything a step reports must agree to round-off (1e-9 relative to the size of the quantity).
Also: the generated kinematic code in ``kernels/generated.py`` is current and is the model's.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.estimation import EKF, IMM, UKF, FilterOutput, Measurement
from ftc_mj.estimation.codegen import DEPENDENTS, GENERATED, digest_line, generated_block, split
from ftc_mj.estimation.kernels import generated
from ftc_mj.model.kinematics import KinematicModel, body_rates, numpy_rates_jacobian, numpy_step_jacobian
from tests.estimation.filters import excited_data, make_filter

RTOL = 1e-9
FIELDS = ("x", "P", "innovation", "S", "nis", "speed_innovation", "speed_innovation_std", "mode_probs", "model_x")
Filter = EKF | UKF | IMM

KINDS: dict[str, Callable[[RunConfig, str], Filter]] = {
    kind: (lambda cfg, b, kind=kind: make_filter(kind, cfg, reference=b == "numpy"))
    for kind in ("ekf", "ukf", "imm-ekf", "imm-ukf")
}
"""Filter kind → ``make(cfg, backend)`` with backend ``"numba"`` (the package) or ``"numpy"`` (the reference)."""


def close(a: object, b: object) -> float:
    """Largest difference of ``a`` from ``b`` relative to the largest magnitude in ``b`` (NaNs must match)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    assert np.array_equal(np.isnan(a), np.isnan(b)) and np.array_equal(np.isinf(a), np.isinf(b))
    fin = np.isfinite(b)
    if not fin.any():
        return 0.0
    return float(np.abs(a[fin] - b[fin]).max() / max(float(np.abs(b[fin]).max()), 1e-300))


def assert_same(fast: Filter, ref: Filter, of: FilterOutput, orf: FilterOutput, k: int) -> float:
    worst = 0.0
    for name in FIELDS:
        va, vb = getattr(of, name), getattr(orf, name)
        assert (va is None) == (vb is None), name
        if va is not None:
            d = close(va, vb)
            assert d <= RTOL, f"step {k}: {name} differs by {d:.1e} (relative)"
            worst = max(worst, d)
    assert (of.rejected, of.reset) == (orf.rejected, orf.reset), f"step {k}"
    assert (fast.resets, fast.rejections) == (ref.resets, ref.rejections), f"step {k}"
    if isinstance(fast, IMM):
        assert isinstance(ref, IMM)
        worst = max(worst, close(fast.loglik, ref.loglik), close(fast.P_comb, ref.P_comb))
    return worst


def run_both(make: Callable[[str], Filter], steps: Callable[[int, Filter], tuple[np.ndarray, Measurement]],
             n: int, poke: Callable[[int, Filter], None] | None = None) -> tuple[Filter, Filter, float]:
    """Step a numba and a numpy filter on the same inputs; ``poke`` may corrupt both before a step."""
    fast, ref = make("numba"), make("numpy")
    assert type(ref).step is not type(fast).step  # the reference steps in numpy, not through the kernels
    worst = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the numpy reference warns on NaN Cholesky
        for k in range(n):
            u, z = steps(k, ref)
            if poke is not None:
                poke(k, fast)
                poke(k, ref)
            worst = max(worst, assert_same(fast, ref, fast.step(u, z), ref.step(u, z), k))
    return fast, ref, worst


def sensor_cfg(sensors: str, **estimator: object) -> RunConfig:
    yaw = 0.01 if sensors != "speed" else None
    pos = {"pos": 1.0, "pose": 0.05}.get(sensors)
    if sensors == "pose":
        estimator = {"pose_gate_reacquire": 0.3, **estimator}
    return RunConfig.model_validate({"sensors": {"yaw_rate_sigma": yaw, "position_sigma": pos},
                                     "estimator": estimator})


def pose_fix(k: int, ref: Filter) -> tuple[np.ndarray | None, float | None]:
    """A pose fix every 10 steps near the reference filter's estimate, its heading counted three turns off
    (the innovation must be wrapped), displaced 3 m for steps 150-259 (gated, until the streak's limit)."""
    if k % 10 != 5:
        return None, None
    jump = 3.0 if 150 <= k < 260 else 0.0
    return ref.x[:2] + 0.02 + jump, float(ref.x[2]) + 0.01 + 6.0 * math.pi


@pytest.mark.parametrize("sensors", ["speed", "yaw", "pos", "pose"])
@pytest.mark.parametrize(("kind", "models", "variant"), [
    ("ekf", 4, None), ("ukf", 4, None),
    ("imm-ekf", 4, "hypothesis"), ("imm-ekf", 5, "hypothesis"), ("imm-ukf", 4, "hypothesis"),
    ("imm-ukf", 5, "hypothesis"), ("imm-ukf", 4, "paper"), ("imm-ekf", 5, "paper"),
])
def test_numba_matches_numpy(kind: str, models: int, variant: str | None, sensors: str) -> None:
    """300 steps with R_L falling 2 → 1 m over steps 100-200, a dropped (NaN) speed, an outlier beyond
    the gate, a non-finite gyro reading, non-finite wheel rates and (``pos``) a position fix every 50 steps,
    (``pose``) a pose fix every 10 steps with a 3 m jump (:func:`pose_fix`)."""
    n = 300
    u, zs, zy = excited_data(n, yaw_sigma=0.01)
    est = {"kind": kind} | ({"imm_models": models} if kind.startswith("imm") else {})
    cfg = sensor_cfg(sensors, **est | ({"imm_variant": variant} if variant else {}))

    def steps(k: int, ref: Filter) -> tuple[np.ndarray, Measurement]:
        speed = {40: math.nan, 70: float(zs[k]) + 1e3}.get(k, float(zs[k]))
        yaw = math.nan if k == 90 else float(zy[k])
        pos = ref.x[:2] + 0.3 if (sensors == "pos" and k % 50 == 25) else None
        heading = None
        if sensors == "pose":
            pos, heading = pose_fix(k, ref)
        uk = np.array([math.nan, 1.0]) if k == 120 else u[k]
        return uk, Measurement(speed, yaw, pos, heading)

    fast, ref, worst = run_both(lambda b: KINDS[kind](cfg, b), steps, n)
    print(f"{kind} {models} {variant} {sensors}: largest relative difference {worst:.1e}, "
          f"rejections {fast.rejections}, pose fixes rejected {fast.pose_rejections}")
    assert fast.rejections >= 2
    if sensors == "pose":  # the jump's fixes rejected, three in a row at most (the streak's limit), then fused
        assert 3 <= fast.pose_rejections == ref.pose_rejections <= 9


@pytest.mark.parametrize("kind", list(KINDS))
def test_numba_matches_numpy_through_resets(kind: str) -> None:
    """Divergence: persistent large speed errors (NIS dwell) and a corrupted (NaN) covariance."""
    u, zs, _ = excited_data(160)
    cfg = RunConfig.model_validate({"estimator": {"divergence_dwell": 0.2}})

    def steps(k: int, ref: Filter) -> tuple[np.ndarray, Measurement]:
        return u[k], Measurement(float(zs[k]) + (40.0 * (-1) ** k if 20 <= k < 100 else 0.0))

    def poke(k: int, f: Filter) -> None:
        if k == 130:
            f.P = np.full_like(f.P, np.nan)

    fast, ref, _ = run_both(lambda b: KINDS[kind](cfg, b), steps, 160, poke)
    assert fast.resets >= 2


@pytest.mark.parametrize("kind", list(KINDS))
def test_numba_matches_numpy_through_repairs(kind: str) -> None:
    """A covariance that is not positive definite (|correlation| > 1 between the radii, and for an IMM
    member a negative variance) is eigen-floored the same way. The measurement of that step is an
    outlier beyond the gate, so that the indefinite prediction survives to the EKF's end-of-step check."""
    u, zs, _ = excited_data(60)
    cfg = RunConfig()

    def steps(k: int, ref: Filter) -> tuple[np.ndarray, Measurement]:
        return u[k], Measurement(float(zs[k]) + (1e3 if k in (10, 30) else 0.0))

    def poke(k: int, f: Filter) -> None:
        if k in (10, 30):
            P = f.P.copy()
            Pm = P[-1] if P.ndim == 3 else P
            Pm[3, 4] = Pm[4, 3] = 1.2 * math.sqrt(Pm[3, 3] * Pm[4, 4])
            if k == 30 and P.ndim == 3:
                P[0, 2, 2] = -1e-3
            f.P = P

    fast, ref, _ = run_both(lambda b: KINDS[kind](cfg, b), steps, 60, poke)
    assert fast.resets == 0 and fast.rejections == 2


def test_numba_step_is_deterministic() -> None:
    u, zs, zy = excited_data(200, yaw_sigma=0.01)
    cfg = sensor_cfg("yaw", kind="imm-ukf", imm_models=5)
    outs = []
    for _ in range(2):
        f = make_filter("imm-ukf", cfg)
        outs.append(np.array([np.concatenate([o.x, o.P.ravel(), o.mode_probs]) for o in
                              (f.step(u[k], Measurement(float(zs[k]), float(zy[k]))) for k in range(200))]))
    np.testing.assert_array_equal(outs[0], outs[1])


def test_generated_kinematics_is_current() -> None:
    """The block in ``kernels/generated.py`` is what the model generates now, and every kernel module that
    compiles it in carries its digest (else: python -m ftc_mj.estimation.codegen)."""
    block = generated_block()
    assert split(GENERATED.read_text())[1] == block
    for path in DEPENDENTS:
        assert digest_line(block) in path.read_text().splitlines(), path.name


def test_generated_kinematics_is_the_model() -> None:
    m = KinematicModel(b=1.3, dt=0.01)
    rng = np.random.default_rng(4)
    X = rng.normal(size=(20, 5)) + [0, 0, 0, 2, 2]
    U = rng.normal(size=(20, 2)) * 5
    out5, F, r2, H = np.empty(5), np.empty((5, 5)), np.empty(2), np.empty((2, 5))
    for x, u in zip(X, U, strict=True):
        generated.kin_step(x, u, 0.01, 1.3, out5)
        np.testing.assert_allclose(out5, m.step_batch(x, u), rtol=1e-15, atol=1e-15)
        generated.kin_F(x, u, 0.01, 1.3, F)
        np.testing.assert_allclose(F, numpy_step_jacobian(m, x, u), rtol=1e-15, atol=1e-15)
        generated.kin_rates(x, u, 1.3, r2)
        np.testing.assert_allclose(r2, body_rates(x[3], x[4], u[0], u[1], 1.3), rtol=1e-15, atol=1e-15)
        generated.kin_H(x, u, 1.3, H)
        np.testing.assert_allclose(H, numpy_rates_jacobian(m, x, u), rtol=1e-15, atol=1e-15)


@pytest.mark.parametrize(("preset", "expected"), [(None, 2), ("3", 3)])
def test_kernels_compile_at_level_2_unless_the_user_sets_one(preset: str | None, expected: int) -> None:
    """Importing the kernels sets numba's ``NUMBA_OPT`` to 2 (it changes compile time, never results), and
    leaves a level the user set alone. numba reads the variable once, so this runs in a fresh process."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "NUMBA_OPT"}
    if preset is not None:
        env["NUMBA_OPT"] = preset
    code = "import ftc_mj.estimation.kernels.single, numba; print(int(numba.config.OPT))"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert int(out.stdout.strip()) == expected
