"""The LGL transcription's numeric helpers: the shift of a plan to a later horizon and the projection of a
plan's first input into the first-step bound."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ftc_mj.control.transcription import Collocation
from tests.control.common import NOMINAL, OMEGA_MAX, problem

STEP = 20.0 * 0.1  # rad/s: omega_rate_max (rad/s²) x controller period (s)


def test_shift_exact_for_polynomials() -> None:
    col = Collocation(problem(nodes=12))
    t = col.times(0.0)
    X = np.stack([t**3, t**2, t], axis=1)
    U = np.stack([t**4, 1 + t], axis=1)
    Xn, Un = col.shift(0.0, X, U, 0.1, 1.0, np.array(NOMINAL))
    tn = col.times(0.1)
    inside = tn <= t[-1]
    np.testing.assert_allclose(Xn[inside, 0], tn[inside] ** 3, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(Un[inside, 0], tn[inside] ** 4, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(Un[~inside], U[-1][None, :].repeat((~inside).sum(), 0))


@settings(max_examples=60, deadline=None)
@given(u0=st.lists(st.floats(-12.0, 12.0), min_size=2, max_size=2),
       centre=st.lists(st.floats(-12.0, 12.0), min_size=2, max_size=2),
       slope=st.floats(-5.0, 5.0))
def test_project_first_moves_only_the_start_of_the_plan(u0: list[float], centre: list[float], slope: float) -> None:
    """The first input lands in the box; the correction is at most |δ| and fades at omega_rate_max, so it
    adds at most that to the plan's rate (checked between nodes) and is zero after |δ| / omega_rate_max."""
    col = Collocation(problem())
    dt = col.times(0.0)
    U = np.asarray(u0)[None, :] + slope * dt[:, None]
    U = np.clip(U, -OMEGA_MAX + 3.0, OMEGA_MAX - 3.0)  # away from ±omega_max, where the result is clipped
    U[0] = u0
    lo, hi = np.asarray(centre) - STEP, np.asarray(centre) + STEP
    V = col.project_first(U, lo, hi)
    assert np.all(V[0] >= lo) and np.all(V[0] <= hi)
    delta = np.clip(U[0], lo, hi) - U[0]
    corr = V - U
    assert np.all(np.abs(corr) <= np.abs(delta)[None, :] + 1e-12)
    assert np.all(np.abs(np.diff(corr, axis=0)) <= 20.0 * np.diff(dt)[:, None] + 1e-9)
    assert np.all(corr[dt[:, None].repeat(2, 1) > np.abs(delta)[None, :] / 20.0 + 1e-12] == 0.0)
    if np.all(delta == 0.0):
        assert V is U
