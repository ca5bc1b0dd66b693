"""A Gymnasium environment over ftc-mj's closed loop: the agent is the controller.

:class:`DiffDriveEnv` runs the same components as ``ftc-mj run`` — the plant (MuJoCo, or the kinematic
plant with ``plant.kind = "kinematic"``), its faults, the sensors, the filter, the fault decision and the
reconfiguration policy — built by the same factories into the same :class:`~ftc_mj.sim.loop.ClosedLoop`;
only the controller's command is replaced by the action. One :meth:`~DiffDriveEnv.step` is one controller
period (``1 / controller.rate``, 0.1 s by default): the action ``[omega_R, omega_L]`` (rad/s, within the
robot's ``omega_max``) is held on the plant for that period while the filter and the decision run at
their own rate, exactly as the loop holds the NMPC's command. No controller is built: given the NMPC's
commands, an episode's trace is bitwise the trace of ``ftc-mj run`` of the same config but for the
controller's own columns (the solver's statistics; the telemetry of ``pf-nmpc`` or ``robust-nmpc``).

Reward: ``-Δt · Σ e²`` over the estimator steps the action was in force (``e`` the true cross-track error,
m; ``Δt`` the estimator period, s), so that an episode's return is minus the integral of the squared
distance to the path (m²·s), minus ``tip_penalty`` if the robot tips over. The episode terminates when
the robot tips over (plant flag ``TIPPED``) or its physics becomes unstable (``UNSTABLE``/``NAN``), and is
truncated at the run's ``duration``. The episode's trace and events (:meth:`~DiffDriveEnv.episode_trace`)
have the form ``ftc-mj run`` writes, so an episode is scored like a run: by the benchmark's scorer
(:meth:`~DiffDriveEnv.episode_score`) and by the run metrics (:meth:`~DiffDriveEnv.episode_metrics`).

No rendering: MuJoCo's off-screen renderer needs an OpenGL context chosen before ``mujoco`` is imported
(``MUJOCO_GL``); :meth:`~DiffDriveEnv.write_run` writes the episode as a run folder with its Rerun
recording (``ftc-mj view``) instead.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..benchmark.draws import Draw
from ..benchmark.score import score_run
from ..config import RunConfig, load_config
from ..control.base import ControlOutput
from ..errors import BadInput
from ..plant import NAN, TIPPED, UNSTABLE
from ..sim.loop import ClosedLoop, Sample, SimResult
from ..sim.run import RunOutcome, run_metrics, unstable_time, write_outcome
from ..telemetry import Event
from .episode import episode_config
from .observation import diagnosis_values, filter_values, observation_names, observation_space, sensor_values

ENDING_FLAGS = TIPPED | UNSTABLE | NAN
"""Plant flags that end an episode: the robot fell over, or the physics blew up (the plant froze)."""
TIP_ERROR = 10.0
"""m: the default tip-over penalty is this cross-track error held for the whole run."""


class DiffDriveEnv(gym.Env):
    """The differential-drive robot with faults, filter and fault decision; the agent commands the wheels.

    Parameters
    ----------
    scenario
        The episode's scenario when ``reset`` gets no scenario or draw: a built-in name or a TOML file.
    overrides
        Dotted keys as ``ftc-mj run --set`` applied to every episode (e.g. ``{"plant.kind": "kinematic"}``).
    observe_filter
        Append the filter's estimate, the fault decision and the policy's radii to the observation.
    tip_penalty
        Subtracted from the reward when the robot tips over (m²·s); default ``TIP_ERROR² · duration``.
    render_mode
        Only ``None`` (see the module docstring).
    """

    metadata = {"render_modes": []}

    def __init__(self, scenario: str = "scenario2", overrides: Mapping[str, Any] | None = None, *,
                 observe_filter: bool = False, tip_penalty: float | None = None,
                 render_mode: str | None = None) -> None:
        if render_mode is not None:
            raise BadInput(f"render_mode: this environment does not render, got {render_mode!r}")
        if tip_penalty is not None and not (np.isfinite(tip_penalty) and tip_penalty >= 0):
            raise BadInput(f"tip_penalty: must be a finite number ≥ 0 (m²·s), got {tip_penalty!r}")
        self.scenario = str(scenario)
        self.overrides = dict(overrides or {})
        self.observe_filter = bool(observe_filter)
        self.tip_penalty = tip_penalty
        self.config: RunConfig = load_config(self.scenario, self.overrides)
        self.omega_max = float(self.config.robot.omega_max)
        self.action_space = spaces.Box(-self.omega_max, self.omega_max, shape=(2,), dtype=np.float64)
        self.observation_space = observation_space(self.observe_filter)
        self.observation_names = observation_names(self.observe_filter)
        self.render_mode = None
        self.loop: ClosedLoop | None = None
        self.draw: Draw | None = None
        """The benchmark draw of the episode (``None``: a scenario)."""
        self._plants: dict[str, Any] = {}  # this environment's own plants, reused across its resets
        self._k = 0
        self._sample: Sample | None = None
        self._done = True
        self._wall0 = 0.0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start the episode ``options`` names (:mod:`ftc_mj.envs.episode`); the first observation is the
        controller sample at t = 0. :class:`~ftc_mj.errors.BadInput` naming a bad option or setting; an
        exception of a component during the episode propagates (as in strict mode, ``FTC_MJ_STRICT=1``).
        A reset that raises leaves no episode: :meth:`step` refuses until a reset succeeds."""
        self._done, self.loop, self._sample = True, None, None
        super().reset(seed=seed)
        cfg, self.draw = episode_config(self.scenario, self.overrides, options, seed)
        if float(cfg.robot.omega_max) != self.omega_max:
            raise BadInput(f"robot.omega_max: the episode's {cfg.robot.omega_max} rad/s differs from the "
                             f"action space's {self.omega_max} rad/s; make the environment with that override")
        self.config = cfg
        self._wall0 = time.perf_counter()
        self.loop = ClosedLoop(cfg, with_controller=False, plants=self._plants)
        self._k = 0
        self._sample = self.loop.measure(0)
        self._done = False
        return self._observation(self._sample), self._info(self._sample)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Hold ``action`` (rad/s, clipped to ``±omega_max``) for one controller period."""
        if self._done or self.loop is None or self._sample is None:
            raise RuntimeError("step() without an episode (before a successful reset(), after a reset() that "
                               "raised, or after the episode ended): call reset()")
        loop, k = self.loop, self._k
        loop.apply(k, self._sample.t, ControlOutput(omega=self._command(action)))
        loop.finish(k)
        end = min(k + loop.est_per_ctl, loop.n)
        for j in range(k + 1, end):
            loop.step(j)
        truncated = end == loop.n
        self._sample = self._final_sample() if truncated else loop.measure(end)
        last = end - 1 if truncated else end
        flags = np.bitwise_or.reduce(loop.trace.columns["plant_flags"][k + 1:last + 1], initial=0)
        terminated = bool(flags & ENDING_FLAGS)
        if terminated and not truncated:
            loop.record(end)  # the row that saw the ending is complete in the trace
        self._k = end
        self._done = terminated or truncated
        e = loop.trace.columns["cross_track_error"][k + 1:last + 1]
        reward = -loop.dt * float(np.dot(e, e)) - (self._tip_penalty() if flags & TIPPED else 0.0)
        return self._observation(self._sample), reward, terminated, truncated, self._info(self._sample)

    def _command(self, action: Any) -> np.ndarray:
        """The action as a float64 command (rad/s) within the robot's limits. Anything but two finite real
        numbers of shape ``(2,)`` (``(2, 1)``, strings, complex numbers, NaN, ±inf) is a ``ValueError``."""
        try:
            a = np.asarray(action)
        except (TypeError, ValueError):  # ragged sequences
            a = np.asarray(None)
        if a.shape != (2,) or a.dtype.kind not in "fiu" or not np.all(np.isfinite(a)):
            shown = " ".join(repr(action).split())[:80]
            raise ValueError(f"action: expected 2 finite real wheel rates [omega_R, omega_L] (rad/s) of shape (2,), "
                             f"got {shown}")
        return np.clip(a.astype(np.float64), -self.omega_max, self.omega_max)

    def _final_sample(self) -> Sample:
        """The sensors read once more at the run's end (no trace row: the run has ``n`` rows)."""
        assert self.loop is not None
        parts = self.loop.parts
        truth = parts.plant.truth()
        t = self.loop.n * self.loop.dt
        return Sample(t, truth, parts.sensors.read(truth, t), None)

    def _tip_penalty(self) -> float:
        """The tip-over penalty (m²·s)."""
        return TIP_ERROR**2 * self.config.duration if self.tip_penalty is None else float(self.tip_penalty)

    def _observation(self, s: Sample) -> np.ndarray:
        """The observation at the sample ``s`` (:mod:`ftc_mj.envs.observation`)."""
        loop = self.loop
        assert loop is not None
        values = sensor_values(s.t, s.reading, loop.parts.reference, loop.controller_pose(s.reading))
        if self.observe_filter:
            values += filter_values(loop.out, loop.last_ds, loop.model_radii, float(loop.parts.policy.state))
            values += diagnosis_values(loop.last_diagnosis)
        return np.array(values, dtype=np.float64)

    def _info(self, s: Sample) -> dict[str, Any]:
        """Time (s), the radii (m) the reconfiguration policy gives a controller, the true cross-track error
        (m) and plant flags, the run's seed."""
        assert self.loop is not None
        radii = self.loop.model_radii if s.radii is None else s.radii
        e = float(self.loop.parts.reference.cross_track(s.truth.x, s.truth.y))
        return {"t": s.t, "model_radii": np.array(radii, dtype=float), "cross_track_error": e,
                "plant_flags": int(s.truth.flags), "run_seed": self.config.seed}

    def episode_result(self) -> SimResult:
        """The episode so far as a simulation result (the rows completed, its events in time order)."""
        if self.loop is None:
            raise RuntimeError("no episode: call reset()")
        return self.loop.result(self._wall0)

    def episode_trace(self) -> tuple[dict[str, np.ndarray], list[Event]]:
        """The episode's trace columns (as ``ftc-mj run`` writes them) and events, for a scorer."""
        res = self.episode_result()
        return res.trace, res.events

    def episode_score(self) -> dict[str, Any]:
        """The episode's benchmark scores (:func:`ftc_mj.benchmark.score.score_run`, as ``ftc-mj bench``
        scores a run: a draw's episode by its version's success rule); its status is ``unstable`` if the physics
        blew up, else ``ok``."""
        from ..benchmark.definition import load_definition

        res = self.episode_result()
        status = "unstable" if unstable_time(res.trace) is not None else "ok"
        rule = load_definition(self.draw.version).judge if self.draw is not None else None
        return score_run(self.config, res.trace, res.events, status=status, record=res.record, rule=rule)

    def episode_row(self, method: str) -> dict[str, Any]:
        """The episode as a row of ``ftc-mj bench``'s ``scores.parquet`` for the method named ``method``: the
        draw (index, fault class, split, benchmark version) and :meth:`episode_score`. Rows of an agent and
        of the built-in methods on the same draws go to :func:`ftc_mj.benchmark.stats.aggregate` and
        :func:`~ftc_mj.benchmark.stats.paired`. :class:`BadInput` for an episode that is not a draw."""
        if self.draw is None:
            raise BadInput("episode_row: the episode is not a benchmark draw (reset with options split, index)")
        d = self.draw
        return {"method": method, "draw": d.index, "fault_class": d.fault_class, "split": d.split,
                "benchmark": d.version, **self.episode_score()}

    def episode_metrics(self, result: SimResult | None = None) -> dict[str, Any]:
        """The episode's run metrics (``metrics.json``'s keys, :func:`ftc_mj.sim.run.run_metrics`), with
        ``controller = "agent"`` and ``agent`` for the controller in the run id (the config's did not run)."""
        cfg = self.config
        m = run_metrics(cfg, self.episode_result() if result is None else result)
        m["controller"] = "agent"
        tail = f"_{cfg.reconfiguration.policy}_s{cfg.seed}_"
        m["run_id"] = m["run_id"].replace(f"_{cfg.controller.kind}{tail}", f"_agent{tail}", 1)
        return m

    def write_run(self, out: str | Path, *, rrd: bool = True) -> Path:
        """Write the episode as a run folder ``out/<run-id>/`` (the config — whose controller the agent
        replaced —, trace, metrics, events, and with ``rrd`` the Rerun recording, for ``ftc-mj view``); its path."""
        res = self.episode_result()
        metrics = self.episode_metrics(res)
        outcome = write_outcome(RunOutcome(metrics["run_id"], metrics, res, None), self.config, Path(out), rrd)
        assert outcome.run_dir is not None
        return outcome.run_dir
