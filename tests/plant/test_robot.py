"""The MuJoCo truth plant against the kinematic model, punctures, variants, flags and failure handling.

Reference figures (suspended variant, measured while writing these tests; position error of the plant against the
kinematic model integrated with the truth radii and the measured wheel rates at 1 kHz, over 10 s):
no fault 2 m/s 0.02 %; 50 % left step puncture 1.95 %; ramp 2 -> 0.1 m in 10 s 0.41 %; 10 m/s on the 50 m circle
0.30 %. Rigid variant, 50 % puncture: roll 30.2 deg.
"""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from ftc_mj.config import RunConfig, validate_config
from ftc_mj.errors import BadInput
from ftc_mj.model.kinematics import inverse_rates, pose_rates
from ftc_mj.plant import (
    LARGE_ROLL,
    LIFTOFF,
    NAN,
    PHYSICS_WARNING,
    SCRAPE,
    TIPPED,
    Plant,
    Truth,
    flag_names,
)
from ftc_mj.wiring.plant import build_plant, plant_from_settings
from tests.plant.helpers import make_cfg, mujoco_plant

B = 1.0
R0 = 2.0


def drive_and_compare(
    cfg: RunConfig, V: float, yaw_rate: float, T: float = 10.0, ramp_acc: float = 2.0
) -> tuple[float, float, Truth, int]:
    """Ramp up to (V, yaw_rate) from rest at ``ramp_acc`` (m/s^2) with the kinematic inverse rates, then compare the
    plant over ``T`` s with the kinematic model fed the truth radii and the measured wheel rates (trapezoidal rule at
    the 1 kHz physics rate). Returns (position error m, distance m, final truth, OR of flags during the test)."""
    p = mujoco_plant(cfg)
    wR, wL = inverse_rates(V, yaw_rate, R0, R0, B)
    T_ramp = V / ramp_acc
    while p.time < T_ramp - 1e-9:
        s = min(1.0, (p.time + p.dt) / T_ramp)
        p.set_command(s * wR, s * wL)
        p.advance(1)
    p.set_command(wR, wL)
    tr = p.truth()
    x = np.array([tr.x, tr.y, tr.psi])
    dist = 0.0
    flags = 0
    dt = p.dt
    t_end = p.time + T

    def f(pose: np.ndarray, t: Truth) -> np.ndarray:
        return np.array(pose_rates(pose[2], t.R_R, t.R_L, t.omega_R, t.omega_L, B))

    while p.time < t_end - 1e-9:
        prev = tr
        p.advance(1)
        tr = p.truth()
        k1 = f(x, prev)
        k2 = f(x + dt * k1, tr)
        x = x + 0.5 * dt * (k1 + k2)
        dist += abs(tr.v) * dt
        flags |= tr.flags
    err = math.hypot(tr.x - x[0], tr.y - x[1])
    return err, dist, tr, flags


# ------------------------------------------------------------------------------------- accuracy vs kinematic model
def test_no_fault_straight_matches_kinematics() -> None:
    err, dist, tr, flags = drive_and_compare(make_cfg(), V=2.0, yaw_rate=0.0)
    assert dist == pytest.approx(20.0, rel=0.02)
    assert err / dist < 0.01, f"{err:.3f} m over {dist:.1f} m"
    assert flags == 0, flag_names(flags)
    assert abs(tr.y) < 1e-3 and abs(tr.psi) < 1e-4


def test_step_puncture_matches_kinematics_within_5_percent() -> None:
    cfg = make_cfg()
    cfg.faults.left = [(3.0, 2.0), (3.0, 1.0)]  # 50 % step, 2 s into the comparison window
    err, dist, tr, _ = drive_and_compare(cfg, V=2.0, yaw_rate=0.0)
    assert tr.R_L == 1.0
    assert err / dist < 0.05, f"{err:.3f} m over {dist:.1f} m"
    assert abs(tr.roll) < math.radians(2.0)  # the levelling suspension keeps the chassis level


