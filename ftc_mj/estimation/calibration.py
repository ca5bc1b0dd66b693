"""Thresholds of the change detectors (:mod:`.change`) for a target mean time between false alarms.

The detectors run on the innovations of the residual generator matched to the no-fault hypothesis
(:mod:`.residual`), whose whitened innovations are i.i.d. ``N(0, I)`` when nothing changes (kinematic
plant, any estimator): that is the one null model, and :func:`arl0_threshold` (called by the decision
factory) calibrates each detector on it for the target ``decision.arl0`` (s).

``cusum``: each hypothesis' CUSUM sees ``u_iᵀ e ~ N(0, 1)`` i.i.d., for which Siegmund's approximation
``ARL0 ≈ (e^{b} - b - 1)/(δ²/2)``, ``b = h + 1.166 δ``, is accurate to a few per cent (tested); the rule
alarms on the largest of three correlated CUSUMs, which has no closed form. ``glr``: the maximum over
onsets and hypotheses of ``D²/2C`` has none either. So both thresholds come from a Monte Carlo of the
detector on ``N(0, I)`` innovations with the residual generator's signatures at its nominal operating
point (the reference's speed and yaw rate at nominal radii; ``P`` after 20 s of its Riccati recursion
from ``P0``; speed and yaw-rate channels, position fixes ignored): the threshold whose censored
first-alarm rate (alarms / exposure up to each chain's first alarm) is ``1/arl0``. The run's own
operating point differs (the generator's gain shrinks as it learns the radii; the controller moves the
wheel rates): the false-alarm rates of the full closed loop are measured on development seeds and
validated on held-out ones (docs/fdi.md). Targets beyond 200 s are calibrated at 200 s and extended by
``h += log(arl0/200 s)`` (the LLR scale: ``ARL0 ∝ e^h`` asymptotically, Lorden 1971), which errs on the
long side for a GLR.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np

from ..disk_cache import cache_root, machine_tag, read_value, write_value
from ..model.kinematics import inverse_rates
from ..resources import sources_digest
from .change import DIRECTIONS, HYPOTHESES, InnovationCUSUM, JumpGLR, channel_kinds, noise_variances
from .measurements import measure_jacobian
from .pcrb import information_bound
from .setup import FilterSetup

OFFSETS_FILE = "data/calibration/physical_offsets.json"
"""The change detectors' threshold offsets on the physical robot, relative to the package (written by
``benchmarks/calibration.py --calibrate``)."""
TYRE_CHANGE_FILE = "data/calibration/tyre_change.json"
"""The fast tyre detector's threshold offsets and no-fault rates under the benchmark's drawn conditions, relative
to the package (written by ``benchmarks/tyre_change_calibration.py --write``)."""
CALIBRATION_HORIZON_S = 200.0
"""Longest null run simulated (s); longer targets are extrapolated on the LLR scale."""
NULL_BLOCK_STEPS = 1000
"""Steps of null innovations drawn at once by :func:`null_running_max` (a block of 160 chains × 4 channels is 5 MB)."""
NOMINAL_SETTLE_S = 20.0
"""Riccati recursion (s) from ``P0`` that sets the nominal covariance."""
THRESHOLD_FOLDER = "thresholds"
"""The folder of calibrated thresholds in the disk cache (:func:`~ftc_mj.disk_cache.cache_root`)."""
THRESHOLD_FORMAT = "ftc-mj threshold 1"
"""Part of every threshold's key (:func:`threshold_key`): a new format is a new key."""


