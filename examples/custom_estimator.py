"""Plug in your own estimator and compare it with the built-in UKF on the same truth plant.

The estimator is defined in ``my_components.py`` (next to this file) and registered there as
``textbook-ekf``; the config names that module in ``plugins``.

    python examples/custom_estimator.py [--duration 40]
"""

from __future__ import annotations

import argparse

import ftc_mj

parser = argparse.ArgumentParser()
parser.add_argument("--duration", type=float, default=40.0)
args = parser.parse_args()

base = {"sensors.yaw_rate_sigma": 0.01, "duration": args.duration, "reconfiguration.policy": "none"}
print(f"{'estimator':<14} {'status':<7} {'detection delay s':>17} {'isolated':>9} {'final R_L error m':>18}")
for kind, options in (("ukf", {}), ("textbook-ekf", {"q_scale": 1.0})):
    cfg = ftc_mj.load_config("scenario2", {**base, "estimator.kind": kind, "estimator.options": options},
                             plugins=["my_components"])
    m = ftc_mj.run(cfg).metrics
    delay = m["detection_delay"]
    print(f"{kind:<14} {m['status']:<7} {delay if delay is None else round(delay, 2)!s:>17} "
          f"{m['isolated_wheel']!s:>9} {m['radius_final_error_L']:>18.3f}")
