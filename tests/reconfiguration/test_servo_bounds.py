"""Bounds that follow a servo loss: what one servo's torque limit allows the shipped robot
(:func:`ftc_mj.plant.limits.servo_limits`, checked against the MJCF's masses and the servo's numbers), the
path-following problem's lateral and longitudinal bounds scaled by the weakest servo's effectiveness
(:func:`ftc_mj.control.pathfollow_spec.servo_limited`), and the controller that takes them from the
accommodation (:meth:`~ftc_mj.control.pathfollow.PathFollowingNMPC.set_actuator_effectiveness`) and finds the
speed the weakened servo can give by itself."""

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from ftc_mj.config import load_config
from ftc_mj.control.pathfollow import PathFollowingNMPC
from ftc_mj.control.pathfollow_spec import servo_limited
from ftc_mj.plant.builder import build_model
from ftc_mj.plant.limits import lateral_accel_limits, servo_limits
from ftc_mj.sim.cache import nominal_plant, robot_limits
from ftc_mj.wiring.control import build_reference
from tests.control.common import pf_spec, problem
from tests.support.kinsim import simulate


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    cfg = load_config("scenario2", {"controller.kind": "pf-nmpc"})
    return build_model(nominal_plant(cfg), cfg.robot)


def test_one_servo_limits_from_the_mjcf(model) -> None:
    """The yaw couple's tyre force ``M a x_G / (2 b)`` on a 2 m wheel needs the 1500 N m of one servo at
    ``a_s = 2 b τ_max / (M x_G R)`` — the same number as ``τ_max R / (b k_v c)`` from the yaw compliance —
    8.0 m/s² on the shipped robot (330 kg, centre of mass 0.568 m ahead of the axle); the wheel's half of
    ``M a_x`` plus its tyre's spin inertia needs it at ``τ_max / (M R / 2 + I / R)`` = 4.17 m/s²."""
    s = servo_limits(model)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    M = float(np.sum(model.body_mass))
    heading = data.xmat[model.body("chassis").id].reshape(3, 3)[:, 0]
    axle = data.xpos[model.body("chassis").id]
    x_G = float(model.body_mass @ ((data.xipos - axle) @ heading)) / M
    R, tau, b = 2.0, 1500.0, 1.0
    assert M == pytest.approx(330.0) and x_G == pytest.approx(0.568, abs=1e-3)
    assert float(model.actuator("act_left").forcerange[1]) == tau
    assert s.lateral == pytest.approx(2.0 * b * tau / (M * x_G * R), rel=1e-9)
    c = lateral_accel_limits(model).yaw_compliance
    assert s.lateral == pytest.approx(tau * R / (b * 1.0e4 * c), rel=1e-12) == pytest.approx(8.0)
    inertia = float(model.body_inertia[model.body("tyre_left").id][1])
    assert s.longitudinal == pytest.approx(tau / (0.5 * M * R + inertia / R)) == pytest.approx(4.1667, abs=1e-4)


def test_the_sim_layer_hands_them_over_and_the_kinematic_plant_has_none() -> None:
    cfg = load_config("scenario2", {"controller.kind": "pf-nmpc"})
    lim = robot_limits(cfg)
    assert lim.servo_lateral_accel == pytest.approx(8.0) and lim.servo_longitudinal_accel == pytest.approx(4.1667,
                                                                                                           abs=1e-4)
    kin = robot_limits(cfg.model_copy(update={"oracle": True, "plant": cfg.plant.model_copy(
        update={"kind": "kinematic"})}))
    assert kin.servo_lateral_accel is None and kin.servo_longitudinal_accel is None


def _spec(A: float = 3.5, lon: float = 3.0, a_s: float | None = 7.2, ax_s: float | None = 4.1667):
    """A path-following problem with the lateral bound ``A``, the longitudinal ``lon`` (m/s²) and the servo
    numbers of the shipped robot (``a_s`` already times the 0.9 margin)."""
    spec = pf_spec(problem(rate_penalty=1.0, max_lateral_accel=A, max_longitudinal_accel=lon))
    return dataclasses.replace(spec, servo_lateral_accel=a_s, servo_longitudinal_accel=ax_s)