def test_ramp_puncture_matches_kinematics_within_5_percent() -> None:
    cfg = make_cfg()
    cfg.faults.left = [(1.0, 2.0), (11.0, 0.1)]  # scenario-4 shape (2 m -> 0.1 m), scaled to fit the 10 s window
    err, dist, tr, _ = drive_and_compare(cfg, V=2.0, yaw_rate=0.0)
    assert tr.R_L == pytest.approx(0.1, abs=1e-3)
    assert err / dist < 0.05, f"{err:.3f} m over {dist:.1f} m"


def test_circle_10ms_matches_kinematics() -> None:
    err, dist, tr, flags = drive_and_compare(make_cfg(), V=10.0, yaw_rate=10.0 / 50.0)
    assert dist == pytest.approx(100.0, rel=0.02)
    assert err / dist < 0.01, f"{err:.3f} m over {dist:.1f} m"
    assert not flags & (LIFTOFF | TIPPED | SCRAPE | LARGE_ROLL), flag_names(flags)
    assert abs(tr.roll) < math.radians(3.0)


# ------------------------------------------------------------------------------------- punctures and re-inflation
def test_hub_settles_to_new_radius_and_reinflates() -> None:
    cfg = make_cfg()
    cfg.faults.left = [(0.5, 2.0), (0.5, 1.0), (2.5, 1.0), (2.5, 2.0)]  # deflate, then re-inflate (grow) at once
    cfg.faults.right = [(0.5, 2.0), (1.5, 0.5)]  # ramp down
    p = mujoco_plant(cfg)
    p.set_command(1.0, 1.0)
    p.advance(2000)
    hR, hL = p.hub_heights()
    assert hL == pytest.approx(1.0, rel=0.02)
    assert hR == pytest.approx(0.5, rel=0.02)
    tr = p.truth()
    assert tr.contact_R and tr.contact_L
    assert tr.z_chassis == pytest.approx(R0, abs=0.02)
    p.advance(1500)
    hR, hL = p.hub_heights()
    assert hL == pytest.approx(2.0, rel=0.02)
    tr = p.truth()
    assert tr.R_L == 2.0 and tr.contact_L and not tr.flags & (TIPPED | SCRAPE)


def test_manual_radius_change_grow_back(default_plant: Plant) -> None:
    p = default_plant
    p.set_wheel_radius("left", 1.2)
    p.advance(500)
    assert p.hub_heights()[1] == pytest.approx(1.2, rel=0.02)
    p.set_wheel_radius("L", 2.0)
    p.advance(500)
    assert p.hub_heights()[1] == pytest.approx(2.0, rel=0.02)
    assert p.model.geom("wheel_left_visual").size[0] == pytest.approx(2.0)
    with pytest.raises(ValueError):
        p.set_wheel_radius("middle", 1.0)
    with pytest.raises(ValueError):
        p.set_wheel_radius("right", -1.0)


def test_never_falls_through_floor_at_small_radius() -> None:
    cfg = make_cfg()
    cfg.faults.left = [(0.2, 2.0), (0.2, 0.1)]
    cfg.faults.right = [(0.2, 2.0), (2.0, 0.1)]
    p = mujoco_plant(cfg)
    p.set_command(2.0, 2.0)
    lowest = math.inf
    for _ in range(400):
        p.advance(10)
        lowest = min(lowest, *p.hub_heights())
    tr = p.truth()
    assert lowest > 0.1 * 0.95  # sphere centre never sinks below its radius (5 mm allowance for soft contact)
    assert p.hub_heights()[0] == pytest.approx(0.1, rel=0.02)
    assert tr.contact_R and tr.contact_L
    assert not tr.flags & (SCRAPE | TIPPED | NAN)


