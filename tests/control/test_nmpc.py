"""The pseudospectral NMPC: closed loops on the kinematic model (RK4 plant under ZOH), agreement with the
plain Opti build and between RTI and IPOPT, the acceleration bounds, failure handling, heading branches.

Numbers quoted in the report come from ``pytest tests/control/test_nmpc.py -s`` (printed lines ``[ctl]``).
"""

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.control import NMPC, barycentric_interpolate
from ftc_mj.control.tracking import reference_at_nodes
from ftc_mj.control.transcription import Collocation
from ftc_mj.wiring.control import build_controller
from tests.control.common import NOMINAL, OFFSET_POSE, cfg_with, check_bounds, left_step, problem
from tests.support.kinsim import simulate
from tests.support.opti_nmpc import OptiNMPC


def _settle_time(res, tol: float) -> float:
    """First time after which |cross-track| stays below ``tol`` until the fault (10 s)."""
    m = res.t < 10.0
    bad = np.nonzero(np.abs(res.cross_track[m]) >= tol)[0]
    return float(res.t[m][bad[-1] + 1]) if len(bad) else 0.0


@pytest.fixture(scope="module")
def rti_fault_run(built, circle):
    ctl = built(build_controller, cfg_with(), circle)  # default solver
    res = simulate(ctl, circle, 20.0, OFFSET_POSE, true_radii=left_step)
    return ctl, res


def test_nmpc_default_offset_and_fault(rti_fault_run) -> None:
    ctl, res = rti_fault_run
    assert isinstance(ctl, NMPC) and ctl.solver_name == RunConfig().controller.solver
    t01 = _settle_time(res, 0.1)
    e_hold = res.max_abs_error(2.0, 10.0)
    e_fault = res.max_abs_error(10.0, 20.0)
    st = res.solve_times[1:] * 1e3
    print(f"\n[ctl] nmpc {ctl.solver_name}: |e|<0.1 m from t={t01:.2f} s; max|e| 2-10 s {e_hold:.2e} m; "
          f"max|e| 10-20 s after 50% left step (true radii) {e_fault:.2e} m; failures {ctl.failures}; "
          f"warm solve median {np.median(st):.2f} ms p95 {np.percentile(st, 95):.2f} ms")
    assert t01 <= 2.0
    assert e_hold < 0.05
    assert e_fault < 0.5
    assert ctl.failures == 0
    assert all(not o.fallback for o in res.outputs)
    check_bounds(res)
    o = res.outputs[-1]
    assert o.predicted.shape == (50, 3) and o.predicted_omega.shape == (50, 2)
    np.testing.assert_allclose(o.predicted_t[[0, -1]], [19.9, 24.9])


def test_nmpc_ipopt_offset_matches_opti(built, circle) -> None:
    ref = circle
    ctl = built(build_controller, cfg_with(solver="ipopt"), ref)
    res = simulate(ctl, ref, 8.0, OFFSET_POSE, true_radii=left_step)
    t01 = _settle_time(res, 0.1)
    print(f"\n[ctl] nmpc ipopt: |e|<0.1 m from t={t01:.2f} s; max|e| 2-8 s {res.max_abs_error(2.0, 8.0):.2e} m; "
          f"iters median {np.median([o.iterations for o in res.outputs]):.0f}")
    assert t01 <= 2.0 and res.max_abs_error(2.0, 8.0) < 0.05
    assert ctl.failures == 0
    check_bounds(res)
    # the plain Opti + IPOPT build of the same problem gives the same plan
    spec = ctl.spec
    col = Collocation(spec)
    opti = OptiNMPC(spec)
    ctl2 = built(NMPC, spec, ref, solver="ipopt", time_budget=None, cold_time_budget=None)
    out = ctl2.solve(0.0, np.array(OFFSET_POSE), np.array(NOMINAL))
    r, _ = reference_at_nodes(ref, col.times(0.0), 0.0)
    X, U, _ = opti.solve(np.array(OFFSET_POSE), np.array(NOMINAL), r, r[:3].T, out.predicted_omega)
    np.testing.assert_allclose(out.predicted_omega, U, atol=1e-4)
    np.testing.assert_allclose(out.predicted, X, atol=1e-5)


