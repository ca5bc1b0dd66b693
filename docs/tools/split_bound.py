"""Regenerate the table of docs/fdi.md ("what no estimator can isolate"): the posterior Cramér–Rao bound
along the radius split on the paper's circle.

    .venv/bin/python docs/tools/split_bound.py

Scenario 2 (left tyre 2 → 1 m at t = 10 s), UKF, NMPC with nominal radii (policy none, the paper's
feedback off), 40 s, seed 0, on both plants, with speed only and with speed + yaw rate. From the onset
on, the bound is computed for an estimator that *knows* the radii stay constant after the puncture
(radius process noise 0) and starts from the filters' prior (σ 0.5 m per wheel): every other estimator
does worse. Printed per run: the bound's σ along the split at the end of the run and at its tightest;
the information ``δᵀ J δ`` separating "left at 1 m" from "right at 1 m" (``δ = (1, -1)`` m, ``J`` the
inverse of the bound's radius block at the end), and the smallest error probability any test between
the two can have, ``Φ(-√(δᵀJδ)/2)`` (two equally likely Gaussian hypotheses whose data Mahalanobis
distance is at most ``√(δᵀJδ)``, since ``J`` also counts the prior).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import norm

from ftc_mj.config import load_config
from ftc_mj.estimation.observability import radius_directions
from ftc_mj.estimation.pcrb import trace_pcrb
from ftc_mj.sim.loop import simulate


def main() -> None:
    print("| plant | sensors | split σ bound at 40 s (m) | tightest split σ after the onset (m) | "
          "δᵀJδ left vs right | smallest error of any left/right test |")
    print("|---|---|---|---|---|---|")
    for plant in ("kinematic", "mujoco"):
        for gyro in (None, 0.01):
            ov = {"plant.kind": plant, "reconfiguration.policy": "none", "duration": 40.0}
            if gyro is not None:
                ov["sensors.yaw_rate_sigma"] = gyro
            cfg = load_config("scenario2", ov)
            tr = simulate(cfg).trace
            k0 = int(np.searchsorted(tr["t"], 10.0 - 1e-9))
            B = trace_pcrb(cfg, tr, q_radius=0.0, start=k0)
            omega = np.column_stack([tr["omega_R"], tr["omega_L"]])[k0:]
            split = np.array([radius_directions(B[k], omega[k]).split_std for k in range(B.shape[0])])
            J = np.linalg.inv(B[-1, 3:5, 3:5])
            d = np.array([1.0, -1.0])
            info = float(d @ J @ d)
            print(f"| {plant} | {'speed+yaw' if gyro else 'speed'} | {split[-1]:.3f} | {split.min():.3f} | "
                  f"{info:.3g} | {norm.cdf(-math.sqrt(info) / 2):.3g} |")


if __name__ == "__main__":
    main()
