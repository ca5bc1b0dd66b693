"""The paper's test matrix (paper §4, the matrix of ``ftc-mj paper``) as a list of (label, overrides).

- scenarios 1–4 × {EKF, UKF, IMM-EKF, IMM-UKF (4 models)} × feedback {off, on}, NMPC — 32 runs;
- scenario 4 with the 5-model IMM-EKF and IMM-UKF, feedback off and on — 4 runs;
- the NMPC-vs-LMPC comparison with the UKF and feedback on, scenarios 2 and 4 — the NMPC runs are
  already above, so 2 LMPC runs.

That is the paper's 38 runs ("feedback off/on" = reconfiguration policy ``none``/``direct``).
Beyond the paper (``extra``): :data:`EXTRA_RUNS`, the IMM as literally printed (variant ``paper``,
which collapses) beside the default ``hypothesis`` variant; and :func:`policy_runs`, the
reconfiguration-policy axis: scenarios 2–4, UKF, NMPC, policies none / direct / safe ×
speed only / speed + yaw rate, with the NMPC's actuation-rate term (``controller.rate_penalty``
= :data:`POLICY_RATE_PENALTY`) — with the paper's cost the loop on the MuJoCo robot breaks under
any realisable policy (docs/findings.md), which would leave nothing to compare.

Labels are ``s<N>-<estimator>[5]-<fb|nofb>-<controller>[-paper]``, e.g. ``s4-imm-ukf5-fb-nmpc``, and
``s<N>-<estimator>-<policy>-<speed|yaw>-<controller>[-rp]`` for the policy axis;
``ftc-mj paper --only GLOB`` selects by label.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass, field
from typing import Any

SCENARIOS = ("scenario1", "scenario2", "scenario3", "scenario4")
ESTIMATORS = ("ekf", "ukf", "imm-ekf", "imm-ukf")
IMM_ESTIMATORS = ("imm-ekf", "imm-ukf")


@dataclass(frozen=True)
class MatrixEntry:
    """One run of the matrix: a label, the built-in scenario and the config overrides."""

    label: str
    scenario: str
    overrides: dict[str, Any] = field(default_factory=dict)
    extra: bool = False
    """True for runs beyond the paper's 38."""

    @property
    def estimator(self) -> str:
        return str(self.overrides["estimator.kind"])

    @property
    def policy(self) -> str:
        return str(self.overrides["reconfiguration.policy"])

    @property
    def feedback(self) -> bool:
        return self.policy != "none"

    @property
    def sensing(self) -> str:
        return "speed+yaw" if self.overrides.get("sensors.yaw_rate_sigma") else "speed"

    @property
    def rate_penalty(self) -> float:
        return float(self.overrides.get("controller.rate_penalty", 0.0))

    @property
    def controller(self) -> str:
        return str(self.overrides["controller.kind"])

    @property
    def imm_models(self) -> int | None:
        return int(self.overrides.get("estimator.imm_models", 4)) if self.estimator.startswith("imm") else None

    @property
    def imm_variant(self) -> str | None:
        return str(self.overrides.get("estimator.imm_variant", "hypothesis")) if self.estimator.startswith("imm") \
            else None


def make_label(scenario: str, estimator: str, policy: str, controller: str = "nmpc", imm_models: int = 4,
               imm_variant: str = "hypothesis", sensing: str = "speed", rate_penalty: float = 0.0) -> str:
    """The label of a matrix entry (see the module docstring)."""
    n = scenario.removeprefix("scenario")
    est = estimator + ("5" if estimator.startswith("imm") and imm_models == 5 else "")
    if policy not in ("none", "direct") or sensing != "speed" or rate_penalty > 0:
        sens = "yaw" if "yaw" in sensing else "speed"
        return f"s{n}-{est}-{policy}-{sens}-{controller}" + ("-rp" if rate_penalty > 0 else "")
    label = f"s{n}-{est}-{'fb' if policy == 'direct' else 'nofb'}-{controller}"
    if estimator.startswith("imm") and imm_variant == "paper":
        label += "-paper"
    return label


def _entry(scenario: str, estimator: str, feedback: bool, controller: str = "nmpc", imm_models: int = 4,
           imm_variant: str = "hypothesis", extra: bool = False) -> MatrixEntry:
    policy = "direct" if feedback else "none"
    ov: dict[str, Any] = {"estimator.kind": estimator, "reconfiguration.policy": policy, "controller.kind": controller}
    if estimator.startswith("imm"):
        ov["estimator.imm_models"] = imm_models
        ov["estimator.imm_variant"] = imm_variant
    return MatrixEntry(make_label(scenario, estimator, policy, controller, imm_models, imm_variant),
                       scenario, ov, extra)


