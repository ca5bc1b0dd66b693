"""The RTI's compiled kernels (:mod:`ftc_mj.control.kernels`) against their numpy reference
(``tests/support/numpy_rti.py``, the package's maths before it was compiled), on the QPs of closed loops that
track and that saturate the wheels; and the multi-stage QP's structured factor as a factor of its Hessian.

Agreement is to round-off: BLAS and the kernels' loops sum in different orders, and ``K diag(a) K`` is
multiplied in another association than the reference's ``K (diag(a) K diag(b))``."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.control import NMPC
from ftc_mj.control.certified_qp import CertifiedQP
from ftc_mj.control.kernels import arrow_inverse_factor, tri_inv
from ftc_mj.control.robust import RobustNMPC
from tests.control.common import problem
from tests.support.kinsim import simulate
from tests.support.numpy_rti import NumpyCertifiedQP, NumpyCondensedQP, NumpyMultiStageQP, recorded_calls

FOUR = [(1.0, 1.0), (0.5, 1.0), (1.0, 0.5), (0.5, 0.5)]
LOOPS = {  # (start pose, true radii, model radii told the controller)
    "tracking": ((0.0, -5.0, 0.0), lambda t: (2.0, 1.0) if t >= 1.0 else (2.0, 2.0), None),
    "saturated": ((0.0, 0.0, 0.0), lambda t: (1.0, 2.0), lambda t: (2.0, 1.0)),
}


@pytest.fixture(scope="module", params=sorted(LOOPS))
def nominal_loop(request, circle):
    """An RTI NMPC with the first-step bound and penalty, its builds' arguments and its QPs over 4 s of a loop."""
    pose, true_r, model_r = LOOPS[request.param]
    spec = problem(rate_penalty=1.0, rate_penalty_first_step=True, max_lateral_accel=3.0)
    ctl = NMPC(spec, circle, solver="rti-daqp", time_budget=None, cold_time_budget=None, max_iter=300)
    qp = ctl._qp
    with qp.recording() as qps:
        builds = recorded_calls(qp, "build", lambda: simulate(ctl, circle, 4.0, pose, true_radii=true_r,
                                                         model_radii=model_r))
    assert len(builds) == len(qps) > 30
    return request.param, ctl, builds, qps


def test_condensing_and_cost_equal_the_numpy_reference(nominal_loop) -> None:
    """``H, g, E, e, G, hc`` of every RTI step equal the reference's to round-off (relative to the size of
    each output; for ``e = c(0) + A(0) x0 − hD0·hc``, a difference of terms ~1e4 that leaves ~1e-3, to the size
    of those terms), and the first-step penalty entered (``u_prev`` given in every build after the first)."""
    _, ctl, builds, _ = nominal_loop
    ref = NumpyCondensedQP(ctl.col, "daqp")
    hD0 = np.abs(ctl._qp.elim.hD0).sum()
    worst = 0.0
    for args in builds:
        out, expect = ctl._qp.build(*args), ref.build(*args)
        scales = [1.0 + np.abs(b).max() for b in expect]
        scales[3] = 1.0 + np.abs(expect[5]).max() * hD0
        for a, b, scale in zip(out, expect, scales, strict=True):
            assert a.shape == b.shape
            worst = max(worst, float(np.abs(a - b).max() / scale))
    assert sum(a[5] is not None for a in builds) >= len(builds) - 1
    print(f"\n[rti] condensing and cost, compiled vs numpy: {len(builds)} builds, max rel diff {worst:.1e}")
    assert worst < 1e-13


def test_certified_kernel_equals_the_numpy_reference(nominal_loop) -> None:
    """The compiled working-set solve and certificate decide every recorded QP as the numpy reference does
    (same verdict, same path: guess chained as in the loop, else PIQP's active set) with the same solution to
    round-off; the tracking loop is decided by the guessed working set, the saturated one mostly by PIQP."""
    name, ctl, _, qps = nominal_loop
    qp, ref = ctl._qp, NumpyCertifiedQP()
    ws_c = ws_r = None
    paths: dict[str, int] = {}
    worst = 0.0
    for H, g, E, e, Lv, ll, lu, Lo, lbx, ubx in qps:
        A, lba, uba = qp._rows(E, e, Lv, ll, lu, Lo)
        rc = qp._cqp.solve(H, g, A, lba, uba, lbx, ubx, ws_c)
        rr = ref.solve(H, g, A, lba, uba, lbx, ubx, ws_r)
        assert (rc.status, rc.path) == (rr.status, rr.path)
        paths[rc.path] = paths.get(rc.path, 0) + 1
        ws_c, ws_r = rc.working_set, rr.working_set
        if rc.status == "optimal":
            assert np.array_equal(rc.working_set, rr.working_set)
            worst = max(worst, float(np.abs(rc.u - rr.u).max()))
            np.testing.assert_allclose(rc.lam_x, rr.lam_x, atol=1e-6 * (1 + np.abs(rr.lam_x).max()))
    print(f"\n[rti] certified QP ({name}), compiled vs numpy: {paths}, max |du| {worst:.1e} rad/s")
    assert paths.get("guess" if name == "tracking" else "ipm", 0) >= 0.5 * len(qps)
    assert worst < 1e-7


