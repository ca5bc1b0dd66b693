"""The Gymnasium environment: the API contract (``check_env``), the same plant as ``ftc-mj run`` (an
episode driven by the NMPC's commands is the run, bitwise), the benchmark's scorer for any controller
(on a shared run's config and on a benchmark draw), determinism, the observation's conventions, the
reward's definition and the ending of an episode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ftc_mj
from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.score import SCORE_COLUMNS, score_run
from ftc_mj.benchmark.stats import paired
from ftc_mj.config import load_config, validate_config
from ftc_mj.envs import ENV_ID, DiffDriveEnv
from ftc_mj.errors import BadInput
from ftc_mj.plant import TIPPED
from ftc_mj.wiring.control import build_controller, build_reference
from tests.support.shared_runs import SHARED_RUNS

KINEMATIC = {"plant.kind": "kinematic", "duration": 2.0}
"""Scenario 2 on the kinematic plant, 2 s: 20 controller periods."""
SHARED = "s2-puncture-5s-safe"
"""The shared 5 s MuJoCo run with the left puncture at 3 s, declared and handed over by the safe policy."""
SOLVER_COLUMNS = {"solve_time_ms", "solver_iterations", "solver_ok"}
"""The controller's own trace columns: an action has no solver."""
POSE = ("x_pose", "y_pose", "psi_pose")


def run_config(name: str):
    """The resolved config of the shared run ``name``."""
    scenario, overrides = SHARED_RUNS[name]
    return load_config(scenario, overrides)


def nmpc_episode(env: DiffDriveEnv, **reset: object) -> float:
    """One episode commanded by the built-in NMPC, built outside the environment from its config and fed
    what the loop feeds it: the time, the pose the sensors read, the policy's radii and the last command.
    The return."""
    obs, info = env.reset(**reset)
    controller = build_controller(env.config, build_reference(env.config))
    pose = [env.observation_names.index(n) for n in POSE]
    applied, total, done = None, 0.0, False
    while not done:
        cmd = controller.solve(info["t"], obs[pose], info["model_radii"], applied)
        applied = np.array(cmd.omega, dtype=float)
        obs, reward, terminated, truncated, info = env.step(cmd.omega)
        total, done = total + reward, terminated or truncated
    return total


def random_episode(env: DiffDriveEnv, action_seed: int, **reset: object) -> tuple[list[np.ndarray], float]:
    """One episode of uniformly random wheel rates (the action space seeded with ``action_seed``):
    observations, return."""
    obs, _ = env.reset(**reset)
    env.action_space.seed(action_seed)
    seen, total, done = [obs], 0.0, False
    while not done:
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        seen.append(obs)
        total, done = total + reward, terminated or truncated
    return seen, total


@pytest.fixture(scope="module")
def nmpc_env() -> tuple[DiffDriveEnv, float]:
    """The shared MuJoCo run's config as an environment, after one NMPC-commanded episode, and its return."""
    scenario, overrides = SHARED_RUNS[SHARED]
    env = DiffDriveEnv(scenario, overrides)
    return env, nmpc_episode(env)


@pytest.fixture(scope="module")
def random_env() -> tuple[DiffDriveEnv, float]:
    """The same config after one random-policy episode (seed 0), and its return."""
    scenario, overrides = SHARED_RUNS[SHARED]
    env = DiffDriveEnv(scenario, overrides)
    return env, random_episode(env, 0)[1]


def test_check_env_passes() -> None:
    env = DiffDriveEnv("scenario2", KINEMATIC, observe_filter=True)
    with pytest.warns(UserWarning):  # gymnasium recommends [-1, 1] actions and finite bounds: rad/s, m are unbounded
        check_env(env, skip_render_check=True)


def test_made_by_id_and_by_module_id() -> None:
    for env_id in (ENV_ID, f"ftc_mj.envs:{ENV_ID}"):
        env = gym.make(env_id, scenario="scenario1", overrides=KINEMATIC)
        assert isinstance(env.unwrapped, DiffDriveEnv) and env.unwrapped.config.name == "scenario1"


