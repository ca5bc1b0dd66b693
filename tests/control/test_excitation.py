"""The yaw-rate dither: it changes the model's yaw rate by exactly δψ̇ and not its speed."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from ftc_mj.control.excitation import dither_wheel_rates, yaw_dither
from ftc_mj.model.kinematics import body_rates


@given(wR=st.floats(-10, 10), wL=st.floats(-10, 10), rR=st.floats(0.1, 3.0), rL=st.floats(0.1, 3.0),
       dpsi=st.floats(-0.5, 0.5))
def test_dither_adds_yaw_rate_at_constant_speed(wR: float, wL: float, rR: float, rL: float, dpsi: float) -> None:
    b = 1.0
    out = dither_wheel_rates(np.array([wR, wL]), dpsi, np.array([rR, rL]), b, omega_max=1e6)
    v0, r0 = body_rates(rR, rL, wR, wL, b)
    v1, r1 = body_rates(rR, rL, out[0], out[1], b)
    assert abs(v1 - v0) < 1e-9 and abs((r1 - r0) - dpsi) < 1e-9


def test_dither_is_clipped_and_periodic() -> None:
    out = dither_wheel_rates(np.array([17.0, 17.0]), 1.0, np.array([0.1, 0.1]), 1.0, omega_max=17.45)
    assert np.all(np.abs(out) <= 17.45)
    assert yaw_dither(0.0, 0.05, 2.0) == 0.0 and abs(yaw_dither(0.5, 0.05, 2.0) - 0.05) < 1e-15