@pytest.mark.parametrize("first_step", ["free", "bound"])
@pytest.mark.parametrize("rate_penalty", [0.0, 0.05])
def test_nmpc_rti_converges_to_ipopt(rate_penalty: float, first_step: str, built, circle) -> None:
    """RTI steps from the shifted IPOPT plan converge (Gauss–Newton, linearly) to IPOPT's solution
    (also with the optional rate penalty, and IPOPT agrees with the plain Opti build). ``bound``: the
    command in force is the t = 0 command, and the perturbed pose asks for more than the first-step
    bound ``|U(t0) − u_applied| ≤ omega_rate_max T_s`` = 2 rad/s allows, so it is active (with the
    rate penalty, the penalty on that step acts too)."""
    ref = circle
    spec = problem(rate_penalty=rate_penalty, rate_penalty_first_step=True)
    # no wall-clock rules: a loaded machine must not matter
    rti = built(NMPC, spec, ref, solver="rti-daqp", time_budget=None, cold_time_budget=None)
    ip = built(NMPC, spec, ref, solver="ipopt", time_budget=None, cold_time_budget=None)
    R = np.array(NOMINAL)
    pose0 = np.array(OFFSET_POSE)
    rti.solve(0.0, pose0, R)
    o0 = ip.solve(0.0, pose0, R)
    col = Collocation(spec)
    tau1 = 0.1 / col.h - 1.0
    pose1 = barycentric_interpolate(col.tau, o0.predicted, np.array([tau1]))[0] + np.array([0.03, -0.02, 0.005])
    ua = o0.omega if first_step == "bound" else None
    b = ip.solve(0.1, pose1, R, ua)
    a = rti.solve(0.1, pose1, R, ua)  # the first RTI iterate, from the shifted plan
    assert a.status.startswith("rti") and not a.fallback and not b.fallback
    r, _ = reference_at_nodes(ref, col.times(0.1), pose1[2])
    Xg, Ug = a.predicted, a.predicted_omega
    errs = [np.abs(Ug - b.predicted_omega).max()]
    for _ in range(5):
        ok, _, Xg, Ug = rti._qp.solve(Xg, Ug, R, pose1, r, u_prev=ua)
        assert ok
        errs.append(np.abs(Ug - b.predicted_omega).max())
    e_str = " ".join(f"{v:.1e}" for v in errs)
    print(f"\n[ctl] RTI iterates vs converged IPOPT plan ({first_step} first step), max|domega| (rad/s): {e_str}")
    assert errs[0] < 0.2 and errs[-1] < 1e-3
    np.testing.assert_allclose(a.omega, b.omega, atol=0.2)
    if ua is not None:  # both meet the bound (2 rad/s = 20 rad/s² x 0.1 s); active without the penalty
        step = np.abs(b.omega - ua)
        assert np.all(step <= 2.0 + 1e-6) and np.all(np.abs(Ug[0] - ua) <= 2.0 + 1e-6)
        assert step.max() > 2.0 - 1e-6 or rate_penalty > 0
    if rate_penalty > 0 or ua is not None:
        X, U, _ = built(OptiNMPC, spec).solve(pose1, R, r, b.predicted, b.predicted_omega, ua)
        np.testing.assert_allclose(b.predicted_omega, U, atol=1e-4)


def test_nmpc_nominal_radii_steady_error(built, circle) -> None:
    """No feedback of the radii: the model keeps the nominal radii after the puncture."""
    cfg = cfg_with()
    ref = circle
    ctl = built(build_controller, cfg, ref)
    res = simulate(ctl, ref, 30.0, (0.0, 0.0, 0.0), true_radii=left_step, model_radii=lambda t: NOMINAL)
    rms = res.rms_error(20.0, 30.0)
    mx = res.max_abs_error(20.0, 30.0)
    print(f"\n[ctl] nmpc {cfg.controller.solver}, nominal radii after 50% left step: steady |e| RMS {rms:.2f} m, "
          f"max {mx:.2f} m (t 20-30 s); with true radii it is < 1e-3 m")
    assert 0.5 < rms < 5.0
    assert ctl.failures == 0
    check_bounds(res)


def test_injected_failure_max_iter_zero(built, circle) -> None:
    cfg = cfg_with(solver="ipopt", max_iter=0)
    ref = circle
    ctl = built(build_controller, cfg, ref)  # shared with test_rate_bound's fallback test
    res = simulate(ctl, ref, 2.0, (0.0, 0.0, 0.0))
    assert len(res.outputs) == 20
    assert ctl.failures == 20
    assert all(o.fallback and not o.success and "max_iter" in o.status for o in res.outputs)
    check_bounds(res)
    # no plan ever existed: fallback is the reference feed-forward, which tracks the nominal circle
    assert res.max_abs_error(0.0, 2.0) < 1e-6


