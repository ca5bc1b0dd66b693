"""The identity of a run: what a run id and a study run key are computed from, in one place.

A run is a pure function of its resolved config and seed, and of the robot it simulates. Its
identity is the resolved config (:func:`~ftc_mj.config.config_to_toml_dict`) without the output
settings (where and how results are written changes no number), with ``plant.model_file``
replaced by the SHA-256 of the model file's *contents* (:func:`~ftc_mj.resources.model_digest`):

- the same config and robot give the same identity on every machine and from every checkout or
  install location (a shipped model is ``builtin:diffdrive.xml``; a copy of a model elsewhere is
  the same robot);
- a changed robot (one edited value in the MJCF) is a different run.

:func:`run_digest` hashes that identity (SHA-256 of its canonical JSON: sorted keys, floats by
``repr``); :func:`run_id` (``ftc-mj run`` folders, the paper matrix) and the study run keys
(:func:`ftc_mj.study.plan.run_key`) are both made from it.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

from .config import RunConfig, config_to_toml_dict
from .estimation.imm import IMMSettings
from .resources import model_digest, sources_digest


def canonical_hash(obj: Any, n: int = 16) -> str:
    """First ``n`` hex digits of the SHA-256 of plain data as canonical JSON (sorted keys)."""
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:n]


def run_identity(cfg: RunConfig) -> dict[str, Any]:
    """The resolved config as plain data, without ``output``, the model file named by its contents
    (``plant.model_file`` → ``plant.model_digest``)."""
    d = config_to_toml_dict(cfg)
    d.pop("output", None)
    plant = d.setdefault("plant", {})
    plant["model_digest"] = model_digest(plant.pop("model_file", cfg.plant.model_file))
    return d


def run_digest(cfg: RunConfig, n: int = 16) -> str:
    """First ``n`` hex digits of the hash of :func:`run_identity`."""
    return canonical_hash(run_identity(cfg), n)


def run_id(cfg: RunConfig) -> str:
    """``<name>_<estimator>[M[c][p]]_<controller>_<policy>_s<seed>_<digest>``: readable settings and 8
    hex digits of :func:`run_digest` (``M`` the IMM bank size, ``c`` a custom bank, ``p`` the paper
    variant)."""
    est, settings = cfg.estimator.kind, cfg.estimator
    if isinstance(settings, IMMSettings):
        est += f"{settings.bank_size}" + ("c" if settings.imm_bank is not None else "")
        if settings.imm_variant == "paper":
            est += "p"
    return f"{cfg.name}_{est}_{cfg.controller.kind}_{cfg.reconfiguration.policy}_s{cfg.seed}_{run_digest(cfg, 8)}"


def source_revision() -> str | None:
    """The git commit of the ftc_mj sources (short hash, ``+modified`` when the checkout has uncommitted
    changes), or ``None`` for an install outside a git checkout. Recorded in a study's log, beside the
    numbers it produced, so that a published table names the code that computed it."""
    import subprocess
    from pathlib import Path

    here = str(Path(__file__).resolve().parent)
    try:
        head = subprocess.run(["git", "-C", here, "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=10)
        if head.returncode != 0:
            return None
        dirty = subprocess.run(["git", "-C", here, "status", "--porcelain", "--untracked-files=no", "--", here],
                               capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip() + ("+modified" if dirty.stdout.strip() else "")


_SOURCE: list[str] = []


def source_identity() -> str:
    """What names the ftc_mj code a built-in component runs: ``git <revision>`` for a clean checkout, else
    ``<package version>+sources <digest>`` (:func:`~ftc_mj.resources.sources_digest`; an install, or a checkout with
    uncommitted changes, which a revision alone would not name). Computed once per process."""
    if not _SOURCE:
        from . import __version__

        rev = source_revision()
        clean = rev is not None and not rev.endswith("+modified")
        _SOURCE.append(f"git {rev}" if clean else f"{__version__}+sources {sources_digest()}")
    return _SOURCE[0]
