"""Gymnasium environments over ftc-mj's closed loop (:class:`DiffDriveEnv`).

Importing this package registers :data:`ENV_ID` (``ftc_mj/DiffDrive-v1``) with Gymnasium::

    import gymnasium as gym
    import ftc_mj.envs  # noqa: F401 - registers the environment

    env = gym.make("ftc_mj/DiffDrive-v1", scenario="scenario2", overrides={"plant.kind": "kinematic"})
    obs, info = env.reset(seed=0)

``gym.make("ftc_mj.envs:ftc_mj/DiffDrive-v1")`` imports it on the way (Gymnasium 1.x has no
plug-in entry points for environments). The environment: :mod:`ftc_mj.envs.diffdrive`; its observation:
:mod:`ftc_mj.envs.observation`; which run an episode is: :mod:`ftc_mj.envs.episode`; docs/gym.md.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from .diffdrive import DiffDriveEnv
from .observation import FILTER_NAMES, SENSOR_NAMES, observation_names

ENV_ID = "ftc_mj/DiffDrive-v1"
"""The registered id of :class:`DiffDriveEnv`."""

if ENV_ID not in registry:
    register(id=ENV_ID, entry_point="ftc_mj.envs.diffdrive:DiffDriveEnv")

__all__ = ["ENV_ID", "FILTER_NAMES", "SENSOR_NAMES", "DiffDriveEnv", "observation_names"]
