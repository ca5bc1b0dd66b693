"""The decision rules' false-alarm rates measured on the physical plant, and the maths that measures them.

A detector's run length under no fault is its time to the first alarm from a fresh start. A run of finite
length ends before some alarms: the run length is *censored* by the run's end. Modelled as exponential
(a detector far from its start forgets it: the renewal of a CUSUM or a window-limited GLR after an alarm
is a fresh start), the maximum-likelihood rate of censored exponential run lengths is the number of alarms
over the total time watched (each run length up to its alarm or the run's end), :func:`censored_rate`; its
exact 95 % interval is Garwood's Poisson interval on the count, and the mean run length (ARL0) is its
inverse.

``benchmarks/calibration.py`` measures the rates of the ``cusum``, ``glr`` and ``sigma`` rules under no
fault on the MuJoCo plant, with and without the gyro, and writes them to the data file
:data:`RATES_FILE` shipped with the package; :func:`measured_arl0` reads it for Lorden's bound of the
benchmark's score (:mod:`ftc_mj.benchmark.score`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from ..estimation.calibration import TYRE_CHANGE_FILE, package_data, sensor_set

RATES_FILE = "data/calibration/alarm_rates.json"
"""The measured rates, relative to the package (written by ``benchmarks/calibration.py``)."""
RULE_SETTINGS = ("arl0", "cusum_shift", "glr_window", "k_sigma", "min_drop", "dwell")
"""The ``[estimator.decision]`` settings a measured rate holds for (a rule's threshold depends on them)."""
LAUNCH_S = 5.0
"""End (s) of the launch: the rates the benchmark's bound uses are measured from here on (its faults start at
6 s or later)."""


@dataclass(frozen=True)
class Rate:
    """A censored-exponential alarm rate (1/s) with its exact 95 % interval."""

    alarms: int
    exposure: float
    """Seconds watched (s)."""
    rate: float
    lo: float
    hi: float

    @property
    def arl0(self) -> float:
        """Mean run length (s) at the estimated rate (``inf`` without an alarm)."""
        return math.inf if self.rate <= 0.0 else 1.0 / self.rate

    @property
    def arl0_interval(self) -> tuple[float, float]:
        """95 % interval (s) of the mean run length (the rate's interval inverted)."""
        return (1.0 / self.hi, math.inf if self.lo <= 0.0 else 1.0 / self.lo)


def censored_rate(run_lengths: Iterable[tuple[float, bool]]) -> Rate:
    """The rate of exponential run lengths ``(length s, ended by an alarm)`` — ``False``: censored by the run's
    end —: alarms / total length, the maximum-likelihood estimate, with Garwood's exact Poisson interval."""
    from scipy.stats import chi2

    runs = list(run_lengths)
    a = sum(1 for _, alarm in runs if alarm)
    e = float(sum(length for length, _ in runs))
    if e <= 0.0:
        return Rate(a, e, math.nan, math.nan, math.nan)
    lo = 0.0 if a == 0 else float(chi2.ppf(0.025, 2 * a)) / 2.0
    hi = float(chi2.ppf(0.975, 2 * (a + 1))) / 2.0
    return Rate(a, e, a / e, lo / e, hi / e)


def run_lengths(alarm_times: Iterable[float], start: float, end: float) -> list[tuple[float, bool]]:
    """Run lengths ``(s, alarmed)`` of a detector restarted at ``start`` (s) and after each of its alarms
    (``alarm_times``, s, in order, those after a restart), censored at the run's ``end`` (s)."""
    out, t0 = [], start
    for t in alarm_times:
        if start <= t <= end:
            out.append((t - t0, True))
            t0 = t
    out.append((end - t0, False))
    return out


def chosen_offset(curve: dict[float, Rate], design: float) -> float:
    """The threshold offset (LLR units) of ``curve`` (offset -> the after-launch rate measured at it) whose mean
    time between false alarms is nearest the ``design`` (s) on the log scale (the larger offset, the fewer
    alarms, on a tie); 0 when no offset gave an alarm."""
    finite = {d: r.arl0 for d, r in curve.items() if r.alarms}
    if not finite:
        return 0.0
    return min(finite, key=lambda d: (round(abs(math.log(finite[d] / design)), 9), -d))


def _table() -> dict[str, Any]:
    return package_data(RATES_FILE)  # read once: package_data caches


def measured_arl0(rule: str, gyro: bool, settings: dict[str, float]) -> float | None:
    """The mean time between false alarms (s) of decision ``rule`` measured after the launch on the MuJoCo
    plant with the sensor set (``gyro``), when it was measured with the same threshold ``settings``
    (:data:`RULE_SETTINGS`); ``None`` otherwise (a rule or setting not measured). Without an alarm: the lower
    end of its 95 % interval (exposure / 3.69), the shortest mean time the measurement allows."""
    row = _table().get("after_launch", {}).get(sensor_set(gyro), {}).get(rule)
    return None if row is None else _arl0_of(row, row["settings"], settings)


def tyre_change_arl0(gyro: bool, settings: dict[str, float]) -> float | None:
    """The mean time to a false alarm (s) after the launch of the diagnoser's fast tyre detector at its calibrated
    threshold, measured on the healthy runs of ftc-v2 development draws with the sensor set (``gyro``)
    (``benchmarks/tyre_change_calibration.py``), when measured with the same threshold ``settings``; ``None``
    otherwise. Without an alarm: the lower end of its 95 % interval."""
    data = package_data(TYRE_CHANGE_FILE)
    row = data.get("after_launch", {}).get(sensor_set(gyro))
    return None if row is None else _arl0_of(row, data.get("settings", {}), settings)


def _arl0_of(row: dict[str, Any], measured_with: dict[str, float], settings: dict[str, float]) -> float | None:
    """The ARL0 (s) of a stored rate ``row`` if ``settings`` equal the ones it was ``measured_with``."""
    if any(abs(float(settings.get(k, math.nan)) - v) > 1e-9 for k, v in measured_with.items()):
        return None
    rate = Rate(row["alarms"], row["exposure"], row["rate"], row["lo"], row["hi"])
    return rate.arl0 if rate.alarms else rate.arl0_interval[0]
