"""The MPCs' input-rate bound relative to the command in force, ``|U(t0) − u_applied| ≤ omega_rate_max T_s``.

Default numbers: omega_rate_max 20 rad/s² and a 10 Hz controller, so consecutive commands may differ
by at most 2 rad/s per wheel. Each closed-loop test also runs the earlier formulation (the first input
free, ``rate_bound_from_applied = False``) and checks that it breaks the bound in the same run: the run
saturates, so the check can fail.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from ftc_mj.config import load_config
from ftc_mj.control import NMPC, LinearMPC
from ftc_mj.control.excitation import dither_wheel_rates
from ftc_mj.control.spec import first_input_bounds, first_step_penalty
from ftc_mj.control.tracking import reference_at_nodes
from ftc_mj.sim.loop import simulate
from ftc_mj.wiring.control import build_controller
from tests.control.common import cfg_with, problem
from tests.support.kinsim import simulate as kin_simulate

STEP = 20.0 * 0.1  # rad/s: omega_rate_max (rad/s²) x controller period (s)
OMEGA_MAX = problem().omega_max
TOL = 1e-6  # rad/s: the acceptance tolerance; solver tolerances (~1e-7) are clipped away in _accept


def _steps(omega: np.ndarray) -> np.ndarray:
    """Largest per-wheel change (rad/s) between consecutive commands, (K, 2) -> (K-1,)."""
    return np.abs(np.diff(omega, axis=0)).max(axis=1)


def test_first_input_bounds(built, circle) -> None:
    spec = problem()
    lo, hi = first_input_bounds(spec, None)
    np.testing.assert_array_equal(lo, [-OMEGA_MAX] * 2)
    np.testing.assert_array_equal(hi, [OMEGA_MAX] * 2)
    lo, hi = first_input_bounds(spec, np.array([1.0, -17.0]))
    np.testing.assert_allclose(lo, [-1.0, -OMEGA_MAX])
    np.testing.assert_allclose(hi, [3.0, -15.0])
    lo, hi = first_input_bounds(spec, np.array([30.0, 0.0]))  # outside the box: clipped first, never empty
    np.testing.assert_allclose(lo, [OMEGA_MAX - STEP, -STEP])
    np.testing.assert_allclose(hi, [OMEGA_MAX, STEP])
    for bad in (np.array([np.nan, 0.0]), np.array([1.0, 2.0, 3.0])):
        with pytest.raises(ValueError, match="u_applied"):
            first_input_bounds(spec, bad)
    # the step penalty rate_penalty T_s |Δ/T_s|² = (rate_penalty / T_s) |Δ|²: 1 / 0.1 s = 10 per (rad/s)²
    u = np.array([1.0, 2.0])
    on = problem(rate_penalty=1.0, rate_penalty_first_step=True)
    assert first_step_penalty(on, u) == pytest.approx(10.0)
    assert first_step_penalty(problem(rate_penalty=1.0), u) == 0.0  # off by default
    assert first_step_penalty(on, None) == 0.0 == first_step_penalty(spec, u)
    ctl = built(NMPC, spec, circle, solver="rti-daqp", time_budget=None, cold_time_budget=None)
    with pytest.raises(ValueError, match="u_applied"):  # a caller's bug fails the run, it is no fallback
        ctl.solve(0.0, np.zeros(3), np.array([2.0, 2.0]), np.array([np.inf, 0.0]))


@settings(max_examples=60, deadline=None)
@example(w=[0.0, -2.3628680158659134e-297], prev=[0.0, 2.0], dpsi=0.0)  # |plain - prev| rounds to STEP
@given(w=st.lists(st.floats(-OMEGA_MAX, OMEGA_MAX), min_size=2, max_size=2),
       prev=st.lists(st.floats(-OMEGA_MAX, OMEGA_MAX), min_size=2, max_size=2), dpsi=st.floats(-1.0, 1.0))
def test_dither_stays_within_the_step_bound(w: list[float], prev: list[float], dpsi: float) -> None:
    """The dithered command stays within ±STEP of the command in force and within ±omega_max; where the
    step bound does not bind it is the plain dithered command."""
    radii = np.array([2.0, 1.0])
    out = dither_wheel_rates(np.array(w), dpsi, radii, 1.0, OMEGA_MAX, np.array(prev), STEP)
    plain = dither_wheel_rates(np.array(w), dpsi, radii, 1.0, OMEGA_MAX)
    assert np.all(np.abs(out - prev) <= STEP + 1e-12) and np.all(np.abs(out) <= OMEGA_MAX)
    inside = (plain >= np.array(prev) - STEP) & (plain <= np.array(prev) + STEP)  # the clip's own interval
    np.testing.assert_array_equal(out[inside], plain[inside])


def test_fallback_and_warm_start_meet_the_bound(built, circle) -> None:
    """A fallback (the reference feed-forward before any plan, the shifted plan after one) and the warm
    start of the next solve are moved into the first-step bound when the command in force is far from
    them (as after a saturated sample)."""
    ref = circle
    R = np.array([2.0, 2.0])
    # IPOPT stopped at max_iter = 0 always falls back (the time budget never acts); the build test_nmpc's
    # injected-failure test uses
    ff = built(build_controller, cfg_with(solver="ipopt", max_iter=0), ref)
    o = ff.solve(0.0, np.zeros(3), R)
    ua = o.omega + np.array([5.0, -5.0])
    o = ff.solve(0.1, np.zeros(3), R, ua)
    assert o.fallback and np.all(np.abs(o.omega - ua) <= STEP + 1e-12)
    np.testing.assert_array_equal(o.predicted_omega[0], o.omega)

    ctl = built(NMPC, problem(), ref, solver="rti-daqp", time_budget=None, cold_time_budget=None)
    first = ctl.solve(0.0, np.zeros(3), R)
    ua = first.omega + np.array([4.0, -4.0])
    o = ctl.solve(0.1, np.array([np.nan, 0.0, 0.0]), R, ua)  # invalid pose: the shifted plan
    assert o.fallback and np.all(np.abs(o.omega - ua) <= STEP + 1e-12)
    pose = np.array([1.0, 0.0, 0.02])
    r, _ = reference_at_nodes(ref, ctl.col.times(0.1), pose[2])
    _, Ug = ctl._guess(0.1, pose, r, R)
    assert np.all(np.abs(Ug[0] - ua) <= STEP + 1e-12)
    o = ctl.solve(0.1, pose, R, ua)
    assert not o.fallback and o.status.startswith("rti") and np.all(np.abs(o.omega - ua) <= STEP + TOL)


@pytest.mark.parametrize("kind, duration", [("rti-daqp", 3.0), ("ipopt", 1.0), ("lmpc", 1.0)])
def test_saturated_kinematic_loop_meets_the_bound(kind: str, duration: float, built, circle) -> None:
    """Every MPC (RTI, IPOPT, LMPC) on a kinematic loop told swapped radii (the plan saturates): the
    commands change by at most STEP per sample, reaching it; the free first input jumps by more."""
    ref = circle
    worst = {}
    for bound in (True, False):
        spec = problem(rate_bound_from_applied=bound)
        ctl = (built(LinearMPC, spec, ref, time_budget=None) if kind == "lmpc"
               else built(NMPC, spec, ref, solver=kind, time_budget=None, cold_time_budget=None))
        res = kin_simulate(ctl, ref, duration, true_radii=lambda t: (1.0, 2.0), model_radii=lambda t: (2.0, 1.0))
        steps = _steps(np.array([o.omega for o in res.outputs]))
        worst[bound] = steps.max()
        if bound:
            assert steps.max() <= STEP + TOL
            assert np.sum(steps >= STEP - TOL) >= 3
            assert ctl.failures == 0
    print(f"\n[ctl] {kind}, saturated kinematic loop {duration:.0f} s: largest command step {worst[True]:.3f} rad/s "
          f"with the bound, {worst[False]:.2f} rad/s with the first input free")
    assert worst[False] > STEP + 0.5


def _mujoco_commands(scenario: str, duration: float, **overrides) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Commands (K, 2) at the controller samples, their times (s) and whether the dither was on."""
    cfg = load_config(scenario, {"reconfiguration.policy": "direct", "duration": duration, **overrides})
    res = simulate(cfg)
    assert res.error is None
    tr = res.trace
    k = np.arange(tr["t"].size) % cfg.estimator_per_controller == 0
    return (np.stack([tr["omega_R_cmd"][k], tr["omega_L_cmd"][k]], axis=1), tr["t"][k],
            np.isfinite(tr["excitation"][k]))


