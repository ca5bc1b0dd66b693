"""NMPC / LMPC closed loops on the kinematic model (RK4 plant under ZOH), failure handling, factory.

Numbers quoted in the report come from ``pytest tests/test_control.py -s`` (printed lines ``[ctl]``).
"""

import math

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.control import (
    NMPC,
    LinearMPC,
    OpenLoopController,
    OptiNMPC,
    ProblemSpec,
    barycentric_interpolate,
    build_controller,
    build_reference,
)
from ftc_mj.control.collocation import Collocation, reference_at_nodes
from ftc_mj.control.kinsim import simulate

NOMINAL = (2.0, 2.0)
OFFSET_POSE = (0.0, -5.0, 0.0)
OMEGA_MAX = math.radians(1000.0)


def left_step(t: float) -> tuple[float, float]:
    """50 % left-wheel puncture at t = 10 s."""
    return (2.0, 1.0) if t >= 10.0 else (2.0, 2.0)


def _cfg(**ctl) -> RunConfig:
    """Config with controller overrides; a generous time budget so that a loaded CI machine does not
    turn a slow solve into a (correctly counted) fallback. Budget handling: test_over_budget_falls_back."""
    cfg = RunConfig()
    cfg.controller.time_budget = 5.0
    for k, v in ctl.items():
        setattr(cfg.controller, k, v)
    return cfg


def _settle_time(res, tol: float) -> float:
    """First time after which |cross-track| stays below ``tol`` until the fault (10 s)."""
    m = res.t < 10.0
    bad = np.nonzero(np.abs(res.cross_track[m]) >= tol)[0]
    return float(res.t[m][bad[-1] + 1]) if len(bad) else 0.0


def _check_bounds(res) -> None:
    assert np.max(np.abs(res.omega)) <= OMEGA_MAX + 1e-6
    for o in res.outputs:
        assert np.all(np.abs(o.omega) <= OMEGA_MAX + 1e-6)


@pytest.fixture(scope="module")
def rti_fault_run():
    cfg = _cfg()  # default solver
    ref = build_reference(cfg)
    ctl = build_controller(cfg, ref)
    res = simulate(ctl, ref, 20.0, OFFSET_POSE, true_radii=left_step)
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
    _check_bounds(res)
    o = res.outputs[-1]
    assert o.predicted.shape == (50, 3) and o.predicted_omega.shape == (50, 2)
    np.testing.assert_allclose(o.predicted_t[[0, -1]], [19.9, 24.9])


def test_nmpc_ipopt_offset_matches_opti() -> None:
    cfg = _cfg(solver="ipopt")
    ref = build_reference(cfg)
    ctl = build_controller(cfg, ref)
    res = simulate(ctl, ref, 8.0, OFFSET_POSE, true_radii=left_step)
    t01 = _settle_time(res, 0.1)
    print(f"\n[ctl] nmpc ipopt: |e|<0.1 m from t={t01:.2f} s; max|e| 2-8 s {res.max_abs_error(2.0, 8.0):.2e} m; "
          f"iters median {np.median([o.iterations for o in res.outputs]):.0f}")
    assert t01 <= 2.0 and res.max_abs_error(2.0, 8.0) < 0.05
    assert ctl.failures == 0
    _check_bounds(res)
    # the plain Opti + IPOPT build of the same problem gives the same plan
    spec = ctl.spec
    col = Collocation(spec)
    opti = OptiNMPC(spec)
    ctl2 = NMPC(spec, ref, solver="ipopt", time_budget=None, cold_time_budget=None)
    out = ctl2.solve(0.0, np.array(OFFSET_POSE), np.array(NOMINAL))
    r, _ = reference_at_nodes(ref, col.times(0.0), 0.0)
    X, U, _ = opti.solve(np.array(OFFSET_POSE), np.array(NOMINAL), r, r[:3].T, out.predicted_omega)
    np.testing.assert_allclose(out.predicted_omega, U, atol=1e-4)
    np.testing.assert_allclose(out.predicted, X, atol=1e-5)


