"""The figure of docs/findings.md, "A path-following NMPC that degrades gracefully": scenario 4 speed against
the feasible speed and contouring error, scenario 3 lateral acceleration and wheel lift-off, time-parametrised
NMPC vs path-following NMPC (UKF, safe policy, speed + yaw rate, held-out seed 3).

It runs its four runs itself with the settings of the matching cells of the built-in study ``pathfollow``
(``ftc_mj/data/studies/pathfollow.toml``, run as ``ftc-mj study pathfollow``); it does not read the study's output.

    .venv/bin/python docs/tools/pathfollow_figure.py [--seed 3] [--out docs/figures/pathfollow.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ftc_mj.config import load_config  # noqa: E402
from ftc_mj.model.kinematics import max_path_speed  # noqa: E402
from ftc_mj.plant import LIFTOFF  # noqa: E402
from ftc_mj.sim.run import execute  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
COLORS = {"nmpc": "tab:orange", "pf-nmpc": "tab:blue"}


def trace(scenario: str, controller: str, seed: int) -> dict[str, np.ndarray]:
    cfg = load_config(scenario, {"estimator.kind": "ukf", "reconfiguration.policy": "safe", "seed": seed,
                                 "controller.kind": controller, "controller.rate_penalty": 1.0,
                                 "sensors.yaw_rate_sigma": 0.01})
    return execute(cfg, None).result.trace


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "figures" / "pathfollow.png")
    args = ap.parse_args()
    cfg = load_config("scenario4")
    fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for ctl in ("nmpc", "pf-nmpc"):
        tr = trace("scenario4", ctl, args.seed)
        t = tr["t"]
        ax[0].plot(t, tr["v"], color=COLORS[ctl], label=f"{ctl}: speed")
        ax[1].plot(t, tr["cross_track_error"], color=COLORS[ctl], label=ctl)
        if ctl == "pf-nmpc":
            V_f = np.minimum(max_path_speed(1.0 / cfg.reference.radius, tr["R_R"], tr["R_L"], cfg.plant_half_track,
                                            cfg.robot.omega_max), cfg.reference.speed)
            ax[0].plot(t, V_f, "k--", lw=1, label="feasible speed (true radii)")
        tr3 = trace("scenario3", ctl, args.seed)
        lift = (np.nan_to_num(tr3["plant_flags"]).astype(np.int64) & LIFTOFF) != 0
        a = tr3["v"] * tr3["yaw_rate"]
        ax[2].plot(tr3["t"], a, color=COLORS[ctl], lw=1, label=f"{ctl}: lateral acceleration")
        ax[2].plot(tr3["t"][lift], a[lift], ".", color=COLORS[ctl], ms=3, label=f"{ctl}: wheel off the ground")
    ax[0].set_ylabel("speed (m/s)")
    ax[0].set_title(f"scenario 4 (left tyre 2 → 0.1 m, 10–29 s), seed {args.seed}, UKF, safe, speed + yaw rate")
    ax[1].set_ylabel("cross-track error (m)")
    ax[2].set_ylabel("v · yaw rate (m/s²)")
    ax[2].set_title("scenario 3 (left then right tyre 2 → 1 m at 5 s and 10 s)")
    ax[2].set_xlabel("t (s)")
    for a_ in ax:
        a_.grid(alpha=0.3)
        a_.legend(fontsize=8, loc="best")
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(args.out)


if __name__ == "__main__":
    main()
