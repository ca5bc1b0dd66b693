"""Drive the robot through the Gymnasium environment: random wheel rates against a hand-written tracking
law (no MPC), each episode scored like a run: by ``ftc-mj bench``'s scorer (``success``: on the path from
5 s after the fault, not tipped) and by the run metrics (``ftc-mj run``'s metrics.json keys).

    python examples/gym_random_policy.py [--duration 20] [--seed 0] [--out DIR]

Scenario 2 (left tyre to 50 % at 10 s) with a yaw-rate gyro. The law is Kanayama's kinematic tracking
law on the observed pose and reference point, turned into wheel rates with the radii the reconfiguration
policy chose (the observation's ``R_R_model``/``R_L_model``: the safe policy hands the filter's estimate
over once the puncture is declared and isolated), so it keeps following the circle after the puncture.
With ``--out`` each episode is written as a run folder (``ftc-mj view`` opens it).
"""

from __future__ import annotations

import argparse
import math

import gymnasium as gym
import numpy as np

import ftc_mj.envs  # noqa: F401 - registers ftc_mj/DiffDrive-v1

parser = argparse.ArgumentParser()
parser.add_argument("--duration", type=float, default=20.0)  # s: docs/gym.md quotes this run
parser.add_argument("--seed", type=int, default=0)
parser.add_argument("--out", default=None)
args = parser.parse_args()

env = gym.make("ftc_mj/DiffDrive-v1", scenario="scenario2",
               overrides={"duration": args.duration, "sensors.yaw_rate_sigma": 0.01}, observe_filter=True)
names = env.unwrapped.observation_names
half_track = env.unwrapped.config.model_half_track  # m


def tracking_law(obs: np.ndarray) -> np.ndarray:
    """Wheel rates (rad/s) from the pose error in the robot's frame (gains 1/s, 1/m², 1/rad)."""
    o = dict(zip(names, obs, strict=True))
    dx, dy = o["x_ref"] - o["x_pose"], o["y_ref"] - o["y_pose"]
    c, s = math.cos(o["psi_pose"]), math.sin(o["psi_pose"])
    ex, ey = c * dx + s * dy, -s * dx + c * dy
    epsi = math.atan2(math.sin(o["psi_ref"] - o["psi_pose"]), math.cos(o["psi_ref"] - o["psi_pose"]))
    v = o["v_ref"] * math.cos(epsi) + 1.0 * ex
    w = o["yaw_rate_ref"] + o["v_ref"] * (0.2 * ey + 1.5 * math.sin(epsi))
    return np.array([(v + w * half_track) / o["R_R_model"], (v - w * half_track) / o["R_L_model"]])


print(f"{'policy':<10} {'return (m²·s)':>14} {'cross-track RMS (m)':>20} {'bench success':>14}  outcome")
for policy in ("random", "tracking"):
    obs, info = env.reset(seed=args.seed)
    env.action_space.seed(args.seed)
    total, done = 0.0, False
    while not done:
        action = env.action_space.sample() if policy == "random" else tracking_law(obs)
        obs, reward, terminated, truncated, info = env.step(action)
        total, done = total + reward, terminated or truncated
    m, score = env.unwrapped.episode_metrics(), env.unwrapped.episode_score()
    print(f"{policy:<10} {total:>14.1f} {m['cross_track_rms']:>20.3f} {score['success']!s:>14}  {m['outcome']}")
    if args.out:
        print(f"  written to {env.unwrapped.write_run(args.out)}")