@pytest.mark.parametrize("first_step", ["free", "bound"])
@pytest.mark.parametrize("rate_penalty", [0.0, 0.05])
def test_nmpc_rti_converges_to_ipopt(rate_penalty: float, first_step: str) -> None:
    """RTI steps from the shifted IPOPT plan converge (Gauss–Newton, linearly) to IPOPT's solution
    (also with the optional rate penalty, and IPOPT agrees with the plain Opti build). ``bound``: the
    command in force is the t = 0 command, and the perturbed pose asks for more than the first-step
    bound ``|U(t0) − u_applied| ≤ omega_rate_max T_s`` = 2 rad/s allows, so it is active (with the
    rate penalty, the penalty on that step acts too)."""
    ref = build_reference(RunConfig())
    spec = ProblemSpec(rate_penalty=rate_penalty, rate_penalty_first_step=True)
    rti = NMPC(spec, ref, solver="rti-daqp", time_budget=None, cold_time_budget=None)  # no wall-clock rules:
    ip = NMPC(spec, ref, solver="ipopt", time_budget=None, cold_time_budget=None)  # a loaded machine must not matter
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
        X, U, _ = OptiNMPC(spec).solve(pose1, R, r, b.predicted, b.predicted_omega, ua)
        np.testing.assert_allclose(b.predicted_omega, U, atol=1e-4)


def test_nmpc_nominal_radii_steady_error() -> None:
    """No feedback of the radii: the model keeps the nominal radii after the puncture."""
    cfg = _cfg()
    ref = build_reference(cfg)
    ctl = build_controller(cfg, ref)
    res = simulate(ctl, ref, 30.0, (0.0, 0.0, 0.0), true_radii=left_step, model_radii=lambda t: NOMINAL)
    rms = res.rms_error(20.0, 30.0)
    mx = res.max_abs_error(20.0, 30.0)
    print(f"\n[ctl] nmpc {cfg.controller.solver}, nominal radii after 50% left step: steady |e| RMS {rms:.2f} m, "
          f"max {mx:.2f} m (t 20-30 s); with true radii it is < 1e-3 m")
    assert 0.5 < rms < 5.0
    assert ctl.failures == 0
    _check_bounds(res)


def test_lmpc_tracks_and_fault() -> None:
    cfg = _cfg(kind="lmpc")
    ref = build_reference(cfg)
    ctl = build_controller(cfg, ref)
    assert isinstance(ctl, LinearMPC)
    res = simulate(ctl, ref, 10.0, OFFSET_POSE)
    st = res.solve_times * 1e3
    print(f"\n[ctl] lmpc {ctl.qpsol}: 5 m offset, max|e| 3-10 s {res.max_abs_error(3.0, 10.0):.2e} m; "
          f"solve median {np.median(st):.2f} ms p95 {np.percentile(st, 95):.2f} ms")
    assert res.max_abs_error(3.0, 10.0) < 0.5
    assert all(o.success and not o.fallback for o in res.outputs)
    _check_bounds(res)
    # 50 % left fault: with the true radii, and with nominal radii
    ctl = build_controller(cfg, ref)
    res_t = simulate(ctl, ref, 25.0, (0.0, 0.0, 0.0), true_radii=left_step)
    ctl2 = build_controller(cfg, ref)
    res_n = simulate(ctl2, ref, 25.0, (0.0, 0.0, 0.0), true_radii=left_step, model_radii=lambda t: NOMINAL)
    print(f"[ctl] lmpc after 50% left step at 10 s: true radii max|e| 10-25 s {res_t.max_abs_error(10, 25):.2e} m; "
          f"nominal radii RMS 15-25 s {res_n.rms_error(15, 25):.2f} m (max {res_n.max_abs_error(10, 25):.2f} m); "
          f"failures {ctl.failures}/{ctl2.failures}")
    assert res_t.max_abs_error(10, 25) < 0.5
    assert ctl.failures == 0 and ctl2.failures == 0
    _check_bounds(res_t)
    _check_bounds(res_n)


def test_injected_failure_max_iter_zero() -> None:
    cfg = _cfg(solver="ipopt", max_iter=0)
    ref = build_reference(cfg)
    ctl = build_controller(cfg, ref)
    res = simulate(ctl, ref, 2.0, (0.0, 0.0, 0.0))
    assert len(res.outputs) == 20
    assert ctl.failures == 20
    assert all(o.fallback and not o.success and "max_iter" in o.status for o in res.outputs)
    _check_bounds(res)
    # no plan ever existed: fallback is the reference feed-forward, which tracks the nominal circle
    assert res.max_abs_error(0.0, 2.0) < 1e-6