@pytest.mark.parametrize("solver", ["rti-daqp", "ipopt"])
def test_injected_nan_radii_and_pose(solver: str, built, circle) -> None:
    ref = circle
    ctl = built(build_controller, cfg_with(solver=solver), ref)
    bad = {12, 13, 14}

    class Faulty:
        failures = 0

        def solve(self, t, pose, radii, u_applied=None):
            k = int(round(t * 10))
            if k in bad:
                radii = np.array([np.nan, 2.0])
            if k == 20:
                pose = np.array([np.nan, 0.0, 0.0])
            return ctl.solve(t, pose, radii, u_applied)

    res = simulate(Faulty(), ref, 5.0, (0.0, 0.0, 0.0))
    fb = [k for k, o in enumerate(res.outputs) if o.fallback]
    assert fb == [12, 13, 14, 20]
    assert ctl.failures == 4
    assert "radii" in res.outputs[12].status and "pose" in res.outputs[20].status
    # fallback = the shifted previous plan: command close to the steady command
    np.testing.assert_allclose(res.outputs[13].omega, res.outputs[11].omega, atol=0.05)
    assert res.max_abs_error(0.0, 5.0) < 0.05
    check_bounds(res)


def test_over_budget_falls_back(circle) -> None:
    ref = circle
    ctl = NMPC(problem(), ref, solver="rti-daqp", time_budget=1e-9)
    ctl.solve(0.0, np.zeros(3), np.array(NOMINAL))  # cold IPOPT seed: its own budget
    o = ctl.solve(0.1, np.array([1.0, 0.0, 0.02]), np.array(NOMINAL))
    assert o.fallback and "over budget" in o.status and ctl.failures == 1


def test_heading_wrap(built, circle) -> None:
    """A measured heading off by 2π k is the same pose (one build, reset between the two cold solves: a reset
    NMPC is a new one, ``test_reset_controller_repeats_a_new_ones_loop``)."""
    ref = circle
    a = built(NMPC, problem(), ref, solver="ipopt", time_budget=None, cold_time_budget=None)
    pose = np.array([0.0, -1.0, 0.1])
    oa = a.solve(0.0, pose, np.array(NOMINAL))
    a.reset()
    ob = a.solve(0.0, pose + np.array([0, 0, -4 * np.pi]), np.array(NOMINAL))
    np.testing.assert_allclose(oa.omega, ob.omega, atol=1e-6)


@pytest.mark.parametrize("kind", ["nmpc", "lmpc"])
def test_wrapped_heading_in_closed_loop(kind: str, built, circle) -> None:
    """The plant reports psi wrapped to (-π, π]; the circle's psi passes π at t ≈ 15.7 s."""
    ref = circle
    ctl = built(build_controller, cfg_with(kind=kind), ref)

    class Wrapped:
        failures = 0

        def solve(self, t, pose, radii, u_applied=None):
            p = np.array(pose, dtype=float)
            p[2] = (p[2] + np.pi) % (2 * np.pi) - np.pi
            return ctl.solve(t, p, radii, u_applied)

    res = simulate(Wrapped(), ref, 20.0, (0.0, 0.0, 0.0))
    assert res.max_abs_error(0.0, 20.0) < 1e-3
    assert ctl.failures == 0


def _lateral(omega: np.ndarray, radii=NOMINAL, b: float = 1.0) -> np.ndarray:
    V = (radii[0] * omega[:, 0] + radii[1] * omega[:, 1]) / 2.0
    r = (radii[0] * omega[:, 0] - radii[1] * omega[:, 1]) / (2.0 * b)
    return V * r