def test_rigid_variant_rolls_under_puncture() -> None:
    """Hubs welded to the chassis: the punctured side drops. Geometric roll of the axle line: between
    atan((R_R - R_L) / 2b) = 26.6 deg (contacts keep their 2b horizontal spacing) and asin((R_R - R_L) / 2b) = 30 deg
    (sphere contacts stay under the hubs, which are 2b apart along the tilted axle; what MuJoCo does). Measured 30.2
    deg (the chassis also pitches ~6 deg onto the caster, which mixes into the ZYX roll angle)."""
    cfg = make_cfg(variant="rigid")
    cfg.faults.left = [(0.5, 2.0), (0.5, 1.0)]
    p = mujoco_plant(cfg)
    assert p.model.nq == 9  # the slides are gone
    p.advance(3000)
    tr = p.truth()
    roll_deg = math.degrees(abs(tr.roll))
    assert 25.0 < roll_deg < 32.0, roll_deg
    assert tr.roll < 0  # left (+y) side down
    assert tr.flags & LARGE_ROLL and not tr.flags & TIPPED
    assert tr.contact_R and tr.contact_L


def test_suspended_stays_level_under_puncture() -> None:
    cfg = make_cfg()
    cfg.faults.left = [(0.5, 2.0), (0.5, 1.0)]
    p = mujoco_plant(cfg)
    p.advance(3000)
    tr = p.truth()
    assert abs(tr.roll) < math.radians(0.5) and abs(tr.pitch) < math.radians(0.5)
    assert tr.flags == 0, flag_names(tr.flags)


def test_pitch_stable_under_full_torque_steps(default_plant: Plant) -> None:
    """Step commands to full rate forward, to zero and to full rate backward: the motor reaction (2 x 1500 N m on
    2 m wheels) never lifts the caster or swings the chassis over the axle."""
    p = default_plant
    max_pitch = 0.0
    flags = 0
    for cmd in ((p.omega_max, p.omega_max), (0.0, 0.0), (-p.omega_max, -p.omega_max), (0.0, 0.0)):
        p.set_command(*cmd)
        for _ in range(300):
            p.advance(10)
            tr = p.truth()
            max_pitch = max(max_pitch, abs(tr.pitch))
            flags |= tr.flags
    assert max_pitch < math.radians(3.0)
    assert not flags & (TIPPED | LARGE_ROLL | SCRAPE | LIFTOFF), flag_names(flags)


# ------------------------------------------------------------------------------------- interface and truth
def test_reset_puts_initial_pose_and_radii() -> None:
    cfg = make_cfg(initial_pose=(3.0, -4.0, 3.0))
    cfg.faults.right = [(0.0, 1.5)]
    p = mujoco_plant(cfg)
    tr = p.truth()
    assert (tr.x, tr.y, tr.psi) == pytest.approx((3.0, -4.0, 3.0), abs=1e-9)
    assert tr.R_R == 1.5 and tr.R_L == 2.0
    assert p.hub_heights()[0] == pytest.approx(1.5, abs=1e-9)
    p.set_command(2.0, 2.0)
    p.advance(500)
    p.reset()
    tr = p.truth()
    assert tr.t == 0.0 and tr.x == pytest.approx(3.0) and tr.v == 0.0
    assert p.command == (0.0, 0.0)


def test_command_clipping(default_plant: Plant) -> None:
    p = default_plant
    p.set_command(100.0, -100.0)
    lim = p.omega_max
    assert p.command == pytest.approx((lim, -lim))
    p.set_command(float("nan"), 1.0)
    assert p.command == (0.0, 1.0)


def test_heading_is_unwrapped_and_rates_consistent(default_plant: Plant) -> None:
    p = default_plant
    p.set_command(1.0, -1.0)  # spin in place at 2 rad/s
    psis = []
    for _ in range(500):
        p.advance(10)
        psis.append(p.truth().psi)
    tr = p.truth()
    assert psis[-1] > 2 * math.pi  # more than a full turn, continuous
    assert np.all(np.diff(psis) > 0)
    assert tr.yaw_rate == pytest.approx((tr.R_R * tr.omega_R - tr.R_L * tr.omega_L) / (2 * B), rel=0.02)
    assert tr.v == pytest.approx(0.5 * (tr.R_R * tr.omega_R + tr.R_L * tr.omega_L), abs=0.02)


