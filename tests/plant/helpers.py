"""Plants for the plant tests: a run config with plant settings changed, and the MuJoCo plant of a config."""

from __future__ import annotations

from ftc_mj.config import RunConfig
from ftc_mj.plant import Plant


def make_cfg(**plant: object) -> RunConfig:
    """The default run config with the given ``[plant]`` settings."""
    cfg = RunConfig()
    for k, v in plant.items():
        setattr(cfg.plant, k, v)
    return cfg


def mujoco_plant(cfg: RunConfig) -> Plant:
    """The MuJoCo plant of ``cfg``, built from its plant, robot and fault settings."""
    return Plant(cfg.plant, cfg.robot, cfg.faults)
