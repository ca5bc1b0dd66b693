"""A synthetic recording fixture: plausible scenario-2-like telemetry (trace, solves, events,
reference) for the recorder's tests, its benchmark and the docs screenshot, without simulating."""

from __future__ import annotations

import numpy as np

from ftc_mj.telemetry import Event, Solve


def synthetic_run(duration: float = 40.0, *, rate_hz: float = 100.0, solve_rate_hz: float = 10.0,
                  horizon: int = 20, n_modes: int = 3, fault_time: float = 10.0, seed: int = 0,
                  ) -> tuple[dict[str, np.ndarray], list[Solve], list[Event], np.ndarray]:
    """A plausible scenario-2-like run (right tyre deflating from 2.0 m to 1.0 m over 1 s at
    ``fault_time`` while tracking a 50 m circle at 10 m/s) for tests, benchmarks and screenshots.

    Returns ``(trace, solves, events, reference_path)``; the trace has every column
    :func:`ftc_mj.rerun.record.write_rrd` understands, solver columns filled on solve rows only (NaN elsewhere).
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration * rate_hz))
    t = np.arange(n) / rate_hz
    R0, b, Rc, V = 2.0, 1.0, 50.0, 10.0
    R_R = np.where(t < fault_time, R0, np.maximum(R0 - 1.0 * (t - fault_time), 1.0))
    R_L = np.full(n, R0)
    w = V / Rc
    err = 0.6 * np.exp(-np.maximum(t - fault_time, 0.0) / 4.0) * (t >= fault_time) * np.sin(0.8 * t)
    psi = w * t + np.pi / 2
    rad = Rc + err
    x, y = rad * np.cos(w * t), rad * np.sin(w * t)
    v = V + 0.3 * np.sin(0.5 * t) * (t >= fault_time)
    yaw_rate = np.full(n, w) + 0.05 * np.gradient(err, t)
    omega_L = (v - yaw_rate * b) / R_L
    omega_R = (v + yaw_rate * b) / R_R
    tau = np.maximum(t - fault_time, 0.0)
    R_R_hat = np.where(t < fault_time, R0 + 0.01 * np.sin(t), 1.0 + (R0 - 1.0) * np.exp(-tau / 1.5))
    R_L_hat = R0 + 0.01 * np.sin(0.7 * t)
    R_R_std = 0.02 + 0.3 * np.exp(-t) + 0.15 * np.exp(-tau / 2.0) * (t >= fault_time)
    R_L_std = 0.02 + 0.3 * np.exp(-t)
    innovation_std = np.full(n, 0.5) + 0.05 * np.exp(-t)
    innovation = rng.normal(0.0, 0.5, n)
    trace: dict[str, np.ndarray] = {
        "t": t, "x": x, "y": y, "psi": psi, "v": v, "v_meas": v + rng.normal(0.0, 0.5, n),
        "R_R": R_R, "R_L": R_L, "R_R_hat": R_R_hat, "R_L_hat": R_L_hat, "R_R_std": R_R_std,
        "R_L_std": R_L_std, "innovation": innovation, "innovation_std": innovation_std,
        "omega_R": omega_R + rng.normal(0.0, 0.02, n), "omega_L": omega_L + rng.normal(0.0, 0.02, n),
        "omega_R_cmd": omega_R, "omega_L_cmd": omega_L, "cross_track_error": err,
        "yaw_rate": yaw_rate, "yaw_rate_meas": yaw_rate + rng.normal(0.0, 0.01, n),
        "roll": np.where(t < fault_time, 0.0, -np.arcsin((R0 - R_R) / (2 * b))),
        "pitch": np.zeros(n), "z": 0.5 * (R_R + R_L), "nis": innovation**2 / innovation_std**2,
        "fault_detected": (t >= fault_time + 0.8).astype(np.float64),
        # safe reconfiguration: nominal, hold after the declaration, hand-over 0.5 s later
        "reconfig_state": np.select([t < fault_time + 0.8, t < fault_time + 1.3], [0.0, 1.0], 2.0),
        "R_L_model": np.full(n, R0),
    }
    trace["R_R_model"] = np.where(trace["reconfig_state"] == 2.0, np.maximum(R_R_hat, 0.05), R0)
    if n_modes:
        logits = np.zeros((n, n_modes))
        logits[:, 0] = np.where(t < fault_time + 0.5, 4.0, -2.0)
        if n_modes > 1:
            logits[:, 1] = np.where(t < fault_time + 0.5, 0.0, 4.0)
        p = np.exp(logits)
        p /= p.sum(axis=1, keepdims=True)
        for k in range(n_modes):
            trace[f"mode_prob_{k + 1}"] = p[:, k]
    trace["solve_time_ms"], trace["solver_iterations"], trace["solver_ok"], solves = _solves(
        t, x, y, rng, rate_hz=rate_hz, solve_rate_hz=solve_rate_hz, horizon=horizon, fault_time=fault_time)
    events = [
        Event(0.0, "info", "run started: scenario2 (synthetic), UKF, feedback on"),
        Event(fault_time, "warn", "fault onset: right tyre deflating 2.0 m -> 1.0 m over 1 s"),
        Event(fault_time + 0.8, "warn", "decision: fault isolated on the RIGHT wheel"),
        Event(fault_time + 2.0, "info", "reconfiguration: feeding back R_R_hat"),
        Event(duration - 1.0 / rate_hz, "info", "run finished"),
    ]
    ang = np.linspace(0.0, 2 * np.pi, 361)
    reference = np.column_stack([Rc * np.cos(ang), Rc * np.sin(ang)])
    return trace, solves, events, reference


def _solves(t: np.ndarray, x: np.ndarray, y: np.ndarray, rng: np.random.Generator, *, rate_hz: float,
            solve_rate_hz: float, horizon: int, fault_time: float,
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[Solve]]:
    """NMPC solves every ``1 / solve_rate_hz`` s (the one near ``fault_time + 0.3`` s fails and falls back):
    solve time (ms), iterations and success (1/0) on the solve rows (NaN elsewhere), and the solves."""
    n = len(t)
    Rc, V = 50.0, 10.0
    w = V / Rc
    every = max(1, int(round(rate_hz / solve_rate_hz)))
    rows = np.arange(0, n, every)
    solves: list[Solve] = []
    st = np.full(n, np.nan)
    it = np.full(n, np.nan)
    ok = np.full(n, np.nan)
    for i in rows:
        tk = t[i] + np.arange(horizon) * 0.1
        pred = np.column_stack([Rc * np.cos(w * tk), Rc * np.sin(w * tk), w * tk + np.pi / 2])
        pred[:, :2] += np.array([x[i] - pred[0, 0], y[i] - pred[0, 1]]) * np.exp(-np.arange(horizon) / 5)[:, None]
        fail = bool(abs(t[i] - (fault_time + 0.3)) < 0.5 / solve_rate_hz)
        s = Solve(t=float(t[i]), predicted=pred, solve_time_ms=float(8.0 + rng.gamma(2.0, 1.0)),
                  iterations=int(8 + rng.integers(0, 10)) if not fail else 3000,
                  status="Maximum_Iterations_Exceeded" if fail else "Solve_Succeeded", fallback=fail)
        solves.append(s)
        st[i], it[i], ok[i] = s.solve_time_ms, s.iterations, float(s.ok)
    return st, it, ok, solves


def scalar_series(trace: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The values a recording of ``trace`` holds at every row, by ``Scalars`` entity (radii in m, rates
    in rad/s, speeds in m/s): radii with ±2σ, innovation with ±2σ and NIS, wheel rates, cross-track
    error, speed, yaw rate, attitude, fault flag and the IMM mode probabilities present."""
    series: dict[str, np.ndarray] = {
        "/radius/right/truth": trace["R_R"], "/radius/right/estimate": trace["R_R_hat"],
        "/radius/right/upper": trace["R_R_hat"] + 2 * trace["R_R_std"],
        "/radius/right/lower": trace["R_R_hat"] - 2 * trace["R_R_std"],
        "/radius/left/truth": trace["R_L"], "/radius/left/estimate": trace["R_L_hat"],
        "/radius/left/upper": trace["R_L_hat"] + 2 * trace["R_L_std"],
        "/radius/left/lower": trace["R_L_hat"] - 2 * trace["R_L_std"],
        "/innovation/value": trace["innovation"], "/innovation/upper": 2 * trace["innovation_std"],
        "/innovation/lower": -2 * trace["innovation_std"], "/innovation/nis": trace["nis"],
        "/wheel_rate/right/measured": trace["omega_R"], "/wheel_rate/right/command": trace["omega_R_cmd"],
        "/wheel_rate/left/measured": trace["omega_L"], "/wheel_rate/left/command": trace["omega_L_cmd"],
        "/tracking/cross_track_error": trace["cross_track_error"], "/speed/truth": trace["v"],
        "/speed/measured": trace["v_meas"], "/yaw_rate/truth": trace["yaw_rate"],
        "/yaw_rate/measured": trace["yaw_rate_meas"], "/attitude/roll": trace["roll"],
        "/attitude/pitch": trace["pitch"], "/attitude/z": trace["z"],
        "/fault/detected": trace["fault_detected"],
    }
    k = 1
    while f"mode_prob_{k}" in trace:
        series[f"/imm/mode_prob_{k}"] = trace[f"mode_prob_{k}"]
        k += 1
    return series