@dataclass(frozen=True)
class NominalPoint:
    """A filter (the residual generator) at its nominal operating point (module docstring), as hashable
    numbers."""

    H: tuple[float, ...]
    """(m, 5) measurement Jacobian."""
    L: tuple[float, ...]
    """(m, m) lower Cholesky factor of the filter's innovation covariance ``S``."""
    K: tuple[float, ...]
    """(5, m) filter gain ``P Hᵀ R⁻¹``."""
    F: tuple[float, ...]
    """(5, 5) prediction Jacobian."""

    @property
    def m(self) -> int:
        """Channels."""
        return len(self.H) // 5

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(W, F, A)``: ``W = L⁻¹ H``, ``F``, ``A = I - K H`` as the detectors take them."""
        m = self.m
        H, L, K = np.array(self.H).reshape(m, 5), np.array(self.L).reshape(m, m), np.array(self.K).reshape(5, m)
        return np.linalg.solve(L, H), np.array(self.F).reshape(5, 5), np.eye(5) - K @ H


def nominal_point(setup: FilterSetup, speed: float, yaw_rate: float) -> NominalPoint:
    """Speed (+ yaw-rate) channels of the filter ``setup`` at a steady ``speed`` (m/s) and ``yaw_rate``
    (rad/s) with nominal radii; the covariance after :data:`NOMINAL_SETTLE_S` of the filter's Riccati
    recursion from ``P0``."""
    R0 = setup.nominal_radius
    u = np.array(inverse_rates(speed, yaw_rate, R0, R0, setup.model.b), float)
    x = np.array([0.0, 0.0, 0.0, R0, R0])
    kinds = channel_kinds(setup, 2 if setup.yaw_rate_sigma is not None else 1)
    assert kinds is not None
    H = measure_jacobian(setup.model, x[None, :], u, kinds)[0]
    var = noise_variances(setup, kinds)
    F = setup.model.step_jacobian(x, u)
    n = int(round(NOMINAL_SETTLE_S / setup.dt))
    P = information_bound(np.broadcast_to(F, (n, 5, 5)), [H] * n, [np.diag(var)] * n, setup.Q, setup.P0)[-1]
    Pm = F @ P @ F.T + setup.Q
    L = np.linalg.cholesky(H @ Pm @ H.T + np.diag(var))
    K = P @ H.T / var
    return NominalPoint(tuple(H.ravel()), tuple(L.ravel()), tuple(K.ravel()), tuple(F.ravel()))


def null_running_max(kind: str, point: NominalPoint, *, shift: float, window: int, steps: int, chains: int,
                     seed: int = 0) -> np.ndarray:
    """Running maximum (chains, steps) of a detector's statistic on i.i.d. ``N(0, I)`` innovations with the
    signatures of the nominal ``point``: the null distribution of its first-alarm time for every
    threshold at once."""
    W, F, A = point.arrays()
    rng = np.random.default_rng([seed, 17, point.m])
    out = np.empty((chains, steps))
    run = np.zeros(chains)
    if kind == "cusum":  # the innovations drawn in blocks of steps: the same numbers as one step at a time
        det_c = InnovationCUSUM(shift, chains)
        for k in range(0, steps, NULL_BLOCK_STEPS):
            n = min(NULL_BLOCK_STEPS, steps - k)
            det_c.running_max(rng.standard_normal((n, chains, point.m)), W, run, out[:, k:k + n])
    elif kind == "glr":
        det_g = JumpGLR(informative_lags(point, window), chains)
        for k in range(steps):
            run = np.maximum(run, det_g.step(rng.standard_normal((chains, point.m)), W, F, A))
            out[:, k] = run
    else:
        raise ValueError(f"unknown change detector {kind!r}")
    return out


def informative_lags(point: NominalPoint, window: int, keep: float = 1.0 - 1e-6) -> int:
    """Lags (≤ ``window``) that carry the fraction ``keep`` of a jump's signature information at the
    nominal point. Beyond them a jump's log-likelihood ratio no longer changes, so the running maximum
    of the statistic — all a first alarm depends on — is the same with the shorter window."""
    W, F, A = point.arrays()
    phi = DIRECTIONS.copy()
    info = np.zeros((window, len(HYPOTHESES)))
    for j in range(window):
        info[j] = np.sum((phi @ W.T) ** 2, axis=1)
        phi = phi @ A.T @ F.T
    cum = np.cumsum(info, axis=0)
    total = cum[-1]
    need = np.all(cum >= keep * total, axis=1)
    return int(np.argmax(need)) + 1 if need.any() else window


def first_alarm_rate(running_max: np.ndarray, h: float) -> float:
    """Censored first-alarm rate (alarms per step) at threshold ``h``: chains alarming / steps observed up
    to each chain's first alarm (the maximum-likelihood rate of an exponential first-alarm time)."""
    hit = running_max >= h
    alarmed = hit[:, -1]
    first = np.where(alarmed, hit.argmax(axis=1) + 1, running_max.shape[1])
    return float(alarmed.sum()) / float(first.sum())


@functools.lru_cache(maxsize=32)
def null_threshold(kind: str, point: NominalPoint, shift: float, window: int, arl0_steps: int) -> float:
    """Threshold whose censored first-alarm rate on i.i.d. ``N(0, I)`` innovations is ``1/arl0_steps``
    (bisection on 160 chains of ``arl0_steps`` steps): kept in this process and on the machine's disk cache
    (:data:`THRESHOLD_FOLDER`), so the methods of a bench that meet the same draw calibrate its detector once."""
    folder = cache_root()
    if folder is None:
        return _null_threshold(kind, point, shift, window, arl0_steps)
    key = threshold_key(kind, point, shift, window, arl0_steps)
    path = folder / THRESHOLD_FOLDER / f"{key}.json"
    h = read_value(path, key)
    if h is None:
        h = _null_threshold(kind, point, shift, window, arl0_steps)
        write_value(path, key, h)
    return h


