"""Closed loop of a controller on the kinematic model itself: the test (and benchmark) oracle.

The plant is :class:`~ftc_mj.model.kinematics.KinematicModel` integrated with RK4 under
zero-order hold of the command; the true radii follow a step schedule. This is *not* the MuJoCo
truth plant (``ftc_mj.plant``) — it isolates the controller.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ftc_mj.control.base import ControlOutput
from ftc_mj.model.kinematics import KinematicModel


@dataclass
class KinSimResult:
    """Logged closed loop. Arrays over plant substeps unless said otherwise."""

    t: np.ndarray  # s
    pose: np.ndarray  # (K, 3) m, m, rad
    cross_track: np.ndarray  # m
    omega: np.ndarray  # (K, 2) rad/s, applied
    outputs: list[ControlOutput] = field(default_factory=list)  # one per control sample

    @property
    def solve_times(self) -> np.ndarray:
        """Wall time (s) of every control sample."""
        return np.array([o.solve_time for o in self.outputs])

    def max_abs_error(self, t_from: float, t_to: float = np.inf) -> float:
        """max |cross-track| (m) on [t_from, t_to]."""
        m = (self.t >= t_from) & (self.t <= t_to)
        return float(np.max(np.abs(self.cross_track[m])))

    def rms_error(self, t_from: float, t_to: float = np.inf) -> float:
        """RMS cross-track (m) on [t_from, t_to]."""
        m = (self.t >= t_from) & (self.t <= t_to)
        return float(np.sqrt(np.mean(self.cross_track[m] ** 2)))


def rk4(model: KinematicModel, x: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
    """One RK4 step (s) of the 5-state model under constant input ``u``."""
    f = model.derivative
    k1 = f(x, u)
    k2 = f(x + 0.5 * dt * k1, u)
    k3 = f(x + 0.5 * dt * k2, u)
    k4 = f(x + dt * k3, u)
    return x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def simulate(
    controller,
    reference,
    duration: float,
    initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    true_radii: Callable[[float], tuple[float, float]] = lambda t: (2.0, 2.0),
    model_radii: Callable[[float], tuple[float, float]] | None = None,
    half_track: float = 1.0,
    control_period: float = 0.1,
    substeps: int = 10,
) -> KinSimResult:
    """Run ``controller`` against the kinematic plant for ``duration`` (s).

    ``true_radii(t)`` gives the plant radii (m); ``model_radii(t)`` what the controller is told
    (default: the true ones, i.e. perfect estimation).
    """
    model = KinematicModel(b=half_track)
    model_radii = model_radii or true_radii
    n = int(round(duration / control_period))
    dt = control_period / substeps
    x = np.array([*initial_pose, *true_radii(0.0)], dtype=float)
    ts, poses, us, outs = [0.0], [x[:3].copy()], [], []
    u: np.ndarray | None = None
    for k in range(n):
        t = k * control_period
        out = controller.solve(t, x[:3].copy(), np.asarray(model_radii(t), dtype=float), u)
        outs.append(out)
        u = np.asarray(out.omega, dtype=float).copy()
        for i in range(substeps):
            ti = t + i * dt
            x[3:] = true_radii(ti)
            x = rk4(model, x, u, dt)
            ts.append(ti + dt)
            poses.append(x[:3].copy())
            us.append(u)
    us.append(us[-1] if us else np.zeros(2))
    t_arr = np.array(ts)
    P = np.array(poses)
    return KinSimResult(t_arr, P, np.asarray(reference.cross_track(P[:, 0], P[:, 1])), np.array(us), outs)