@pytest.mark.parametrize("solver", ["rti-daqp", "ipopt"])
def test_injected_nan_radii_and_pose(solver: str) -> None:
    cfg = _cfg(solver=solver)
    ref = build_reference(cfg)
    ctl = build_controller(cfg, ref)
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
    _check_bounds(res)


def test_over_budget_falls_back() -> None:
    ref = build_reference(RunConfig())
    ctl = NMPC(ProblemSpec(), ref, solver="rti-daqp", time_budget=1e-9)
    ctl.solve(0.0, np.zeros(3), np.array(NOMINAL))  # cold IPOPT seed: its own budget
    o = ctl.solve(0.1, np.array([1.0, 0.0, 0.02]), np.array(NOMINAL))
    assert o.fallback and "over budget" in o.status and ctl.failures == 1


def test_heading_wrap() -> None:
    """A measured heading off by 2π k is the same pose."""
    ref = build_reference(RunConfig())
    a = NMPC(ProblemSpec(), ref, solver="ipopt", time_budget=None, cold_time_budget=None)
    b = NMPC(ProblemSpec(), ref, solver="ipopt", time_budget=None, cold_time_budget=None)
    pose = np.array([0.0, -1.0, 0.1])
    oa = a.solve(0.0, pose, np.array(NOMINAL))
    ob = b.solve(0.0, pose + np.array([0, 0, -4 * np.pi]), np.array(NOMINAL))
    np.testing.assert_allclose(oa.omega, ob.omega, atol=1e-6)