def threshold_key(kind: str, point: NominalPoint, shift: float, window: int, arl0_steps: int) -> str:
    """32 hex digits naming one calibration: its arguments (the nominal point's numbers by their exact ``repr``),
    the ftc-mj sources (:func:`~ftc_mj.resources.sources_digest`: a changed calibration is a new key) and the
    machine (:func:`~ftc_mj.disk_cache.machine_tag`: the Monte Carlo's last bits depend on numpy's kernels)."""
    text = "|".join((THRESHOLD_FORMAT, sources_digest(), machine_tag(), kind, repr(point), repr(float(shift)),
                     str(int(window)), str(int(arl0_steps))))
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _null_threshold(kind: str, point: NominalPoint, shift: float, window: int, arl0_steps: int) -> float:
    """:func:`null_threshold` computed: the bisection on the Monte Carlo's running maxima."""
    chains = 160  # ≈ 100 first alarms at the target: the rate to ±10 %, the threshold to ±0.1 nats
    M = null_running_max(kind, point, shift=shift, window=window, steps=arl0_steps, chains=chains)
    lo, hi = 0.0, float(M.max()) + 1.0
    target = 1.0 / arl0_steps
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if first_alarm_rate(M, mid) > target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def arl0_threshold(kind: str, point: NominalPoint, *, arl0: float, shift: float, window: int,
                   rate: float) -> float:
    """Threshold (log-likelihood-ratio units) of the ``cusum`` or ``glr`` detector for a mean time
    ``arl0`` (s) between false alarms at the nominal ``point``: calibrated on a horizon of at most
    :data:`CALIBRATION_HORIZON_S` at the filter ``rate`` (Hz) and extrapolated to ``arl0``; ``shift``
    the CUSUM design shift (σ), ``window`` the GLR window (steps)."""
    horizon = min(arl0, CALIBRATION_HORIZON_S)
    h = null_threshold(kind, point, float(shift), window, int(round(horizon * rate)))
    return h + math.log(arl0 / horizon)


def siegmund_arl0(h: float, shift: float) -> float:
    """Siegmund's approximation of a single Gaussian CUSUM's ARL0 (steps) at threshold ``h`` (LLR units)
    for a design shift ``shift`` (σ): ``(e^b - b - 1)/(δ²/2)``, ``b = h + 1.166 δ``."""
    b = h + 1.166 * shift
    return (math.exp(b) - b - 1.0) / (0.5 * shift * shift)


@functools.cache
def package_data(name: str) -> dict[str, Any]:
    """The JSON data file ``name`` (relative to the package), ``{}`` when it is absent."""
    path = resources.files("ftc_mj").joinpath(name)
    return json.loads(path.read_text()) if path.is_file() else {}


def sensor_set(gyro: bool) -> str:
    """The calibration's key of a sensor set: ``speed`` or ``speed+yaw``."""
    return "speed+yaw" if gyro else "speed"


def physical_offset(kind: str, gyro: bool) -> float:
    """Offset (log-likelihood-ratio units) added to the ``cusum`` or ``glr`` detector's threshold under the
    physical null model with the sensor set (``gyro``): chosen on no-fault MuJoCo runs of the development seeds
    so that the detector's mean time between false alarms after the launch is the design's
    (``benchmarks/calibration.py --calibrate``; docs/fdi.md, "Calibration on the physical plant"). Measured at
    the design ARL0 of 100 s and applied at any: on the LLR scale (``ARL0 ∝ e^h``, Lorden 1971) a null model
    that makes the mean time a factor ``c`` of the design's at one design does so at every design, and
    ``-log c`` corrects it at each. 0 where not measured."""
    return float(package_data(OFFSETS_FILE).get("offsets", {}).get(sensor_set(gyro), {}).get(kind, 0.0))


def tyre_change_offset(gyro: bool) -> float:
    """Offset (log-likelihood-ratio units) the diagnoser's fast tyre detector adds to the estimator's calibrated
    CUSUM threshold with the sensor set (``gyro``): chosen on the healthy runs of ftc-v2 development draws so that
    its mean time to a false alarm after the launch is the design's under drawn conditions — paths, speeds,
    friction, payloads, a closed loop that corrects and pose fixes, where scenario 1's offset (one path, feedback
    off, no pose sensor) lets it alarm three times too often without a gyro
    (``benchmarks/tyre_change_calibration.py``; docs/fdi.md, "The fast tyre detector"). 0 where not measured."""
    return float(package_data(TYRE_CHANGE_FILE).get("offsets", {}).get(sensor_set(gyro), 0.0))
