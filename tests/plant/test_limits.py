"""The robot's lift-off limit, braking trade-off and yaw compliance derived from the MJCF, checked against the
numbers read from the XML by hand and against the MuJoCo plant itself."""

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from ftc_mj.config import DEFAULT_MODEL_FILE, RunConfig
from ftc_mj.model.kinematics import inverse_rates
from ftc_mj.plant import LIFTOFF, Plant, build_model
from ftc_mj.plant.builder import GRAVITY
from ftc_mj.plant.limits import lateral_accel_limits
from ftc_mj.resources import model_path


@pytest.fixture(scope="module")
def limits():
    cfg = RunConfig()
    return lateral_accel_limits(build_model(cfg.plant, cfg.robot))


def _xml_numbers() -> dict[str, float]:
    """Masses, heights, half track, tyre radius, friction, axle inertia, caster x and servo gain as written in
    the built-in diffdrive.xml (names as in the file; the chassis frame sits at the nominal hub height)."""
    root = ET.parse(model_path(DEFAULT_MODEL_FILE)).getroot()
    body = {b.get("name"): b for b in root.iter("body")}
    geom = {g.get("name"): g for g in root.iter("geom")}
    z0 = float(body["chassis"].get("pos").split()[2])
    chassis = body["chassis"].find("inertial")
    return {
        "m_c": float(chassis.get("mass")), "h_c": z0 + float(chassis.get("pos").split()[2]),
        "m_hub": float(body["hub_left"].find("inertial").get("mass")),
        "m_tyre": float(body["tyre_left"].find("inertial").get("mass")),
        "I_axle": float(body["tyre_left"].find("inertial").get("diaginertia").split()[1]),
        "b": float(body["hub_left"].get("pos").split()[1]), "R": float(geom["wheel_left"].get("size")),
        "mu": float(geom["wheel_left"].get("friction").split()[0]), "z0": z0,
        "x_c": float(geom["caster"].get("pos").split()[0]),
        "kv": float(next(a for a in root.iter("velocity") if a.get("name") == "act_left").get("kv")),
    }


def test_limits_match_a_hand_derivation_from_the_xml(limits) -> None:
    """With the XML's numbers (and the builder's chassis centre of mass at x = (1 − 0.7) x_caster): static tyre
    load N0 = (M g − M g x_G / x_c)/2, load transfer k = (Σ m h + Σ I/R)/(2b), rollover N0/k, yaw compliance
    c = M x_G R² / (2 b² k_v); the traction limit solves the inner tyre's friction circle."""
    n = _xml_numbers()
    lam = RunConfig().plant.wheel_load_fraction
    M = n["m_c"] + 2 * (n["m_hub"] + n["m_tyre"])
    x_G = n["m_c"] * (1 - lam) * n["x_c"] / M
    N0 = 0.5 * M * GRAVITY * (1 - x_G / n["x_c"])
    k = (n["m_c"] * n["h_c"] + 2 * (n["m_hub"] + n["m_tyre"]) * n["z0"] + 2 * n["I_axle"] / n["R"]) / (2 * n["b"])
    assert limits.wheel_load == pytest.approx(N0, rel=1e-9)
    assert limits.load_transfer == pytest.approx(k, rel=1e-9)
    assert limits.rollover == pytest.approx(N0 / k, rel=1e-9)
    assert limits.yaw_compliance == pytest.approx(M * x_G * n["R"] ** 2 / (2 * n["b"] ** 2 * n["kv"]), rel=1e-9)
    a = limits.traction
    n_in = N0 - k * a
    demand = math.hypot(M * a * x_G / (2 * n["b"]), M * a * n_in / (2 * N0))
    assert demand == pytest.approx(n["mu"] * n_in, rel=1e-9)  # on the friction circle
    assert 0 < limits.traction < limits.rollover and limits.liftoff == limits.traction
    assert 0.5 < limits.braking_trade < 1.0  # braking loads the inner tyre (0.75 for this robot)
    print(f"\n[limits] traction {limits.traction:.3f} m/s², rollover {limits.rollover:.3f} m/s², braking trade "
          f"{limits.braking_trade:.3f}, yaw compliance {limits.yaw_compliance:.4f} s/m")


def test_plant_lifts_its_inner_wheel_near_the_derived_limit_and_turns_by_the_compliance(
        limits, default_plant: Plant) -> None:
    """Quasi-static ramp of the commanded lateral acceleration (0.1 m/s² per s) at 10 m/s on the MuJoCo plant:
    (1) the yaw rate lags the command by the derived compliance, psidot_cmd / psidot = 1 + c V, within 3 % (the
    servo's own dynamics and the tyres' creep are neglected in the derivation); (2) the inner wheel leaves the
    ground at an actual lateral acceleration within [1.0, 1.15] of the derived traction limit (measured 1.065:
    the derivation shares the lateral force in proportion to the loads and neglects the chassis roll)."""
    p = default_plant
    V, a_cmd = 10.0, 2.5
    p.set_motion(V, a_cmd / V)
    ratio, onset = [], None
    for k in range(6000):
        a_cmd = 2.5 + 0.1 * k * 0.01
        p.set_command(*inverse_rates(V, a_cmd / V, 2.0, 2.0, 1.0))
        p.advance(10)
        tr = p.truth()
        if 1000 <= k < 1100:  # settled, well below the limit
            ratio.append((a_cmd / V) / tr.yaw_rate)
        if tr.flags & LIFTOFF:
            onset = tr.v * tr.yaw_rate
            break
    assert np.mean(ratio) == pytest.approx(1 + limits.yaw_compliance * V, rel=0.03)
    assert onset is not None and 1.0 <= onset / limits.traction <= 1.15
    print(f"\n[limits] measured lift-off onset {onset:.3f} m/s² ({onset / limits.traction:.3f} × derived), "
          f"psidot_cmd/psidot {np.mean(ratio):.3f} vs 1 + cV = {1 + limits.yaw_compliance * V:.3f}")