def test_nmpc_through_the_env_is_the_run_bitwise(nmpc_env, shared_runs) -> None:
    """Same plant, faults, sensors, filter, decision and policy: with the NMPC's commands as actions the
    trace equals ``ftc-mj run``'s in every column but the solver's, bit for bit, and so do the events."""
    env, _ = nmpc_env
    trace, events = env.episode_trace()
    run = shared_runs[SHARED].result
    assert list(trace) == list(run.trace)
    differing = [c for c in trace if c not in SOLVER_COLUMNS
                 and not np.array_equal(trace[c], run.trace[c], equal_nan=True)]
    assert differing == []
    assert events == run.events and any("fault declared: left" in e.text for e in events)


def test_random_policy_and_nmpc_scored_by_the_same_scorer(nmpc_env, random_env, shared_runs) -> None:
    """Both episodes are scored by the benchmark's scorer and get the run's metrics; the NMPC's scores are
    those of ``ftc-mj run``'s trace exactly, its metrics too (but for identity and wall clock), and random
    wheel rates stray farther from the circle than the NMPC (cross-track RMS, m)."""
    run = shared_runs[SHARED]
    nmpc_score, random_score = nmpc_env[0].episode_score(), random_env[0].episode_score()
    assert set(nmpc_score) == set(random_score) == set(SCORE_COLUMNS)
    assert nmpc_score == score_run(run_config(SHARED), run.result.trace, run.result.events)
    nmpc, random = nmpc_env[0].episode_metrics(), random_env[0].episode_metrics()
    assert set(nmpc) == set(random) == set(run.metrics)
    assert nmpc["controller"] == random["controller"] == "agent"
    for key in ("cross_track_rms", "cross_track_max", "detection_delay", "isolated_wheel", "outcome"):
        assert nmpc[key] == run.metrics[key], key
    assert random["cross_track_rms"] > 5 * nmpc["cross_track_rms"]


def test_a_benchmark_draw_scored_for_the_nmpc_and_a_random_policy() -> None:
    """Draw dev 2 of ftc-v1 (circle, right tyre deflating from 6.64 s, seed 769) on the kinematic plant, 14 s: the
    episode is the draw's run (its config, its seed whatever ``seed`` says); the NMPC through the
    environment succeeds (within 0.5 m of the path from 5 s after the onset), random wheel rates do not;
    both as rows of the benchmark's scores, compared by its paired statistics."""
    env = DiffDriveEnv("scenario2", {"plant.kind": "kinematic", "duration": 14.0})
    d = draw("dev", 2, "ftc-v1")
    v1 = {"split": "dev", "index": 2, "version": "ftc-v1"}
    nmpc_episode(env, seed=5, options=v1)
    expected = validate_config({**d.scenario(), "plant": {**d.scenario()["plant"], "kind": "kinematic"},
                                "duration": 14.0})
    assert env.config == expected and env.config.seed == d.seed == 769
    nmpc = env.episode_row("nmpc-through-env")
    random_episode(env, 0, options=v1)
    random = env.episode_row("random")
    assert nmpc["success"] and nmpc["isolation"] == "correct" and nmpc["contouring_max"] < 0.5
    assert not random["success"] and random["contouring_rms"] > 1.0
    assert nmpc["draw"] == random["draw"] == 2 and nmpc["fault_class"] == d.fault_class == "puncture_ramp"
    comparison = paired([nmpc, random], "contouring_rms", "random", "nmpc-through-env")
    assert comparison.a_larger == 1 and comparison.b_larger == 0


def test_an_episode_written_as_a_run_folder_reads_back(nmpc_env, tmp_path) -> None:
    """``write_run`` gives a run folder ``ftc_mj.load_run`` reads: the episode's trace (every column, NaN
    where nothing was produced), its events and metrics, the agent named as the controller."""
    env, _ = nmpc_env
    run = ftc_mj.load_run(env.write_run(tmp_path, rrd=False))
    trace, events = env.episode_trace()
    assert run.run_id == env.episode_metrics()["run_id"] and "_agent_" in run.run_id
    assert run.metrics["controller"] == "agent" and run.events == events
    assert all(np.array_equal(run.trace[c].to_numpy(), trace[c], equal_nan=True) for c in trace)