def test_lateral_acceleration_bound_is_respected_and_rti_converges_to_it(built, circle) -> None:
    """With ``max_lateral_accel`` = 1.5 m/s² the 10 m/s, 50 m circle (2 m/s²) is infeasible: IPOPT's
    plan meets the bound at every node (active somewhere), and RTI iterates on the linearised bound
    converge to the same plan."""
    ref = circle
    spec = problem(max_lateral_accel=1.5)
    # a cold solve towards an infeasible reference: more iterations
    ip = built(NMPC, spec, ref, solver="ipopt", time_budget=None, cold_time_budget=None, max_iter=100)
    rti = built(NMPC, spec, ref, solver="rti-daqp", time_budget=None, cold_time_budget=None, max_iter=100)
    R = np.array(NOMINAL)
    r0 = ref.at(0.0)
    pose = np.array([r0.x, r0.y, r0.psi])  # on the circle, heading along it
    o = ip.solve(0.0, pose, R)
    assert o.success and not o.fallback
    lat = _lateral(o.predicted_omega)
    assert np.max(np.abs(lat)) <= 1.5 + 1e-6 and np.max(np.abs(lat)) > 1.5 - 1e-3
    rti.solve(0.0, pose, R)  # IPOPT seed
    col = Collocation(spec)
    r, _ = reference_at_nodes(ref, col.times(0.0), pose[2])
    Xg, Ug = rti._guess(0.0, pose, r, R)
    for _ in range(8):
        ok, _, Xg, Ug = rti._qp.solve(Xg, Ug, R, pose, r)
        assert ok
    np.testing.assert_allclose(Ug, o.predicted_omega, atol=1e-3)
    assert np.max(np.abs(_lateral(Ug))) <= 1.5 + 1e-4
    # without the bound the same plan asks for the circle's 2 m/s²
    free = built(NMPC, problem(), ref, solver="ipopt", time_budget=None, cold_time_budget=None).solve(0.0, pose, R)
    assert np.max(np.abs(_lateral(free.predicted_omega))) > 1.9


def test_longitudinal_acceleration_bound_is_respected_and_rti_meets_it(built, circle) -> None:
    """Starting 10 m behind the reference, the free plan catches up with more than 2 m/s² of forward
    acceleration; with ``max_longitudinal_accel`` = 1 m/s² IPOPT's plan keeps |dV/dt| ≤ 1 m/s² at every
    node (active somewhere) and the RTI QP (the rows are linear in the inputs, so exact) converges to it."""
    ref = circle
    spec = problem(max_longitudinal_accel=1.0)
    ip = built(NMPC, spec, ref, solver="ipopt", time_budget=None, cold_time_budget=None, max_iter=100)
    rti = built(NMPC, spec, ref, solver="rti-daqp", time_budget=None, cold_time_budget=None, max_iter=100)
    R = np.array(NOMINAL)
    col = Collocation(spec)
    r0 = ref.at(0.0)
    pose = np.array([r0.x - 10.0, r0.y, r0.psi])

    def accel(omega: np.ndarray) -> np.ndarray:
        V = (R[0] * omega[:, 0] + R[1] * omega[:, 1]) / 2.0
        return col.D @ V / col.h

    o = ip.solve(0.0, pose, R)
    assert o.success and not o.fallback
    a = np.abs(accel(o.predicted_omega))
    assert a.max() <= 1.0 + 1e-6 and a.max() > 1.0 - 1e-3
    rti.solve(0.0, pose, R)  # IPOPT seed
    r, _ = reference_at_nodes(ref, col.times(0.0), pose[2])
    Xg, Ug = rti._guess(0.0, pose, r, R)
    for _ in range(8):
        ok, _, Xg, Ug = rti._qp.solve(Xg, Ug, R, pose, r)
        assert ok
        assert np.abs(accel(Ug)).max() <= 1.0 + 1e-5
    np.testing.assert_allclose(Ug, o.predicted_omega, atol=1e-3)
    free = built(NMPC, problem(), ref, solver="ipopt", time_budget=None, cold_time_budget=None).solve(0.0, pose, R)
    assert np.abs(accel(free.predicted_omega)).max() > 2.0


def test_reset_controller_repeats_a_new_ones_loop(built, circle) -> None:
    """A used and reset NMPC (what the session's ``built`` cache and the simulation's solver cache hand out)
    runs a loop bitwise like a newly built one."""
    cfg = cfg_with()
    used = built(build_controller, cfg, circle)
    simulate(used, circle, 1.0, OFFSET_POSE)  # leaves a plan, multipliers, an active set, counts
    used.reset()
    new = build_controller(cfg, circle)
    a = simulate(used, circle, 3.0, OFFSET_POSE, true_radii=left_step)
    b = simulate(new, circle, 3.0, OFFSET_POSE, true_radii=left_step)
    np.testing.assert_array_equal(a.pose, b.pose)
    for oa, ob in zip(a.outputs, b.outputs, strict=True):
        assert oa.status == ob.status
        np.testing.assert_array_equal(oa.predicted_omega, ob.predicted_omega)
