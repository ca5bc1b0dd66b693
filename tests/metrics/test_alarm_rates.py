"""The run-length maths of the detectors' calibration (:mod:`ftc_mj.metrics.alarm_rates`) against analytic answers:
the censored-exponential rate, its exact interval, and a CUSUM's run length on white Gaussian noise against
Siegmund's approximation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.estimation.calibration import siegmund_arl0
from ftc_mj.estimation.change import InnovationCUSUM
from ftc_mj.metrics.alarm_rates import censored_rate, run_lengths


def test_censored_rate_of_exponential_run_lengths_censored_by_the_run_end() -> None:
    """Exponential run lengths of mean 40 s watched in runs of 30 s: alarms / exposure recovers the rate 1/40
    (4000 runs: about 2100 alarms, standard error 2.2 %; tolerance 8 %), where the mean of the uncensored
    run lengths alone is far below 40 s."""
    rng = np.random.default_rng(0)
    x = rng.exponential(40.0, 4000)
    runs = [(min(v, 30.0), bool(v <= 30.0)) for v in x]
    r = censored_rate(runs)
    assert r.arl0 == pytest.approx(40.0, rel=0.08)
    assert r.lo < 1 / 40.0 < r.hi
    assert np.mean([v for v, a in runs if a]) < 20.0


def test_garwood_interval_of_no_alarm_and_of_one() -> None:
    """The exact Poisson interval: zero alarms in 1000 s bound the rate by 3.689/1000 (ARL0 ≥ 271 s); one
    alarm gives [0.0253, 5.572] / exposure."""
    r0 = censored_rate([(1000.0, False)])
    assert r0.alarms == 0 and r0.arl0 == math.inf and r0.hi * 1000.0 == pytest.approx(3.689, abs=1e-3)
    assert r0.arl0_interval[0] == pytest.approx(1000.0 / 3.689, rel=1e-3)
    r1 = censored_rate([(100.0, True), (900.0, False)])
    assert (r1.lo * 1000.0, r1.hi * 1000.0) == pytest.approx((0.0253, 5.572), abs=1e-3)


def test_run_lengths_restart_after_each_alarm_and_end_censored() -> None:
    """A detector restarted at 5 s and after its alarms at 7 s and 20 s, the run ending at 30 s."""
    assert run_lengths([3.0, 7.0, 20.0], 5.0, 30.0) == [(2.0, True), (13.0, True), (10.0, False)]
    assert run_lengths([], 5.0, 30.0) == [(25.0, False)]


def test_renewed_cusum_run_length_on_white_noise_matches_siegmund() -> None:
    """The calibration's measurement (renewal after each alarm, censored-exponential rate) applied to Page's
    CUSUM (shift 1 σ) on white N(0, 1) noise gives Siegmund's ARL0 at its threshold: h = 4.0 nats, Siegmund
    about 238 steps; 400 chains of 3000 steps (about 5000 alarms, standard error 1.5 %; tolerance 10 %)."""
    h, shift, chains, steps = 4.0, 1.0, 400, 3000
    W = np.array([[0.0, 0.0, 0.0, -1.0, -1.0]])  # one channel: the three hypotheses see the same N(0, 1) sequence
    det = InnovationCUSUM(shift, chains)
    rng = np.random.default_rng(1)
    alarms: list[list[float]] = [[] for _ in range(chains)]
    for k in range(steps):
        C = det.step(rng.standard_normal((chains, 1)), W)
        hit = np.flatnonzero(C[:, 0] >= h)
        for b in hit:
            alarms[b].append(float(k + 1))
        det.C[hit] = 0.0
    r = censored_rate(rl for a in alarms for rl in run_lengths(a, 0.0, float(steps)))
    assert r.arl0 == pytest.approx(siegmund_arl0(h, shift), rel=0.10)