def test_truth_speed_and_slip_in_steady_rolling(default_plant: Plant) -> None:
    p = default_plant
    p.set_command(2.5, 2.5)
    p.advance(4000)
    tr = p.truth()
    assert tr.v == pytest.approx(5.0, rel=0.01)
    assert abs(tr.slip_R) < 0.01 and abs(tr.slip_L) < 0.01
    assert tr.v == pytest.approx(0.5 * (tr.R_R * tr.omega_R + tr.R_L * tr.omega_L), rel=1e-3)


def test_bulk_and_single_steps_agree_exactly(default_plant: Plant) -> None:
    a, b = default_plant, mujoco_plant(make_cfg())
    for p in (a, b):
        p.set_command(3.0, 2.0)
    a.advance(250)
    for _ in range(250):
        b.advance(1)
    assert a.time == b.time
    np.testing.assert_array_equal(a.data.qpos, b.data.qpos)
    np.testing.assert_array_equal(a.data.qvel, b.data.qvel)


def test_reset_plant_equals_a_new_one(default_plant: Plant) -> None:
    """What the shared fixture relies on: after a run that punctured, froze and re-sized a wheel, ``reset``
    gives the state, radii, geometry and truth of a newly built plant, and the same trajectory."""
    p = default_plant
    p.set_wheel_radius("left", 1.0)
    p.set_command(2.0, 1.0)
    p.advance(300)
    p.data.qvel[0] = np.nan
    p.advance(10)
    assert p.frozen
    p.reset()
    new = mujoco_plant(make_cfg())
    for q in (p, new):
        q.set_command(2.0, 1.5)
        q.advance(200)
    np.testing.assert_array_equal(p.data.qpos, new.data.qpos)
    np.testing.assert_array_equal(p.data.qvel, new.data.qvel)
    np.testing.assert_array_equal(p.model.geom_size, new.model.geom_size)
    np.testing.assert_array_equal(p.model.qpos_spring, new.model.qpos_spring)
    assert p.truth() == new.truth()


def test_nan_is_flagged_not_raised(default_plant: Plant) -> None:
    p = default_plant
    p.set_command(1.0, 1.0)
    p.advance(100)
    good = p.truth()
    p.data.qvel[0] = np.nan
    p.advance(10)
    tr = p.truth()
    assert p.frozen
    assert tr.flags & NAN and tr.flags & PHYSICS_WARNING
    assert tr.t == pytest.approx(0.11)
    assert all(math.isfinite(v) for v in (tr.x, tr.y, tr.psi, tr.v))
    assert tr.x == pytest.approx(good.x, abs=1e-9)
    p.advance(10)
    assert p.time == pytest.approx(0.12) and p.truth().flags & NAN
    assert "NAN" in p.describe_flags(tr.flags) and p.describe_flags(0) == "none"


# ------------------------------------------------------------------------------------- determinism and inputs
def test_determinism_same_config_same_truth() -> None:
    def run() -> list[tuple]:
        cfg = make_cfg()
        cfg.faults.left = [(0.3, 2.0), (0.3, 1.0)]
        p = mujoco_plant(cfg)
        out = []
        for k in range(100):
            p.set_command(1.0 + 0.01 * k, 1.0)
            p.advance(10)
            tr = p.truth()
            out.append(tuple(tr.as_dict().values()))
        return out

    assert run() == run()


def test_bad_model_file_names_field(tmp_path: Path) -> None:
    with pytest.raises(BadInput, match=r"^plant\.model_file"):
        validate_config({"plant": {"model_file": str(tmp_path / "nope.xml")}})
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body name='x'></worldbody></mujoco>")
    cfg = validate_config({"plant": {"model_file": str(bad)}})
    with pytest.raises(BadInput, match=r"^plant\.model_file") as ei:
        mujoco_plant(cfg)
    assert "\n" not in str(ei.value)
    incomplete = tmp_path / "incomplete.xml"
    incomplete.write_text("<mujoco><worldbody><geom name='floor' type='plane' size='1 1 1'/></worldbody></mujoco>")
    cfg = validate_config({"plant": {"model_file": str(incomplete)}})
    with pytest.raises(BadInput, match=r"^plant\.model_file.*chassis"):
        mujoco_plant(cfg)