def test_shift_exact_for_polynomials() -> None:
    col = Collocation(ProblemSpec(nodes=12))
    t = col.times(0.0)
    X = np.stack([t**3, t**2, t], axis=1)
    U = np.stack([t**4, 1 + t], axis=1)
    Xn, Un = col.shift(0.0, X, U, 0.1, 1.0, np.array(NOMINAL))
    tn = col.times(0.1)
    inside = tn <= t[-1]
    np.testing.assert_allclose(Xn[inside, 0], tn[inside] ** 3, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(Un[inside, 0], tn[inside] ** 4, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(Un[~inside], U[-1][None, :].repeat((~inside).sum(), 0))


def test_factory_kinds() -> None:
    cfg = _cfg(kind="open-loop", open_loop_omega=(3.0, 4.0))
    ctl = build_controller(cfg, build_reference(cfg))
    assert isinstance(ctl, OpenLoopController)
    np.testing.assert_allclose(ctl.solve(0.0, np.zeros(3), np.array(NOMINAL)).omega, [3.0, 4.0])
    assert isinstance(build_controller(_cfg(kind="lmpc"), build_reference(cfg)), LinearMPC)
    with pytest.raises(ValueError):
        NMPC(ProblemSpec(), build_reference(cfg), solver="bogus")


@pytest.mark.parametrize("kind", ["nmpc", "lmpc"])
def test_wrapped_heading_in_closed_loop(kind: str) -> None:
    """The plant reports psi wrapped to (-π, π]; the circle's psi passes π at t ≈ 15.7 s."""
    cfg = _cfg(kind=kind)
    ref = build_reference(cfg)
    ctl = build_controller(cfg, ref)

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


def test_lateral_acceleration_bound_is_respected_and_rti_converges_to_it() -> None:
    """With ``max_lateral_accel`` = 1.5 m/s² the 10 m/s, 50 m circle (2 m/s²) is infeasible: IPOPT's
    plan meets the bound at every node (active somewhere), and RTI iterates on the linearised bound
    converge to the same plan."""
    ref = build_reference(RunConfig())
    spec = ProblemSpec(max_lateral_accel=1.5)
    ip = NMPC(spec, ref, solver="ipopt", time_budget=None, cold_time_budget=None, max_iter=100)  # cold, infeasible ref
    rti = NMPC(spec, ref, solver="rti-daqp", time_budget=None, cold_time_budget=None, max_iter=100)
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
    free = NMPC(ProblemSpec(), ref, solver="ipopt", time_budget=None, cold_time_budget=None).solve(0.0, pose, R)
    assert np.max(np.abs(_lateral(free.predicted_omega))) > 1.9


def test_longitudinal_acceleration_bound_is_respected_and_rti_meets_it() -> None:
    """Starting 10 m behind the reference, the free plan catches up with more than 2 m/s² of forward
    acceleration; with ``max_longitudinal_accel`` = 1 m/s² IPOPT's plan keeps |dV/dt| ≤ 1 m/s² at every
    node (active somewhere) and the RTI QP (the rows are linear in the inputs, so exact) converges to it."""
    ref = build_reference(RunConfig())
    spec = ProblemSpec(max_longitudinal_accel=1.0)
    ip = NMPC(spec, ref, solver="ipopt", time_budget=None, cold_time_budget=None, max_iter=100)
    rti = NMPC(spec, ref, solver="rti-daqp", time_budget=None, cold_time_budget=None, max_iter=100)
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
    free = NMPC(ProblemSpec(), ref, solver="ipopt", time_budget=None, cold_time_budget=None).solve(0.0, pose, R)
    assert np.abs(accel(free.predicted_omega)).max() > 2.0


DAQP_ITERATION_LIMIT = -4  # DAQP's exit flag when it stops at its iteration limit


def _record_qps(spec: ProblemSpec, true_radii, model_radii, duration: float = 10.0) -> tuple[NMPC, list]:
    """QP data ``(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx)`` of every RTI step of a closed loop solved by the CasADi
    plugin alone (``certified`` off)."""
    ref = build_reference(RunConfig())
    ctl = NMPC(spec, ref, solver="rti-daqp", time_budget=None, cold_time_budget=None, max_iter=300)
    qp = ctl._qp
    qp.certified = False
    with qp.recording() as rec:
        simulate(ctl, ref, duration, (0.0, 0.0, 0.0), true_radii=true_radii, model_radii=model_radii)
    return ctl, rec


def test_saturated_loop_is_bitwise_repeatable_in_one_process() -> None:
    """The same closed loop twice in one process gives bitwise the same QPs, whatever the thread
    environment: with CasADi's bundled OpenBLAS multithreaded, IPOPT's seed differed by up to 3e-12
    from one call to the next and the saturated loop turned that into other trajectories."""
    spec = ProblemSpec(max_lateral_accel=1.5)
    runs = [_record_qps(spec, lambda t: (1.0, 2.0), lambda t: (2.0, 1.0), duration=3.0)[1] for _ in range(2)]
    assert len(runs[0]) == len(runs[1]) > 20
    for qa, qb in zip(*runs, strict=True):
        for a, b in zip(qa, qb, strict=True):
            assert np.array_equal(a, b)


@pytest.mark.parametrize("case", ["swapped", "wrong-radii", "lateral", "longitudinal"])
def test_certified_qp_equals_plugin_on_saturated_loop(case: str) -> None:
    """The certified active-set path and the CasADi daqp plugin give the same QP solutions (and the
    same infeasibility verdicts) on QPs recorded from loops that saturate the wheels: the model is
    told the wrong radii, so the plan keeps hitting the rate and wheel-rate bounds (up to ~97 of the
    100 inputs' constraints active), and the first-step bound from the command in force (the two
    first inputs' box, tightened to ±2 rad/s about it) is active in most of them."""
    spec = {"lateral": ProblemSpec(max_lateral_accel=1.5),
            "longitudinal": ProblemSpec(max_longitudinal_accel=1.0)}.get(case, ProblemSpec())
    if case == "wrong-radii":
        ctl, rec = _record_qps(spec, lambda t: (2.0, 0.5), lambda t: NOMINAL)
    else:
        ctl, rec = _record_qps(spec, lambda t: (1.0, 2.0), lambda t: (2.0, 1.0))
    qp = ctl._qp
    qp.reset()
    n, N = qp.nu, qp.col.N
    errs, n_active, verdicts, first_active = [], [], [], 0
    for H, g, E, e, Lv, ll, lu, Lo, lbx, ubx in rec:
        u_ref, _, _, _ = qp._qpfun(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx, np.zeros(n), np.zeros(n),
                                   np.zeros(qp._lam_a.size))
        ref_status = qp._qpfun.stats().get("return_status")
        ok_ref = qp._qpfun.ret == 0 and bool(qp._qpfun.stats().get("success", True))
        verdict, u, lam_x, lam_a = qp._solve_certified(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx)
        verdicts.append(verdict)
        if verdict == "unresolved":  # the plugin decides; nothing to compare
            qp._ws = None
            continue
        # DAQP may stop at its iteration limit (exit flag -4) on a feasible QP that the certified path
        # solves; it must never contradict a verdict either way (infeasible is exit flag -1)
        gave_up = verdict == "optimal" and not ok_ref and ref_status == DAQP_ITERATION_LIMIT
        assert (verdict == "optimal") == ok_ref or gave_up
        if verdict != "optimal":
            qp._ws = None
            continue
        A, lba, uba = qp._rows(E, e, Lv, ll, lu, Lo)
        Au = A @ u
        assert np.all(Au >= lba - 1e-6) and np.all(Au <= uba + 1e-6)
        assert np.all(u >= lbx - 1e-6) and np.all(u <= ubx + 1e-6)
        np.testing.assert_allclose(H @ u + g + lam_x + A.T @ lam_a, 0.0, atol=1e-6 * (1 + np.abs(g).max()))
        if gave_up:  # certified (feasible, stationary, right-signed multipliers); nothing to compare
            continue
        cost = 0.5 * u @ H @ u + g @ u
        cost_ref = 0.5 * u_ref @ H @ u_ref + g @ u_ref
        # never worse than the plugin's beyond the tolerances both work to. By convexity, for the
        # certified (u, lam) with stationarity residual r: f(u) - f(v) <= |r|_inf |v - u|_1 +
        # sum |lam_i| (violation by v of the bound lam_i sits on + slack of u to it). DAQP accepts
        # violations up to 1e-6 (and with multipliers ~1e3 its cost may sit ~1e-3 below the exactly
        # feasible optimum); the certified u solves its active set exactly (slack ~1e-9 at most).
        lam_l1 = np.abs(lam_x).sum() + np.abs(lam_a).sum()
        stat_tol = 1e-6 * (1 + np.abs(g).max())
        budget = stat_tol * np.abs(u_ref - u).sum() + lam_l1 * (1e-6 + 1e-9) + 1e-12 * (1 + abs(cost_ref))
        assert cost - cost_ref <= budget, (cost - cost_ref, budget)
        assert cost >= cost_ref - 1e-6 * (1 + abs(cost_ref))  # nor better than tolerance allows
        errs.append(np.abs(u - u_ref).max())
        n_active.append(int(np.count_nonzero(qp._ws)))
        tight = (lbx[[0, N]] > -qp.omega_max) & (ubx[[0, N]] < qp.omega_max)
        first_active += bool(np.any(tight & (qp._ws[[0, N]] != 0)))
    errs_a = np.array(errs)
    counts = {v: verdicts.count(v) for v in set(verdicts)}
    print(f"\n[ctl] certified vs plugin QP ({case}): {len(rec)} QPs {counts}; active bounds/rows median "
          f"{np.median(n_active):.0f} max {max(n_active)}; first-step bound active in {first_active}; "
          f"max|du| median {np.median(errs_a):.1e} max {errs_a.max():.1e} rad/s")
    assert counts.get("optimal", 0) >= 0.85 * len(rec)
    assert first_active >= 0.5 * len(errs)
    assert max(n_active) >= (80 if case in ("swapped", "wrong-radii") else 20)
    assert np.median(errs_a) < 1e-8
    assert errs_a.max() < 1e-3  # ill-conditioned H (cond ~1e7): DAQP versions differ by up to ~5e-4 here


def test_certified_qp_random_and_infeasible() -> None:
    """CertifiedQP on small random QPs against CasADi's daqp (same solution or same infeasibility
    verdict), a wrong guess is rejected, and an infeasible QP is certified infeasible."""
    import casadi as ca

    from ftc_mj.control.certified_qp import CertifiedQP

    rng = np.random.default_rng(3)
    n, m = 12, 9
    ref = ca.conic("q", "daqp", {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(m, n)},
                   {"error_on_fail": False})
    cqp = CertifiedQP()
    seen = set()
    for _ in range(60):
        M = rng.standard_normal((n, n))
        H = M @ M.T + 0.1 * np.eye(n)
        g = 10.0 * rng.standard_normal(n)
        A = rng.standard_normal((m, n))
        c = rng.standard_normal(m)
        lba, uba = c - rng.uniform(0.0, 2.0, m), c + rng.uniform(0.0, 2.0, m)
        lba[0] = uba[0]  # one equality row
        lbx, ubx = -np.ones(n), np.ones(n)
        r_ref = ref(h=H, g=g, a=A, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
        ok_ref = bool(ref.stats()["success"])
        res = cqp.solve(H, g, A, lba, uba, lbx, ubx)
        seen.add(res.path)
        if res.status == "unresolved":
            continue
        assert (res.status == "optimal") == ok_ref
        if ok_ref:
            np.testing.assert_allclose(res.u, np.asarray(r_ref["x"]).ravel(), atol=1e-6)
            # the solution's own working set is a certified guess; a wrong one is not accepted
            again = cqp.solve(H, g, A, lba, uba, lbx, ubx, guess=res.working_set)
            assert again.path == "guess"
            np.testing.assert_allclose(again.u, res.u, atol=1e-9)
            wrong = np.zeros(n + m, dtype=np.int8)
            wrong[:n] = 1  # all upper bounds active: not optimal for these g
            assert cqp._try(np.linalg.inv(np.linalg.cholesky(H)), H, g, A, np.r_[lbx, lba], np.r_[ubx, uba],
                            lba == uba, wrong, "guess") is None or np.all(res.u > 1 - 1e-6)
    assert "ipm" in seen and "farkas" in seen
    # equality row outside what the box allows: infeasible, with a certificate
    A = np.ones((1, n))
    res = cqp.solve(np.eye(n), np.zeros(n), A, np.array([2.0 * n]), np.array([2.0 * n]), -np.ones(n), np.ones(n))
    assert res.status == "infeasible" and res.path == "farkas"


def test_certificate_refuses_a_working_set_whose_refinement_does_not_converge() -> None:
    """Two nearly parallel active rows (``a`` and ``a + 3e-8 d``) with multipliers 1e9: ``YᵀY`` has a
    condition number ~1e16, so the two refinement steps leave the working-set residual at ~5e-8
    relative — inside ``primal_tol`` and with right-signed multipliers and rounding-level stationarity,
    so primal feasibility, signs and stationarity alone would accept a ``u`` 0.5 away from the exact
    KKT point. The working-set residual (complementarity) part of the certificate refuses it, and
    ``solve`` then does not return the guess."""
    from ftc_mj.control.certified_qp import CertifiedQP

    n = 4
    H = np.eye(n)
    a = np.array([1.0, 2.0, -1.0, 0.5])
    A = np.vstack([a, a + 3e-8 * np.array([0.3, -1.0, 0.7, 1.1])])
    u_star = np.array([0.2, -0.1, 0.3, 0.05])
    uba = A @ u_star
    lba = uba - 10.0
    g = -H @ u_star - A.T @ np.array([1e9, 1e9])  # KKT: H u* + g + Aᵀλ* = 0, both rows active at u*
    lbx, ubx = -np.ones(n), np.ones(n)
    lo, hi = np.r_[lbx, lba], np.r_[ubx, uba]
    ws = np.array([0, 0, 0, 0, 1, 1], dtype=np.int8)
    Linv = np.linalg.inv(np.linalg.cholesky(H))
    eq = lba == uba
    cqp = CertifiedQP()
    u, _ = cqp._eqp(Linv, H, g, A, lo, hi, ws, Linv @ g)
    residual = CertifiedQP._ws_residual(np.r_[u, A @ u], lo, hi, ws)
    assert residual > 10 * cqp.ws_tol  # the refinement did not converge
    assert cqp._try(Linv, H, g, A, lo, hi, eq, ws, "guess") is None
    without = CertifiedQP(ws_tol=np.inf)._try(Linv, H, g, A, lo, hi, eq, ws, "guess")
    assert without is not None and np.abs(without.u - u_star).max() > 0.1  # what the incomplete certificate let through
    assert cqp.solve(H, g, A, lba, uba, lbx, ubx, guess=ws).path != "guess"