def test_return_is_minus_the_integral_of_the_squared_cross_track_error(nmpc_env, random_env) -> None:
    """reward = -Δt Σ e² over the rows after each action: the return is -Δt Σ_{k ≥ 1} e_k² of the trace (m²·s),
    to the round-off of summing 50 terms in a different order (relative 1e-12)."""
    for env, total in (nmpc_env, random_env):
        e = env.episode_trace()[0]["cross_track_error"][1:]
        assert total == pytest.approx(-env.loop.dt * float(np.dot(e, e)), rel=1e-12)
    assert random_env[1] < nmpc_env[1]


def test_same_seed_same_observations_and_another_seed_other_noise() -> None:
    env = DiffDriveEnv("scenario2", KINEMATIC)
    first, _ = random_episode(env, 1, seed=3)
    again, _ = random_episode(DiffDriveEnv("scenario2", KINEMATIC), 1, seed=3)
    other, _ = random_episode(env, 1, seed=4)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    v = env.observation_names.index("v_meas")
    assert first[0][v] != other[0][v] and env.config.seed == 4


def test_two_environments_stepped_in_turn_are_each_the_one_alone() -> None:
    """Each environment owns its MuJoCo plant: stepping another one in between (as a vector of
    environments does) leaves an episode bitwise what it is alone."""
    overrides = {"duration": 0.5}
    alone, _ = random_episode(DiffDriveEnv("scenario1", overrides), 0)
    a, b = DiffDriveEnv("scenario1", overrides), DiffDriveEnv("scenario1", overrides)
    seen = [a.reset()[0]]
    b.reset()
    a.action_space.seed(0)
    for _ in range(5):
        seen.append(a.step(a.action_space.sample())[0])
        b.step([0.0, 0.0])
    assert all(np.array_equal(x, y) for x, y in zip(alone, seen, strict=True))


def test_observation_is_what_the_loop_sensed_with_masks_for_missing_sensors() -> None:
    """The sensor entries equal the trace's sensor columns at the sample's row; no gyro: its entry 0.0 and
    its mask 0; with a gyro: mask 1 and the reading."""
    names = DiffDriveEnv("scenario2", KINEMATIC, observe_filter=True).observation_names
    for sigma, valid in ((None, 0.0), (0.01, 1.0)):
        env = DiffDriveEnv("scenario2", {**KINEMATIC, "sensors.yaw_rate_sigma": sigma} if sigma else KINEMATIC,
                           observe_filter=True)
        env.reset()
        obs, *_ = env.step([5.0, 4.0])
        assert env.observation_space.contains(obs)
        o = dict(zip(names, obs, strict=True))
        trace = env.loop.trace.columns
        assert o["t"] == trace["t"][10] == 0.1
        assert o["v_meas"] == trace["v_meas"][10] and o["yaw_rate_valid"] == valid
        assert o["yaw_rate_meas"] == (trace["yaw_rate_meas"][10] if sigma else 0.0)
        assert o["R_L_hat"] == trace["R_L_hat"][10] and o["filter_valid"] == 1.0


def test_a_speed_dropout_is_masked() -> None:
    """A speed-sensor dropout from 0.5 s to 0.8 s: the trace's speed is NaN there, the observation's
    ``v_meas`` 0.0 with ``speed_valid`` 0; before and after, the reading with mask 1."""
    dropout = {"sensor": "speed", "kind": "dropout", "onset": 0.5, "duration": 0.3}
    env = DiffDriveEnv("scenario2", {**KINEMATIC, "faults.sensor": [dropout]})
    v, ok = env.observation_names.index("v_meas"), env.observation_names.index("speed_valid")
    seen = {}
    obs, info = env.reset()
    while info["t"] < 1.0:
        seen[round(info["t"], 2)] = (obs[v], obs[ok])
        obs, _, _, _, info = env.step([5.1, 4.9])
    trace = env.loop.trace.columns
    for t, (value, valid) in seen.items():
        k = round(t / env.loop.dt)
        dropped = 0.5 <= t < 0.8
        assert valid == (0.0 if dropped else 1.0) and np.isnan(trace["v_meas"][k]) == dropped, t
        assert value == (0.0 if dropped else trace["v_meas"][k]), t