@pytest.mark.parametrize("scenario, duration", [("scenario2", 12.0), ("scenario4", 14.0)])
def test_saturated_mujoco_run_meets_the_bound(scenario: str, duration: float) -> None:
    """MuJoCo plant, UKF, RTI NMPC, direct feedback (the loop leaves the path after the fault and
    saturates): every command step is within STEP (+1e-6), the bound is reached in many samples, and
    the earlier formulation jumps by up to the full wheel-rate range in the same run."""
    cmd, t, _ = _mujoco_commands(scenario, duration)
    old, _, _ = _mujoco_commands(scenario, duration, **{"controller.rate_bound_from_applied": False})
    steps, steps_old = _steps(cmd), _steps(old)
    at = steps >= STEP - TOL
    print(f"\n[ctl] {scenario} direct, {duration:.0f} s MuJoCo: largest step {steps.max():.3f} rad/s, at the bound "
          f"in {at.sum()} samples from t = {t[1:][at].min():.1f} s; first input free: largest {steps_old.max():.1f} "
          f"rad/s, {np.sum(steps_old > STEP + TOL)} samples over the bound")
    assert steps.max() <= STEP + TOL
    assert at.sum() >= 5
    assert steps_old.max() > 10.0


def test_dithered_mujoco_run_meets_the_bound() -> None:
    """With the excitation dither (amplitude 1 rad/s of yaw rate, ±0.5 rad/s per wheel at these radii)
    on top of a saturating loop, the dithered command still changes by at most STEP per sample, also in
    samples where the MPC's own first step is at the bound."""
    cmd, _, dithered = _mujoco_commands("scenario2", 12.0, **{"reconfiguration.excitation.enabled": True,
                                                              "reconfiguration.excitation.amplitude": 1.0})
    steps = _steps(cmd)
    assert steps.max() <= STEP + TOL
    assert np.sum(dithered[1:] & (steps >= STEP - TOL)) >= 3


def test_command_step_metrics() -> None:
    """``command_step_max`` and ``command_at_rate_limit_s`` on a held (100 Hz) command trace: steps of
    2.0 (the bound), 1.0 and 5.0 rad/s at three controller samples -> max 5.0 rad/s, two periods (0.2 s)
    at or beyond the bound."""
    from ftc_mj.metrics.run import compute_metrics
    from ftc_mj.sim.record import build_record
    from ftc_mj.telemetry.columns import BASE_COLUMNS

    cfg = load_config("scenario1", {"duration": 2.0})
    n = 200
    tr = {c: np.zeros(n) for c in BASE_COLUMNS}
    tr["t"] = np.arange(n) * 0.01
    for c in ("R_R", "R_L", "R_R_hat", "R_L_hat"):
        tr[c][:] = 2.0
    tr["innovation_std"][:] = 1.0
    tr["solve_time_ms"][:] = np.nan
    tr["omega_R_cmd"][50:] += 2.0
    tr["omega_L_cmd"][100:] -= 1.0
    tr["omega_R_cmd"][150:] += 5.0
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["command_step_max"] == pytest.approx(5.0)
    assert m["command_at_rate_limit_s"] == pytest.approx(0.2)
