"""Regenerate the tables of docs/fdi.md built on the posterior Cramér–Rao bound: what no estimator can
isolate with speed alone (the bound along the radius split on the paper's circle), and the error the
filters' gains give on a fault-free truth.

    .venv/bin/python docs/tools/pcrb_tables.py

Scenario 2 (left tyre 2 → 1 m at t = 10 s), UKF, NMPC with nominal radii (policy none, the paper's
feedback off), 40 s, seed 0, on both plants, with speed only and with speed + yaw rate. From the onset
on, starting from the filters' prior (σ 0.5 m per wheel), two bounds: for the filters' own model (the
radii a random walk of σ 2 m/s·√dt) and for an estimator that *knows* the radii stay constant after
the puncture (radius process noise 0), the most any estimator may assume. Printed: the σ of the bound
along the split (the direction the speed does not see at the current wheel rates) at several times,
and the first time it is at most 0.15 m (the sigma rule's ``max_split_sigma``: isolation).

Second table, the nominal circle (10 m/s, 50 m) without a fault: the steady-state radius σ of the
filters' model (their Riccati recursion: the PCRB of that model), the error σ the same gains give when
the radii are in truth constant (the Lyapunov recursion of the estimation error with no radius
noise), and their ratio — what a filter that is optimal for its random-walk model achieves on a
constant-radius truth relative to the bound.
"""

from __future__ import annotations

import numpy as np

from ftc_mj.config import RunConfig, load_config
from ftc_mj.estimation.decision_factory import nominal_point_of
from ftc_mj.estimation.factory import setup_from_config
from ftc_mj.estimation.observability import radius_directions
from ftc_mj.estimation.pcrb import trace_pcrb
from ftc_mj.sim.loop import simulate

TIMES = (10.2, 10.5, 11.0, 12.0, 20.0, 39.99)
ISOLATED = 0.15


def main() -> None:
    print("| plant | sensors | bound | ω_L/ω_R at 9.9 → 12 s | " + " | ".join(f"split σ at {t:g} s (m)" for t in TIMES)
          + f" | first t with split σ ≤ {ISOLATED:g} m |")
    print("|---|---|---|---|" + "---|" * len(TIMES) + "---|")
    for plant in ("kinematic", "mujoco"):
        for gyro in (None, 0.01):
            ov = {"plant.kind": plant, "reconfiguration.policy": "none", "duration": 40.0}
            if gyro is not None:
                ov["sensors.yaw_rate_sigma"] = gyro
            cfg = load_config("scenario2", ov)
            tr = simulate(cfg).trace
            t = tr["t"]
            k0 = int(np.searchsorted(t, 10.0 - 1e-9))
            omega = np.column_stack([tr["omega_R"], tr["omega_L"]])
            ratio = [omega[int(np.searchsorted(t, x)), 1] / omega[int(np.searchsorted(t, x)), 0] for x in (9.9, 12.0)]
            for name, q in (("filters' model", None), ("radii constant", 0.0)):
                B = trace_pcrb(setup_from_config(cfg), tr, q_radius=q, start=k0)
                split = np.array([radius_directions(B[k], omega[k0 + k]).split_std for k in range(B.shape[0])])
                at = [split[int(np.searchsorted(t[k0:], x))] for x in TIMES]
                ok = t[k0:][split <= ISOLATED]
                first = f"{ok[0]:.2f} s" if ok.size else "never"
                print(f"| {plant} | {'speed+yaw' if gyro else 'speed'} | {name} | {ratio[0]:.2f} → {ratio[1]:.2f} | "
                      + " | ".join(f"{v:.3f}" for v in at) + f" | {first} |")


def constant_truth_table() -> None:
    """The filters' steady-state σ (the bound of their model) against the σ their gains give with constant
    radii, for each wheel, along the observed combination ``w ∝ [ω_R, ω_L]`` and along the split ``d ⊥ w``
    (with speed only the split is a random walk nothing observes, so the model's per-wheel σ grows
    without bound and only ``w`` is shown)."""
    print("\n| sensors | direction | filters' model σ = PCRB (m) | σ with constant radii (m) | ratio |")
    print("|---|---|---|---|---|")
    for gyro in (0.01, None):
        p = nominal_point_of(RunConfig.model_validate({"sensors": {"yaw_rate_sigma": gyro}}))
        m = p.m
        H, K = np.array(p.H).reshape(m, 5), np.array(p.K).reshape(5, m)
        F, R = np.array(p.F).reshape(5, 5), np.diag(np.square(p.r_sd))
        A = np.eye(5) - K @ H
        w = H[0, 3:5] / np.linalg.norm(H[0, 3:5])  # the speed row: ∝ [ω_R, ω_L]
        dirs = {"R_R": np.array([1.0, 0.0]), "R_L": np.array([0.0, 1.0]), "observed w": w,
                "split d": np.array([w[1], -w[0]])}
        if gyro is None:
            dirs = {"observed w": w}
        sig = {}
        for name, q in (("own", np.square(p.q_sd)), ("constant", np.square([*p.q_sd[:3], 0.0, 0.0]))):
            S = np.zeros((5, 5))
            for _ in range(20000):
                S = A @ (F @ S @ F.T + np.diag(q)) @ A.T + K @ R @ K.T
            sig[name] = {d: float(np.sqrt(v @ S[3:5, 3:5] @ v)) for d, v in dirs.items()}
        for d in dirs:
            print(f"| {'speed+yaw' if gyro else 'speed'} | {d} | {sig['own'][d]:.4f} | {sig['constant'][d]:.4f} | "
                  f"{sig['constant'][d] / sig['own'][d]:.3f} |")


if __name__ == "__main__":
    main()
    constant_truth_table()
