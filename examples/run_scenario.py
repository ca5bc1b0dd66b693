"""Run the paper's scenario 2 with a yaw-rate gyro and plot the left radius and the tracking error.

    python examples/run_scenario.py [--duration 40] [--out runs/out/examples]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import ftc_mj  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--duration", type=float, default=40.0)
parser.add_argument("--out", type=Path, default=Path("runs/out/examples"))
args = parser.parse_args()

cfg = ftc_mj.load_config("scenario2", {"sensors.yaw_rate_sigma": 0.01, "controller.rate_penalty": 1.0,
                                       "duration": args.duration})
run = ftc_mj.run(cfg, args.out)
print(f"{run.run_id}: {run.status}, robot {run.metrics['outcome']}, fault declared "
      f"{run.metrics['detection_delay']:.2f} s after it, "
      f"isolated: {run.metrics['isolated_wheel']}; written to {run.path}")

tr = run.trace
fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
ax1.plot(tr["t"], tr["R_L"], label="true R_L")
ax1.plot(tr["t"], tr["R_L_hat"], label="UKF estimate")
ax1.fill_between(tr["t"], tr["R_L_hat"] - 2 * tr["R_L_std"], tr["R_L_hat"] + 2 * tr["R_L_std"], alpha=0.3,
                 label="±2σ")
ax1.plot(tr["t"], tr["R_L_model"], "--", label="radius handed to the NMPC")
ax1.set_ylabel("left radius (m)")
ax1.legend()
ax2.plot(tr["t"], tr["cross_track_error"])
ax2.set_ylabel("cross-track error (m)")
ax2.set_xlabel("t (s)")
fig.savefig(run.path / "radius.png", dpi=100)
print(f"figure: {run.path / 'radius.png'}")
