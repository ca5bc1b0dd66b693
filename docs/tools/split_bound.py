"""Regenerate the table of docs/fdi.md ("what no estimator can isolate"): the posterior Cramér–Rao bound
along the radius split on the paper's circle.

    .venv/bin/python docs/tools/split_bound.py

Scenario 2 (left tyre 2 → 1 m at t = 10 s), UKF, NMPC with nominal radii (policy none, the paper's
feedback off), 40 s, seed 0, on both plants, with speed only and with speed + yaw rate. From the onset
on, starting from the filters' prior (σ 0.5 m per wheel), two bounds: for the filters' own model (the
radii a random walk of σ 2 m/s·√dt) and for an estimator that *knows* the radii stay constant after
the puncture (radius process noise 0), the most any estimator may assume. Printed: the σ of the bound
along the split (the direction the speed does not see at the current wheel rates) at several times,
and the first time it is at most 0.15 m (the sigma rule's ``max_split_sigma``: isolation).
"""

from __future__ import annotations

import numpy as np

from ftc_mj.config import load_config
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
                B = trace_pcrb(cfg, tr, q_radius=q, start=k0)
                split = np.array([radius_directions(B[k], omega[k0 + k]).split_std for k in range(B.shape[0])])
                at = [split[int(np.searchsorted(t[k0:], x))] for x in TIMES]
                ok = t[k0:][split <= ISOLATED]
                first = f"{ok[0]:.2f} s" if ok.size else "never"
                print(f"| {plant} | {'speed+yaw' if gyro else 'speed'} | {name} | {ratio[0]:.2f} → {ratio[1]:.2f} | "
                      + " | ".join(f"{v:.3f}" for v in at) + f" | {first} |")


if __name__ == "__main__":
    main()