def paper_matrix() -> list[MatrixEntry]:
    """The paper's 38 runs, in a stable order."""
    out: list[MatrixEntry] = []
    for sc in SCENARIOS:
        for est in ESTIMATORS:
            for fb in (False, True):
                out.append(_entry(sc, est, fb))
    for est in IMM_ESTIMATORS:
        for fb in (False, True):
            out.append(_entry("scenario4", est, fb, imm_models=5))
    for sc in ("scenario2", "scenario4"):
        out.append(_entry(sc, "ukf", True, controller="lmpc"))
    return out


EXTRA_RUNS: tuple[tuple[str, str, bool], ...] = (
    ("scenario2", "imm-ukf", False),
    ("scenario2", "imm-ukf", True),
)
"""(scenario, estimator, feedback) of the extra runs with the literal ``paper`` IMM variant."""


def extra_runs() -> list[MatrixEntry]:
    """Runs beyond the paper: the literal (collapsing) ``paper`` IMM variant."""
    return [_entry(sc, est, fb, imm_variant="paper", extra=True) for sc, est, fb in EXTRA_RUNS]


POLICIES = ("none", "direct", "safe")
POLICY_SCENARIOS = ("scenario2", "scenario3", "scenario4")
POLICY_RATE_PENALTY = 1.0
YAW_RATE_SIGMA = 0.01
"""Gyro noise (rad/s) of the speed + yaw-rate sensing in the policy axis."""


def policy_runs() -> list[MatrixEntry]:
    """The reconfiguration-policy axis: scenarios 2–4 × {none, direct, safe} × {speed,
    speed + yaw rate}, UKF + NMPC with the actuation-rate term — 18 runs."""
    out = []
    for sc in POLICY_SCENARIOS:
        for sensing in ("speed", "speed+yaw"):
            for pol in POLICIES:
                ov: dict[str, Any] = {"estimator.kind": "ukf", "reconfiguration.policy": pol, "controller.kind": "nmpc",
                                      "controller.rate_penalty": POLICY_RATE_PENALTY}
                if sensing == "speed+yaw":
                    ov["sensors.yaw_rate_sigma"] = YAW_RATE_SIGMA
                out.append(MatrixEntry(make_label(sc, "ukf", pol, "nmpc", sensing=sensing,
                                                  rate_penalty=POLICY_RATE_PENALTY), sc, ov, extra=True))
    return out


PF_SCENARIOS = ("scenario1", "scenario2", "scenario3", "scenario4")


def pathfollow_runs() -> list[MatrixEntry]:
    """The path-following axis (:mod:`~ftc_mj.paper.claims.pathfollow`): pf-nmpc with ``safe`` and a gyro on
    scenarios 1–4, the time-parametrised NMPC likewise on scenario 1 (scenarios 2–4 are on the policy axis), and
    pf-nmpc with speed only under ``safe`` and ``none`` on scenarios 2–4 — 11 runs, UKF, actuation-rate term."""
    combos = [(sc, ctl, "safe", "speed+yaw") for sc in PF_SCENARIOS
              for ctl in (("pf-nmpc", "nmpc") if sc == "scenario1" else ("pf-nmpc",))]
    combos += [(sc, "pf-nmpc", pol, "speed") for sc in PF_SCENARIOS[1:] for pol in ("safe", "none")]
    out = []
    for sc, ctl, pol, sensing in combos:
        ov: dict[str, Any] = {"estimator.kind": "ukf", "reconfiguration.policy": pol, "controller.kind": ctl,
                              "controller.rate_penalty": POLICY_RATE_PENALTY}
        if sensing == "speed+yaw":
            ov["sensors.yaw_rate_sigma"] = YAW_RATE_SIGMA
        out.append(MatrixEntry(make_label(sc, "ukf", pol, ctl, sensing=sensing, rate_penalty=POLICY_RATE_PENALTY),
                               sc, ov, extra=True))
    return out


def full_matrix(extras: bool = True) -> list[MatrixEntry]:
    return paper_matrix() + (extra_runs() + policy_runs() + pathfollow_runs() if extras else [])


def select(entries: list[MatrixEntry], patterns: list[str] | None) -> list[MatrixEntry]:
    """Entries whose label matches any of the glob ``patterns`` (all when none are given)."""
    if not patterns:
        return list(entries)
    return [e for e in entries if any(fnmatch.fnmatchcase(e.label, p) for p in patterns)]