def test_builder_applies_static_edits() -> None:
    cfg = validate_config(
        {
            "plant": {
                "wheel_radius": 1.5,
                "half_track": 0.8,
                "chassis_mass": 300.0,
                "wheel_mass": 20.0,
                "tyre_friction": 0.7,
                "actuator_gain": 5000.0,
                "timestep": 0.002,
                "caster_friction": 0.1,
            },
            "estimator": {"rate": 100.0},
        }
    )
    p = mujoco_plant(cfg)
    m = p.model
    assert m.opt.timestep == 0.002
    assert m.geom("wheel_left").size[0] == 1.5 and m.geom("wheel_right_visual").size[0] == 1.5
    assert m.body("hub_left").pos[1] == pytest.approx(0.8) and m.body("hub_right").pos[1] == pytest.approx(-0.8)
    assert m.body("chassis").mass[0] == pytest.approx(300.0)
    assert m.body("tyre_left").mass[0] == pytest.approx(20.0)
    assert m.geom("wheel_left").friction[0] == pytest.approx(0.7)
    assert m.geom("caster").friction[0] == pytest.approx(0.1) and m.geom("caster").condim[0] == 3
    assert m.actuator("act_left").gainprm[0] == 5000.0 and m.actuator("act_left").biasprm[2] == -5000.0
    p.set_command(1.0, 1.0)
    p.advance(1000)
    tr = p.truth()
    assert tr.z_chassis == pytest.approx(1.5, abs=0.02)
    assert p.hub_heights()[0] == pytest.approx(1.5, rel=0.01)
    assert tr.v == pytest.approx(1.5, rel=0.02)
    assert tr.flags == 0, flag_names(tr.flags)


def test_contacts_and_masses_plausible(default_plant: Plant) -> None:
    """Drive wheels carry most of the weight; the caster only balances."""
    p = default_plant
    p.advance(1000)
    m, d = p.model, p.data
    mujoco.mj_forward(m, d)
    normal = {}
    f6 = np.zeros(6)
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, f6)
        g = {m.geom(int(d.contact.geom1[i])).name, m.geom(int(d.contact.geom2[i])).name} - {"floor"}
        normal[g.pop()] = f6[0]
    total = sum(normal.values())
    weight = float(m.body_subtreemass[m.body("chassis").id]) * 9.81
    assert total == pytest.approx(weight, rel=0.01)
    assert (normal["wheel_right"] + normal["wheel_left"]) / total > 0.7  # 77 % by design
    assert normal["caster"] > 0.05 * total


def test_build_plant_factory() -> None:
    assert isinstance(build_plant(make_cfg()), Plant)
    assert build_plant(make_cfg(kind="kinematic")).kind == "kinematic"


def test_plant_from_its_own_sections_equals_the_run_configs() -> None:
    """``plant_from_settings`` validates the three sections on their own (no run config) and gives the plant
    a run with them gets; a bad field is named in one line."""
    cfg = make_cfg(variant="rigid")
    cfg.faults.left = [(0.1, 2.0), (0.1, 1.5)]
    a = plant_from_settings({"variant": "rigid"}, None, {"left": [[0.1, 2.0], [0.1, 1.5]]})
    b = build_plant(cfg)
    for p in (a, b):
        p.set_command(1.0, 1.0)
        p.advance(300)
    assert a.truth() == b.truth()
    with pytest.raises(BadInput, match=r"^faults\.left"):
        plant_from_settings(None, None, {"left": [[1.0, -1.0]]})
    with pytest.raises(BadInput, match=r"^robot\.omega_max"):
        plant_from_settings(None, {"omega_max": -1.0})