@pytest.mark.parametrize(("source", "estimator"), [("sensor", "ukf"), ("sensor", "none"), ("truth", "ukf")])
def test_the_observed_pose_is_the_one_a_method_sees(source: str, estimator: str) -> None:
    """A pose sensor (σ 0.02 m, 10 Hz) whose fixes are displaced 1 m from 0.5 s (a pose bias). With
    ``pose_source = "sensor"`` the observation's pose is what the loop's controller would get — the filter's
    pose estimate (the trace's ``x_hat, y_hat, psi_hat`` at the sample's row), without a filter the last fix
    held — and at 3 s (the filter's χ² gate re-acquires a lasting offset after 2 s) it is ~1 m off the truth, as
    the fixes are; with ``"truth"`` it is the true pose."""
    bias = {"sensor": "pose", "kind": "bias", "onset": 0.5, "size": 1.0}
    env = DiffDriveEnv("scenario2", {**KINEMATIC, "duration": 4.0, "sensors.position_sigma": 0.02,
                                     "sensors.position_rate": 10.0,
                                     "sensors.pose_source": source, "estimator.kind": estimator,
                                     "faults.sensor": [bias]})
    pose = [env.observation_names.index(n) for n in POSE]
    obs, info = env.reset()
    while info["t"] < 3.0:
        obs, _, _, _, info = env.step([5.1, 4.9])
    trace = env.loop.trace.columns
    k = round(info["t"] / env.loop.dt)
    truth = np.array([trace["x"][k], trace["y"][k], trace["psi"][k]])
    if source == "truth":
        assert obs[pose].tolist() == truth.tolist()
        return
    if estimator == "ukf":
        assert obs[pose].tolist() == [trace["x_hat"][k], trace["y_hat"][k], trace["psi_hat"][k]]
    else:
        fixes = np.flatnonzero(np.isfinite(trace["x_meas"][:k + 1]))
        assert obs[pose][:2].tolist() == [trace["x_meas"][fixes[-1]], trace["y_meas"][fixes[-1]]]
    assert 0.8 < float(np.hypot(*(obs[pose][:2] - truth[:2]))) < 1.2


def test_tip_over_terminates_with_the_penalty_and_the_row_that_saw_it() -> None:
    """A hard turn at 10 m/s rolls the MuJoCo robot about 3.6°: with the tip-over limit at 2° the episode
    terminates there, the reward carries the penalty and the trace ends on the row flagged TIPPED."""
    env = DiffDriveEnv("scenario1", {"duration": 3.0, "plant.tipped_limit_deg": 2.0}, tip_penalty=1000.0)
    env.reset()
    terminated = truncated = False
    while not (terminated or truncated):
        _, reward, terminated, truncated, info = env.step([10.0, 0.0])
    assert terminated and not truncated and reward < -1000.0 and info["plant_flags"] & TIPPED
    trace, _ = env.episode_trace()
    assert trace["plant_flags"][-1] & TIPPED and len(trace["t"]) < 300
    assert env.episode_metrics()["outcome"] == "tipped over"
    score = env.episode_score()
    assert score["tipped"] is True and score["success"] is False
    with pytest.raises(RuntimeError, match="reset"):
        env.step([0.0, 0.0])


def test_bad_options_and_actions_name_the_field() -> None:
    with pytest.raises(BadInput, match=r"^tip_penalty: must be a finite number"):
        DiffDriveEnv("scenario2", KINEMATIC, tip_penalty=-1.0)
    with pytest.raises(BadInput, match=r"^render_mode: this environment does not render"):
        DiffDriveEnv("scenario2", KINEMATIC, render_mode="rgb_array")
    env = DiffDriveEnv("scenario2", KINEMATIC)
    with pytest.raises(BadInput, match=r"^options\.speed: not an option"):
        env.reset(options={"speed": 3})
    with pytest.raises(BadInput, match=r"^options\.split: must be one of dev, test"):
        env.reset(options={"split": "train", "index": 0})
    with pytest.raises(BadInput, match=r"^options\.index"):
        env.reset(options={"split": "dev", "index": -1})
    with pytest.raises(BadInput, match=r"^options\.scenario: give either"):
        env.reset(options={"split": "dev", "index": 0, "scenario": "scenario1"})
    env.reset(options={"scenario": "scenario1", "overrides": {"duration": 1.0}})
    assert env.config.name == "scenario1" and env.config.duration == 1.0
    with pytest.raises(BadInput, match=r"^episode_row: the episode is not a benchmark draw"):
        env.episode_row("agent")
    with pytest.raises(ValueError, match="^action"):
        env.step([np.nan, 0.0])