@pytest.mark.parametrize("e", [1.0, 0.6, 0.3, 0.1])
def test_the_bounds_scale_with_the_weakest_servo(e: float) -> None:
    """At effectiveness ``e`` the servo's torque is ``e τ_max`` and the loads are the robot's: the lateral bound is
    ``min(A, e · 0.9 · 8.0)``, the longitudinal ``min(3, e · 4.17)``; a healthy servo leaves both as they were
    (the lift-off limit binds first), the other wheel's healthy servo does not help."""
    spec = _spec()
    out = servo_limited(spec, np.array([1.0, e]))
    assert out.problem.max_lateral_accel == pytest.approx(min(3.5, e * 7.2))
    assert out.problem.max_longitudinal_accel == pytest.approx(min(3.0, e * 4.1667))
    assert servo_limited(spec, np.array([e, 1.0])) == out
    assert dataclasses.replace(out, problem=spec.problem) == spec  # nothing else changes
    none = _spec(a_s=None, ax_s=None)  # no servo (the kinematic plant): unchanged
    assert servo_limited(none, np.array([1.0, e])) == none


def test_the_controller_takes_the_bounds_without_new_solvers_and_a_reset_forgets_them() -> None:
    """The bounds are bounds of the built NLP's rows (and read by the QP at every build): no new solvers; the
    NLP's rows carry the new numbers; a reset (a new run) goes back to the nominal problem."""
    spec = _spec()
    ctl = PathFollowingNMPC(spec, build_reference(load_config("scenario2")))
    nlp, qp = ctl._nlp, ctl.qp
    ctl.set_actuator_effectiveness(np.array([1.0, 0.3]))
    assert ctl._nlp is nlp and ctl.qp is qp and qp.spec is ctl.spec
    assert ctl.spec.problem.max_lateral_accel == pytest.approx(0.3 * 7.2)
    assert np.all(nlp._ubg[nlp._rows] == pytest.approx(0.3 * 7.2))
    assert np.all(nlp._ubg[nlp._lon_rows] == pytest.approx(0.3 * 4.1667))
    assert np.all(nlp._lbg[nlp._lon_rows] == pytest.approx(-0.3 * 4.1667))
    ctl.reset()
    assert ctl.spec == spec and np.all(nlp._ubg[nlp._rows] == 3.5) and np.all(nlp._ubg[nlp._lon_rows] == 3.0)


def test_the_speed_the_weakened_servo_can_give_is_found_by_the_controller() -> None:
    """Kinematic loop on the 50 m circle at a desired 10 m/s, the left servo declared at 15 % from the start:
    the lateral bound is 0.15 · 7.2 = 1.08 m/s² and the controller, told nothing of the speed, settles at
    ``√(1.08 · 50)`` = 7.35 m/s (within 0.5 % over the last 5 of 15 s), on the path within 5 cm (measured:
    7.347 m/s, 2.6 cm)."""
    reference = build_reference(load_config("scenario2"))
    ctl = PathFollowingNMPC(_spec(), reference)
    ctl.set_actuator_effectiveness(np.array([1.0, 0.15]))
    res = simulate(ctl, reference, 15.0, (0.0, 0.0, 0.0))
    V = 0.5 * 2.0 * (res.omega[:, 0] + res.omega[:, 1])
    late = res.t > 10.0
    expect = math.sqrt(0.15 * 7.2 * 50.0)
    print(f"\n[servo] speed at e = 0.15: {V[late].mean():.4f} m/s (expected {expect:.4f}), max|e| after 10 s "
          f"{res.max_abs_error(10.0):.2e} m")
    assert V[late].mean() == pytest.approx(expect, rel=5e-3)
    assert res.max_abs_error(10.0) < 0.05
