"""FDI metrics of one run that a Monte-Carlo study needs to sweep thresholds afterwards, and the
radius error against the posterior Cramér–Rao bound.

First-alarm records (``metrics.json`` key ``fdi_records``): for each rule with a logged statistic
``g_k`` (:mod:`ftc_mj.estimation.rule_statistics`), the rule's first alarm at a threshold ``h`` is the
first row with ``g_k ≥ h``, i.e. the first row at which the running maximum of ``g`` reaches ``h``.
The running maximum is a step function, so its record rows — where ``g`` exceeds every earlier
value — give the first alarm for every threshold at once: a handful of rows instead of the trace.
Each record is ``[t, g, wheel_code]`` (``sigma``: ``[t, g, z_R, z_L, split_identified]``, from which
the isolated wheel at any threshold follows, :func:`~ftc_mj.estimation.rule_statistics.sigma_isolation`).
Records stop at the first value above :data:`RECORD_CAP` (thresholds beyond are of no interest).

Information of the fault (``fdi_cumulative_kl``, fault runs): the Kullback–Leibler information the
puncture puts into the measurements, accumulated from the onset row, ``K_n = Σ_{k<n} ½ Δ_kᵀ R⁻¹ Δ_k``
(nats, per row). ``Δ_k`` is the shift of the *true* speed (and yaw rate) away from what the nominal
model predicts for the same wheel rates, ``[V, ψ̇]_true - [V, ψ̇](R0, ω)``, less its mean over the
second before the onset (the model's bias on a fault-free robot), and ``R`` the sensor noise: the
shift actually observed, whatever the plant does (on the MuJoCo robot a punctured tyre first slips
and the chassis keeps its speed, so the shift builds up over tenths of a second instead of at once).
With a pose sensor (the filter's ``position_sigma``) each fix adds its own information, independent of the
speed sensor's and the gyro's noise: ``½ |δp|² / σ_p² + ½ δψ² / σ_ψ²``, ``δ`` the true pose's departure from the
pose the nominal model dead-reckons from the onset's true pose with the true wheel rates (its speed and yaw rate
shifted by their mean departure over the second before the onset, as above) — :func:`pose_information`. Without
it a detector that reads the fixes could come in under the bound (docs/fdi.md).
The list stops once ``K`` exceeds :data:`KL_CAP` or after :data:`KL_PROFILE_S` seconds;
``fdi_cumulative_kl_t`` holds the time (s) of each value.

PCRB ratios: ``radius_pcrb_rms_R/L`` is the root-mean-square of the bound's σ (m) for the filters' own
random-walk model and ``radius_rmse_over_pcrb_R/L`` the radius RMSE over it;
``radius_pcrb_const_rms_R/L`` and ``radius_rmse_over_pcrb_const_R/L`` the same for the bound of the
model that made the data (radii constant between the truth's changes,
:func:`~ftc_mj.estimation.pcrb.data_model_bound`), the one no estimator can beat on these data; all from
``settle_time`` seconds on.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..estimation.setup import FilterSetup
from ..model.kinematics import body_rates
from .record import RunRecord

RULES: tuple[str, ...] = ("sigma", "mode", "cusum", "glr")
KL_CAP = 25.0
"""nats: log(ARL0/dt) for ARL0 = 7e8 s at 100 Hz, beyond any false-alarm rate of interest."""
KL_PROFILE_S = 5.0
RECORD_CAP: dict[str, float] = {"sigma": 200.0, "mode": 1.0, "cusum": 500.0, "glr": 500.0}
"""Largest threshold of interest per rule (σ, probability, nats)."""


def first_alarm_records(trace: dict[str, np.ndarray], rule: str, split_limit: float) -> list[list[float]]:
    """Record rows of the running maximum of ``<rule>_stat`` (see the module docstring); empty when the
    rule has no statistic in this trace."""
    g = np.asarray(trace.get(f"{rule}_stat", []), float)
    if g.size == 0 or not np.any(np.isfinite(g)):
        return []
    t = np.asarray(trace["t"], float)
    gf = np.where(np.isfinite(g), g, -np.inf)
    prev = np.concatenate(([0.0], np.maximum.accumulate(gf)[:-1]))
    rows = np.flatnonzero(gf > np.maximum(prev, 0.0))
    cap = RECORD_CAP[rule]
    over = np.flatnonzero(gf[rows] > cap)
    if over.size:
        rows = rows[: over[0] + 1]
    if rule == "sigma":
        split = np.asarray(trace["radius_split_std"], float)
        zR, zL = np.asarray(trace["sigma_z_R"], float), np.asarray(trace["sigma_z_L"], float)
        return [[float(t[k]), float(g[k]), float(zR[k]), float(zL[k]), float(split[k] <= split_limit)] for k in rows]
    code = np.asarray(trace[f"{rule}_wheel"], float)
    return [[float(t[k]), float(g[k]), float(code[k])] for k in rows]


def cumulative_kl(setup: FilterSetup, trace: dict[str, np.ndarray], onset: float) -> list[float]:
    """``K_n`` of the module docstring from the ``onset`` row (s) on, with the nominal model, the sensors' σ
    (the pose fixes' among them) and the step of the run's filter ``setup`` (the run record's)."""
    t = np.asarray(trace["t"], float)
    R0 = setup.nominal_radius
    V0, yr0 = body_rates(R0, R0, np.asarray(trace["omega_R"], float), np.asarray(trace["omega_L"], float),
                         setup.model.b)
    dv, dyr = np.asarray(trace["v"], float) - V0, np.asarray(trace["yaw_rate"], float) - yr0
    res = [dv / setup.speed_sigma]
    if setup.yaw_rate_sigma is not None:
        res.append(dyr / setup.yaw_rate_sigma)
    r = np.column_stack(res)
    k0 = int(np.searchsorted(t, onset - 1e-9))
    pre = (t >= onset - 1.0) & (t < onset)
    if not pre.any() or k0 >= t.size:
        return []
    d = r[k0: k0 + int(round(KL_PROFILE_S / setup.dt))] - r[pre].mean(axis=0)
    info = 0.5 * np.sum(d * d, axis=1)
    if setup.position_sigma is not None:
        info = info + pose_information(setup, trace, k0, info.size, V0 + dv[pre].mean(), yr0 + dyr[pre].mean())
    K = np.cumsum(info)
    stop = np.flatnonzero(K > KL_CAP)
    return [float(v) for v in (K[: stop[0] + 1] if stop.size else K)]


def pose_information(setup: FilterSetup, trace: dict[str, np.ndarray], k0: int, n: int, V: np.ndarray,
                     yaw_rate: np.ndarray) -> np.ndarray:
    """The pose fixes' information (nats) at each of the ``n`` rows from row ``k0``: at a row with a fix (the
    trace's ``x_meas`` finite), ``½ ((x − x̂)² + (y − ŷ)²) / σ_p² + ½ wrap(ψ − ψ̂)² / σ_ψ²`` (the heading term
    only when the fix has a heading σ), ``(x̂, ŷ, ψ̂)`` the pose dead-reckoned from row ``k0``'s true pose with the
    model's speed ``V`` (m/s) and yaw rate ``yaw_rate`` (rad/s) per row — each row's pose from the rates of the
    row before — and ``(x, y, ψ)`` the true pose: the shift of the fixes' mean away from the no-change model."""
    t = np.asarray(trace["t"], float)
    rows = slice(k0, min(t.size, k0 + n))
    dt = setup.dt
    x, y, psi = (np.asarray(trace[c], float)[rows] for c in ("x", "y", "psi"))
    v, w = np.asarray(V, float)[rows][:-1], np.asarray(yaw_rate, float)[rows][:-1]
    ph = psi[0] + dt * np.concatenate(([0.0], np.cumsum(w)))
    xh = x[0] + dt * np.concatenate(([0.0], np.cumsum(v * np.cos(ph[:-1]))))
    yh = y[0] + dt * np.concatenate(([0.0], np.cumsum(v * np.sin(ph[:-1]))))
    info = 0.5 * ((x - xh) ** 2 + (y - yh) ** 2) / setup.position_sigma**2
    if setup.heading_sigma is not None:
        dpsi = (psi - ph + np.pi) % (2.0 * np.pi) - np.pi
        info = info + 0.5 * dpsi**2 / setup.heading_sigma**2
    return np.where(np.isfinite(np.asarray(trace["x_meas"], float)[rows]), info, 0.0)


def lorden_delays(K: np.ndarray, arl0: np.ndarray, dt: float) -> np.ndarray:
    """Lorden's lower bound on the delay (s) of any change detector whose mean time between false alarms is
    ``arl0`` (s), for a change whose cumulative information from its onset is ``K`` (nats per row of
    ``dt`` s, non-decreasing): the time the information first reaches ``log(ARL0 / dt)`` (Lorden 1971,
    asymptotically), ``inf`` beyond the profile."""
    j = np.searchsorted(K, np.log(np.maximum(np.asarray(arl0, float) / dt, 1.0)), side="left")
    return np.where(j < K.size, j * dt, np.inf)


def fdi_sweep_metrics(record: RunRecord, trace: dict[str, np.ndarray], settle_time: float = 5.0) -> dict[str, Any]:
    """First-alarm records, the cumulative information of the fault from the record's first onset, and the
    ratios to the PCRB the run recorded (the trace's ``*_pcrb*`` columns; nothing without them)."""
    m: dict[str, Any] = {}
    if "R_R_pcrb_std" not in trace or not np.any(np.isfinite(trace["R_R_pcrb_std"])):
        return m
    m["fdi_records"] = {r: first_alarm_records(trace, r, record.max_split_sigma) for r in RULES}
    onset = record.first_onset
    if onset is not None:
        kl = cumulative_kl(record.setup, trace, onset)
        k0 = int(np.searchsorted(np.asarray(trace["t"], float), onset - 1e-9))
        m["fdi_cumulative_kl"] = kl
        m["fdi_cumulative_kl_t"] = [float(t) for t in np.asarray(trace["t"], float)[k0: k0 + len(kl)]]
    late = np.asarray(trace["t"], float) >= settle_time
    for w in ("R", "L"):
        err = np.asarray(trace[f"R_{w}_hat"], float)[late] - np.asarray(trace[f"R_{w}"], float)[late]
        for kind in ("", "_const"):
            column = f"R_{w}_pcrb{kind}_std"
            if column not in trace:
                continue
            bound = np.asarray(trace[column], float)[late]
            ok = np.isfinite(err) & np.isfinite(bound)
            if not ok.any():
                continue
            rms_bound = float(np.sqrt(np.mean(bound[ok] ** 2)))
            m[f"radius_pcrb{kind}_rms_{w}"] = rms_bound
            m[f"radius_rmse_over_pcrb{kind}_{w}"] = float(np.sqrt(np.mean(err[ok] ** 2))) / rms_bound
    return m