@pytest.fixture(scope="module")
def multistage(circle):
    """A 4-scenario RTI robust NMPC and the arguments of its multi-stage QP's RTI steps (those of its
    assemblies too) over 3 s of a loop that loses half the left wheel at 1 s."""
    spec = problem(rate_penalty=1.0, rate_penalty_first_step=True)
    ctl = RobustNMPC(spec, circle, FOUR, solver="rti-daqp", time_budget=None, cold_time_budget=None)
    calls = recorded_calls(ctl._stage_qp, "solve", lambda: simulate(
        ctl, circle, 3.0, (0.0, -5.0, 0.0), true_radii=LOOPS["tracking"][1], model_radii=lambda t: (2.0, 2.0)))
    assert len(calls) > 20
    return ctl, calls


def test_multistage_assembly_equals_the_numpy_reference(multistage) -> None:
    """Every output of the multi-stage QP's assembly equals the reference's to round-off, the pruned
    scenario's relaxed rows included."""
    ctl, calls = multistage
    sq = ctl._stage_qp
    ref = NumpyMultiStageQP(NumpyCondensedQP(ctl.col, "daqp"), sq.S, sq.k)
    pruned = calls[-1][:5] + (np.array([0.7, np.nan, 0.3, np.nan]),) + calls[-1][6:]
    for args in [*calls, pruned]:
        for a, b in zip(sq.assemble(*args), ref.assemble(*args), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-11 * (1.0 + np.abs(b).max()))


def test_arrow_factor_is_an_inverse_factor_of_the_multistage_hessian(multistage) -> None:
    """``F`` from :func:`arrow_inverse_factor` satisfies ``F H Fᵀ = I`` on the assembled multi-stage Hessians
    (so ``H = F⁻¹ F⁻ᵀ``, which is all the range-space solve needs) and declines a Hessian that is not
    positive definite; :func:`tri_inv` inverts a lower triangular matrix."""
    ctl, calls = multistage
    sq = ctl._stage_qp
    for args in calls[::5]:
        H = sq.assemble(*args)[0]
        F = np.empty_like(H)
        assert arrow_inverse_factor(H, 2 * sq.k, 2 * (sq.N - sq.k), F)
        np.testing.assert_allclose(F @ H @ F.T, np.eye(H.shape[0]), atol=1e-8)
        assert np.all(F[2 * sq.k:, :2 * sq.k] == 0.0)  # the arrow: no fill
    H[-1, -1] = -1.0
    assert not arrow_inverse_factor(H, 2 * sq.k, 2 * (sq.N - sq.k), F)
    L = np.tril(np.random.default_rng(1).uniform(0.5, 2.0, (7, 7)))
    np.testing.assert_allclose(tri_inv(L) @ L, np.eye(7), atol=1e-12)
    H = L @ L.T  # every input shared (a robust horizon of all nodes): no scenario block, the plain Cholesky
    F = np.empty_like(H)
    assert arrow_inverse_factor(H, 7, 0, F)
    np.testing.assert_allclose(F @ H @ F.T, np.eye(7), atol=1e-12)


def test_multistage_steps_equal_the_numpy_reference(multistage) -> None:
    """Replayed in order (each with its own working-set guesses), the compiled multi-stage QP (compiled
    assembly, arrow factor, compiled certificate) and the numpy reference (dense Cholesky factor) reach the
    same verdicts, by the same paths, with the same plans to round-off."""
    ctl, calls = multistage
    sq = ctl._stage_qp
    ref = NumpyMultiStageQP(NumpyCondensedQP(ctl.col, "daqp"), sq.S, sq.k)
    sq.reset()
    sq.path_counts.clear()
    worst = 0.0
    for args in calls:
        a, b = sq.solve(*args), ref.solve(*args)
        assert a[:2] == b[:2]
        if a[0]:
            worst = max(worst, float(np.abs(a[3] - b[3]).max()))
    counts = dict(sq.path_counts)
    assert counts == dict(ref.path_counts)
    print(f"\n[rti] multi-stage QP, compiled vs numpy: {counts}, max |dU| {worst:.1e} rad/s")
    assert worst < 1e-7


@pytest.mark.parametrize("m", [0, 2])
def test_certified_kernel_on_bound_only_and_empty_working_sets(m: int) -> None:
    """Working sets of bounds only (no rows active, or no rows at all) and the empty one: the compiled path
    certifies the same optimum as the numpy reference, and its own working set is accepted as the guess."""
    rng = np.random.default_rng(0)
    n = 6
    M = rng.standard_normal((n, n))
    H, g = M @ M.T + np.eye(n), 10.0 * rng.standard_normal(n)
    A, lba, uba = rng.standard_normal((m, n)), np.full(m, -100.0), np.full(m, 100.0)
    box = np.ones(n)
    got, want = (cls().solve(H, g, A, lba, uba, -box, box) for cls in (CertifiedQP, NumpyCertifiedQP))
    assert got.status == want.status == "optimal"
    assert np.count_nonzero(got.working_set[:n]) >= 2 and not np.any(got.working_set[n:])
    np.testing.assert_allclose(got.u, want.u, atol=1e-12)
    again = CertifiedQP().solve(H, g, A, lba, uba, -box, box, guess=got.working_set)
    assert again.path == "guess"
    free = CertifiedQP().solve(H, 0.01 * g, A, lba, uba, -1e3 * box, 1e3 * box, guess=np.zeros(n + m, np.int8))
    assert free.path == "guess"
    np.testing.assert_allclose(H @ free.u + 0.01 * g, 0.0, atol=1e-10)
