"""The linear MPC: closed loops on the kinematic model with the true and with the nominal radii."""

import numpy as np

from ftc_mj.control import LinearMPC
from ftc_mj.wiring.control import build_controller
from tests.control.common import NOMINAL, OFFSET_POSE, cfg_with, check_bounds, left_step
from tests.support.kinsim import simulate


def test_lmpc_tracks_and_fault(built, circle) -> None:
    cfg = cfg_with(kind="lmpc")
    ref = circle
    ctl = built(build_controller, cfg, ref)
    assert isinstance(ctl, LinearMPC)
    res = simulate(ctl, ref, 10.0, OFFSET_POSE)
    st = res.solve_times * 1e3
    print(f"\n[ctl] lmpc {ctl.qpsol}: 5 m offset, max|e| 3-10 s {res.max_abs_error(3.0, 10.0):.2e} m; "
          f"solve median {np.median(st):.2f} ms p95 {np.percentile(st, 95):.2f} ms")
    assert res.max_abs_error(3.0, 10.0) < 0.5
    assert all(o.success and not o.fallback for o in res.outputs)
    check_bounds(res)
    # 50 % left fault: with the true radii, and with nominal radii
    ctl = built(build_controller, cfg, ref)
    res_t = simulate(ctl, ref, 25.0, (0.0, 0.0, 0.0), true_radii=left_step)
    ctl2 = built(build_controller, cfg, ref, tag="nominal radii")
    res_n = simulate(ctl2, ref, 25.0, (0.0, 0.0, 0.0), true_radii=left_step, model_radii=lambda t: NOMINAL)
    print(f"[ctl] lmpc after 50% left step at 10 s: true radii max|e| 10-25 s {res_t.max_abs_error(10, 25):.2e} m; "
          f"nominal radii RMS 15-25 s {res_n.rms_error(15, 25):.2f} m (max {res_n.max_abs_error(10, 25):.2f} m); "
          f"failures {ctl.failures}/{ctl2.failures}")
    assert res_t.max_abs_error(10, 25) < 0.5
    assert ctl.failures == 0 and ctl2.failures == 0
    check_bounds(res_t)
    check_bounds(res_n)
