"""The payload (``plant.payload_mass``, ``plant.payload_offset``): absent, the model is the MJCF's bit for bit;
present, the robot at rest carries its weight where statics says — the caster takes ``m g x / x_c`` of it
(moment balance about the axle), the tyres the rest — and the lift-off limits include it."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from ftc_mj.config import load_config
from ftc_mj.plant import build_model
from ftc_mj.plant.builder import GRAVITY
from ftc_mj.plant.limits import lateral_accel_limits

MASS, X = 60.0, 1.0
"""Payload (kg) 1 m ahead of the axle midpoint (m)."""


def _model(mass: float) -> mujoco.MjModel:
    cfg = load_config("scenario1", {"plant.payload_mass": mass, "plant.payload_offset": [X, 0.0, -0.8]})
    return build_model(cfg.plant, cfg.robot)


def _rest_loads(m: mujoco.MjModel) -> dict[str, float]:
    """Normal contact force (N) on each tyre and the caster after 3 s at rest (servos holding zero rate)."""
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for _ in range(3000):
        mujoco.mj_step(m, d)
    out = {"wheel_right": 0.0, "wheel_left": 0.0, "caster": 0.0}
    f = np.zeros(6)
    for i in range(d.ncon):
        c = d.contact[i]
        names = {m.geom(int(c.geom1)).name, m.geom(int(c.geom2)).name} & set(out)
        mujoco.mj_contactForce(m, d, i, f)
        for n in names:
            out[n] += float(f[0])
    return out


def test_no_payload_is_the_mjcf_model():
    base = load_config("scenario1")
    a, b = build_model(base.plant, base.robot), _model(0.0)
    assert a.nbody == b.nbody and np.array_equal(a.body_mass, b.body_mass)
    assert np.array_equal(a.body_ipos, b.body_ipos)


def test_payload_weight_is_carried_as_statics_says():
    m0, m1 = _model(0.0), _model(MASS)
    assert m1.body_subtreemass[1] == pytest.approx(m0.body_subtreemass[1] + MASS)
    x_caster = float(m1.geom("caster").pos[0])
    l0, l1 = _rest_loads(m0), _rest_loads(m1)
    W = MASS * GRAVITY
    # moment balance about the axle: the caster takes W x / x_c, the two tyres share the rest (2 % for the
    # chassis' pitch on its struts and the contacts' softness)
    assert l1["caster"] - l0["caster"] == pytest.approx(W * X / x_caster, rel=0.02)
    for w in ("wheel_right", "wheel_left"):
        assert l1[w] - l0[w] == pytest.approx(0.5 * W * (1.0 - X / x_caster), rel=0.02)
    lim0, lim1 = lateral_accel_limits(m0), lateral_accel_limits(m1)
    assert lim1.wheel_load - lim0.wheel_load == pytest.approx(0.5 * W * (1.0 - X / x_caster), rel=1e-9)


def test_payload_keys_only_in_a_resolved_config_with_a_payload():
    """Without a payload the resolved config (and so every run id and study key) is what it was before the
    payload existed; with one it round-trips."""
    from ftc_mj.config import validate_config

    plain = load_config("scenario1").model_dump(mode="json")["plant"]
    assert "payload_mass" not in plain and "payload_offset" not in plain
    cfg = load_config("scenario1", {"plant.payload_mass": MASS, "plant.payload_offset": [X, 0.0, -0.8]})
    dumped = cfg.model_dump(mode="json")
    assert dumped["plant"]["payload_mass"] == MASS and validate_config(dumped) == cfg
