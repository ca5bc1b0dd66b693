"""Regenerate the table of docs/findings.md ("the paper's loop on a physical plant").

    .venv/bin/python docs/tools/physical_plant_table.py

Scenario 2, UKF, NMPC, 40 s, seed 0: plant (MuJoCo, kinematic) × sensing (speed, speed + yaw rate)
× NMPC cost (paper, actuation-rate term 1) × feedback (policy none, direct); prints Markdown rows.
The same runs as the built-in study ``physical_plant`` (which keeps only down-sampled series).
"""

from __future__ import annotations

import itertools

import numpy as np

from ftc_mj.config import load_config
from ftc_mj.sim.run import execute


def main() -> None:
    print("| plant | sensors | NMPC cost | feedback | R̂_L mean 15–40 s (m) | R̂_R mean 15–40 s (m) | "
          "max \\|cross-track\\| after 15 s (m) | yaw-rate std 1–10 s (rad/s) | detection delay (s) | isolated | "
          "command TV (rad/s²) | rows out of domain |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for plant, yaw, rp, fb in itertools.product(("mujoco", "kinematic"), (False, True), (0.0, 1.0), (False, True)):
        if plant == "kinematic" and rp > 0:
            continue
        ov = {"plant.kind": plant, "controller.rate_penalty": rp, "reconfiguration.policy": "direct" if fb else "none"}
        if yaw:
            ov["sensors.yaw_rate_sigma"] = 0.01
        o = execute(load_config("scenario2", ov), rrd=False)
        tr, m = o.result.trace, o.metrics
        t = tr["t"]
        late, early = (t >= 15) & (t <= 40), (t >= 1) & (t < 10)
        dd = m.get("detection_delay")
        print(f"| {plant} | {'speed+yaw' if yaw else 'speed'} | {'rate penalty 1' if rp else 'paper'} | "
              f"{'on' if fb else 'off'} | {np.mean(tr['R_L_hat'][late]):.2f} | {np.mean(tr['R_R_hat'][late]):.2f} | "
              f"{np.max(np.abs(tr['cross_track_error'][t >= 15])):.2f} | {np.std(tr['yaw_rate'][early]):.3f} | "
              f"{'—' if dd is None else f'{dd:.2f}'} | {m.get('isolated_wheel') or '—'} | "
              f"{m['command_total_variation_per_s']:.1f} | {m['plant_out_of_domain_fraction']:.0%} |")


if __name__ == "__main__":
    main()
