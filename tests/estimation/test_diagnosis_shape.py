"""A sensor fault's shape from its integrated residual (:mod:`ftc_mj.estimation.diagnosis.shape`): a bias is a
ramp of the integral, a drift a parabola; constructed residuals with the noise the fit assumes (white fix noise
plus the sensor's integrated noise) are told apart, with the size and the onset of the truth."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.estimation.diagnosis.shape import shape_fit

R, Q = 0.03**2, 1.0e-5  # a 0.03 rad heading fix, a gyro of 0.03 rad/s sampled at 100 Hz: 9e-6 rad²/s
T = np.arange(2.0, 30.0, 0.1)  # the fixes at 10 Hz after the launch
STARTS = np.arange(4.0, 29.5, 0.1)


def residual(mode: str, size: float, onset: float, seed: int) -> np.ndarray:
    """The integrated residual of a ``mode`` fault of ``size`` from ``onset`` (s) with the fit's noise."""
    rng = np.random.default_rng(seed)
    x = np.clip(T - onset, 0.0, None)
    signal = size * x if mode == "bias" else 0.5 * size * x * x
    walk = np.cumsum(np.sqrt(Q * 0.1) * rng.standard_normal(T.size))  # the sensor noise integrated
    return signal + np.sqrt(R) * rng.standard_normal(T.size) + walk + 0.3


@pytest.mark.parametrize(("mode", "size"), [("bias", 0.02), ("bias", -0.1), ("drift", 0.002), ("drift", -0.01)])
def test_a_ramp_is_a_bias_and_a_parabola_a_drift_with_their_size_and_onset(mode: str, size: float) -> None:
    fit = shape_fit(T, residual(mode, size, 11.0, seed=1), R, Q, STARTS, margin=4.0)
    assert fit is not None
    assert fit.mode == mode
    assert abs(fit.size - size) < max(4.0 * fit.sigma, 0.1 * abs(size))
    assert abs(fit.onset - 11.0) < 1.5
    assert (fit.llr > 0) == (mode == "drift")


def test_a_bias_is_rarely_called_a_drift_at_the_margin() -> None:
    """Over 40 noise draws a bias of 0.03 rad/s is declared a drift at most twice (the margin of 4 nats: about
    2 % for a likelihood ratio of two free onsets)."""
    drifts = sum(shape_fit(T, residual("bias", 0.03, 12.0, seed=s), R, Q, STARTS, margin=4.0).mode == "drift"
                 for s in range(40))
    assert drifts <= 2


def test_too_few_samples_give_no_shape() -> None:
    assert shape_fit(T[:5], np.zeros(5), R, Q, STARTS) is None
    assert shape_fit(T, np.zeros(T.size), R, Q, np.array([])) is None