@pytest.mark.parametrize("options", [{"speed": 3}, {"split": "train", "index": 0}, {"split": "dev", "index": -1},
                                     {"scenario": "no-such-scenario"}, {"overrides": {"duration": -1.0}}])
def test_a_failed_reset_leaves_no_episode_to_step(options: dict) -> None:
    """After a reset that raised, ``step`` does not continue the previous episode (it was at t = 0.3 s):
    it refuses in one line until a reset succeeds, which starts at t = 0."""
    env = DiffDriveEnv("scenario2", KINEMATIC)
    env.reset()
    for _ in range(3):
        env.step([5.0, 5.0])
    with pytest.raises(BadInput):
        env.reset(options=options)
    with pytest.raises(RuntimeError, match=r"^step\(\) without an episode .*reset\(\) that raised") as err:
        env.step([5.0, 5.0])
    assert "\n" not in str(err.value)
    with pytest.raises(RuntimeError, match="no episode"):
        env.episode_result()
    _, info = env.reset()
    assert info["t"] == 0.0 and env.step([5.0, 5.0])[4]["t"] == pytest.approx(0.1)


@pytest.mark.parametrize("action", [np.zeros((2, 1)), np.zeros((1, 2)), ["1", "2"], "12", [1 + 2j, 0.0],
                                    np.array([1j, 1j]), [1.0], [1.0, 2.0, 3.0], [[1.0], 2.0], None,
                                    [np.inf, 0.0], [0.0, -np.inf], [np.nan, 0.0]])
def test_an_action_that_is_not_two_finite_real_numbers_is_refused(action: object) -> None:
    env = DiffDriveEnv("scenario2", KINEMATIC)
    env.reset()
    with pytest.raises(ValueError, match=r"^action: expected 2 finite real wheel rates .* of shape \(2,\), got") as err:
        env.step(action)
    assert "\n" not in str(err.value)
    obs, *_ = env.step(np.array([5, 5]))  # integers are real numbers; the episode goes on from t = 0
    assert env.loop is not None and env.loop.trace.columns["omega_R_cmd"][0] == 5.0


def test_the_diagnosis_is_observed_with_the_filter() -> None:
    """With ``observe_filter`` the diagnoser's latest declaration follows the filter's entries: a speed-sensor
    dropout from 0.2 s is declared, its component, target and mode codes and the declaration count observed;
    without a diagnoser ``diag_valid`` is 0."""
    from ftc_mj.estimation.diagnosis.base import COMPONENT_CODES, MODE_CODES, TARGET_CODES

    dropout = {"sensor": "speed", "kind": "dropout", "onset": 0.2, "duration": 1.0}
    env = DiffDriveEnv("scenario2", {**KINEMATIC, "faults.sensor": [dropout]}, observe_filter=True)
    env.reset()
    for _ in range(4):
        obs, *_ = env.step([5.0, 4.0])
    o = dict(zip(env.observation_names, obs, strict=True))
    assert env.observation_space.contains(obs) and o["diag_valid"] == 1.0 and o["diag_count"] == 1.0
    assert (o["diag_component"], o["diag_target"], o["diag_mode"]) == (
        COMPONENT_CODES["speed sensor"], TARGET_CODES["speed"], MODE_CODES["dropout"])
    env = DiffDriveEnv("scenario2", {**KINEMATIC, "diagnosis.kind": "none"}, observe_filter=True)
    env.reset()
    obs, *_ = env.step([5.0, 4.0])
    assert dict(zip(env.observation_names, obs, strict=True))["diag_valid"] == 0.0
