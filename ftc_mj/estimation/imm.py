"""Interacting multiple models (paper §2, Bar-Shalom's five steps) over EKF or UKF members.

One step, for ``M`` mode-matched filters with transition matrix ``Π`` (``Π[i, j]`` = P(i → j)):

1. mixing probabilities ``c̄_j = Σ_i Π_ij μ_i``, ``μ_{i|j} = Π_ij μ_i / c̄_j``;
2. mixing ``x⁰ʲ = Σ_i μ_{i|j} xⁱ``, ``P⁰ʲ = Σ_i μ_{i|j} (Pⁱ + (xⁱ - x⁰ʲ)(xⁱ - x⁰ʲ)ᵀ)``;
3. mode-matched filtering: each member predicts from ``(x⁰ʲ, P⁰ʲ)`` and updates with ``z``; the
   likelihood ``Λ_j = N(z; ẑʲ, Sʲ)`` is kept as a *log*-likelihood;
4. mode probabilities ``μ_j ∝ Λ_j c̄_j``, computed as ``c̄_j exp(log Λ_j - max log Λ)`` so that no
   likelihood underflows (a rejected/absent measurement leaves ``μ = c̄``);
5. combination ``x = Σ μ_j xʲ``, ``P = Σ μ_j (Pʲ + (xʲ - x)(xʲ - x)ᵀ)``.

All members are one batch: the ``M × 11`` sigma points (UKF) or ``M`` Jacobians (EKF) are evaluated
in one vectorised call of the kinematic model.

Model banks (paper): 4 models — no fault; 50 % right; 50 % left; both 50 % — with ``Π`` = 0.97 on the
diagonal, 0.01 elsewhere; 5 models add a linear left-wheel deflation at ``estimator.ramp_rate``
(0.96/0.01). ``μ0`` uniform. Two variants (``estimator.imm_variant``):

``paper``
    Literal: every member is the same filter (free radii, the paper's ``Q``), the models differ only
    in their *initial* radii. Mixing merges them within a few hundred steps (spread of radii → 0,
    ``μ`` stays uniform): kept so that the reproduction can show this collapse.

``hypothesis`` (default)
    Each member's *process model* encodes its hypothesis, so mixing cannot erase it:

    * a radius hypothesised at a fraction ``f`` of nominal is **pinned** in the model-matched
      prediction: after mixing, the member's radius mean is set to ``f·R0`` and its variance to
      ``hypothesis_sigma²``, uncorrelated with the other states; the prediction adds ``Q``; the
      update may refine the radius within that tolerance (absorbing small modelling errors), and
      the next mixing/pinning re-imposes the hypothesis. The pose states are mixed normally.
    * the ramp member (5-model bank) pins ``R_R`` at nominal; its ``R_L`` keeps the *mixed* mean
      (so it starts from, and follows, the bank's estimate of the left radius) with the same
      variance ``hypothesis_sigma²``, and its prediction deflates it,
      ``R_L ← max(R_L - ramp_rate·dt, min_radius)``. All members are thus equally sharp, so no
      member wins for its predictive variance alone. The ramp member differs from the no-fault
      member only by following the left radius downwards: while the radius is constant the two fit
      (almost) equally well and share probability; once the radius keeps falling the pinned members
      fall behind and the ramp member takes over. Because it can follow a small constant offset of
      the left radius too, the decision layer requires the left radius to have actually dropped
      before it declares a fault from this member (:mod:`.decision`).

    Because the members predict different speeds (and yaw rates), their likelihoods differ and the
    mode probabilities discriminate; the combined radius estimate is the mode-weighted mixture.
    With speed alone, the 50 % right and 50 % left hypotheses predict the same speed when
    ``ω_R ≈ ω_L`` (straight or gently curved paths), so their probabilities split between them:
    isolation of the wheel needs the yaw-rate gyro or strongly asymmetric wheel rates.

Health rules are those of :mod:`.kernels.single`, applied to the whole bank: an update whose NIS exceeds
the gate for *every* member is rejected; a member whose covariance is not positive definite is
eigen-floored; divergence (non-finite numbers, or the mixture NIS above ``divergence_nis`` for
``divergence_dwell`` s) resets all members to their last finite estimates with ``reset_inflation·P0``.

A step is one call of the compiled kernel of the members' kind (:mod:`.kernels.imm`).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, Strict, model_validator

from ..context import RunContext
from ..fields import Flag, Fraction, PosFloat, StrictModel, ranged
from .base import FilterOutput, Hypothesis, Measurement
from .buffers import BufferView, FilterBuffers, HealthCounters
from .kernels.imm import imm_combine, imm_step_ekf, imm_step_ukf, impose_hypotheses
from .kernels.layout import C_HYP, P_RAMP_STEP
from .measurements import kernel_inputs
from .settings import EstimatorSettings
from .setup import FilterSettings, FilterSetup, setup_from_settings
from .ukf import SigmaPointSettings

BANK_4: tuple[Hypothesis, ...] = (
    Hypothesis("no fault", 1.0, 1.0, False),
    Hypothesis("right 50%", 0.5, 1.0, False),
    Hypothesis("left 50%", 1.0, 0.5, False),
    Hypothesis("both 50%", 0.5, 0.5, False),
)
BANK_5: tuple[Hypothesis, ...] = (*BANK_4, Hypothesis("left ramp", 1.0, 1.0, ramp=True))


class HypothesisSettings(StrictModel):
    """One member of a custom IMM bank (``estimator.imm_bank``): what it assumes about the wheel radii."""

    name: Annotated[str, Strict(), Field(min_length=1, max_length=60)]
    """Shown in events and figures, e.g. ``"left 30 %"``."""
    frac_R: ranged(0.0, 1.0, lo_open=True) = 1.0
    """Right radius as a fraction of nominal (1 = healthy; a puncture makes a radius smaller)."""
    frac_L: ranged(0.0, 1.0, lo_open=True) = 1.0
    """Left radius as a fraction of nominal."""
    ramp: Flag = False
    """The left radius deflates linearly at ``estimator.ramp_rate`` from the bank's estimate (a ramp
    hypothesis; ``frac_L`` is then not used) instead of a step to ``frac_L``."""


class IMMSettings(FilterSettings):
    """The settings of an IMM bank: its members' (:class:`~.setup.FilterSettings`) and the bank's own."""

    imm_models: Literal[4, 5] = 4
    """The paper's IMM bank: 4 models (no fault, 50 % right, 50 % left, both 50 %) or 5 (plus a left
    ramp). Not used with ``imm_bank``."""
    imm_bank: Annotated[list[HypothesisSettings], Field(min_length=2, max_length=12)] | None = None
    """A custom IMM bank: its members' hypotheses, in order (``None`` = the paper's bank of
    ``imm_models`` members). The decision layer reads the hypotheses, whatever their number and order."""
    p_stay: Fraction | None = None
    """Diagonal of a custom bank's transition matrix (the rest shared equally); ``None`` =
    ``p_stay_4`` for banks of up to 4 members, else ``p_stay_5``."""
    imm_variant: Literal["hypothesis", "paper"] = "hypothesis"
    """``hypothesis``: each member's process model pins its hypothesis; ``paper``: the members differ only in
    their initial radii (the module docstring says what each does)."""
    p_stay_4: Fraction = 0.97
    """Diagonal of the 4-model bank's transition matrix."""
    p_stay_5: Fraction = 0.96
    """Diagonal of the 5-model bank's transition matrix."""
    ramp_rate: PosFloat = 0.1
    """Deflation rate (m/s) hypothesised by the 5th (linear puncture) IMM model."""
    hypothesis_sigma: PosFloat = 0.05
    """IMM ``hypothesis`` variant: std (m) of a member's hypothesised radius, re-imposed at every
    prediction (tolerance for small modelling errors such as tyre compression)."""

    @model_validator(mode="after")
    def _bank(self) -> IMMSettings:
        """A custom bank replaces ``imm_models`` (not both) and its hypotheses have distinct names."""
        if self.imm_bank is not None:
            if "imm_models" in self.model_fields_set:
                raise ValueError("imm_models: give either imm_models (the paper's banks) or imm_bank, not both")
            names = [h.name for h in self.imm_bank]
            if len(set(names)) != len(names):
                raise ValueError("imm_bank: hypothesis names must differ")
        return self

    @property
    def bank_size(self) -> int:
        """Members of the IMM bank (``imm_bank`` if given, else ``imm_models``)."""
        return len(self.imm_bank) if self.imm_bank is not None else self.imm_models


class IMMEKFSettings(IMMSettings, EstimatorSettings):
    """Settings of an IMM bank of EKF members (``estimator.kind = "imm-ekf"``): the bank's and the decision's."""

    kind: Literal["imm-ekf"] = "imm-ekf"
    """An IMM bank of EKFs (a registered estimator, :data:`ftc_mj.registry.estimators`)."""


class IMMUKFSettings(IMMSettings, EstimatorSettings, SigmaPointSettings):
    """Settings of an IMM bank of UKF members (``estimator.kind = "imm-ukf"``): the bank's, the members' sigma
    points and the decision's."""

    kind: Literal["imm-ukf"] = "imm-ukf"
    """An IMM bank of UKFs (a registered estimator, :data:`ftc_mj.registry.estimators`)."""


def transition_matrix(n: int, p_stay: float) -> np.ndarray:
    """``n × n`` matrix with ``p_stay`` on the diagonal and ``(1 - p_stay)/(n - 1)`` elsewhere."""
    off = (1.0 - p_stay) / (n - 1)
    return np.full((n, n), off) + np.eye(n) * (p_stay - off)


def configured_bank(est: IMMSettings) -> tuple[Hypothesis, ...]:
    """The bank ``est`` asks for: ``est.imm_bank`` in its order, else the paper's of ``imm_models`` members."""
    if est.imm_bank is not None:
        return tuple(Hypothesis(h.name, h.frac_R, h.frac_L, h.ramp) for h in est.imm_bank)
    return BANK_4 if est.imm_models == 4 else BANK_5


def configured_transition(est: IMMSettings, n: int) -> np.ndarray:
    """Transition matrix of an ``n``-member bank: ``est.p_stay`` on the diagonal if set, else ``p_stay_4``
    for 4 members and ``p_stay_5`` otherwise."""
    p = est.p_stay if est.p_stay is not None else (est.p_stay_4 if n == 4 else est.p_stay_5)
    return transition_matrix(n, p)


class IMM(HealthCounters):
    """IMM over EKF or UKF members: ``IMM(setup, settings, member="ukf").step(u, z) -> FilterOutput``.

    ``setup``: the members' resolved parameters; ``settings``: the ``[estimator]`` section (bank,
    transition, variant, ``hypothesis_sigma`` (m), ``ramp_rate`` (m/s)). ``hypotheses``/``transition``/
    ``variant`` default to the configured bank (``estimator.imm_bank``, else the paper's 4 or 5 models);
    they can be given explicitly (e.g. a 2-model bank in tests). The bank's :attr:`hypotheses` travel on
    every output (``FilterOutput.hypotheses``), so the decision layer knows what each mode probability
    means.

    ``X`` (M, 5), ``P`` (M, 5, 5), ``mu`` (M,), ``loglik`` (M,), ``x`` (5,) and ``P_comb`` (5, 5) are
    views of the bank's buffers: assigning to them copies into the buffers.
    """

    Settings = IMMSettings
    """The bank's settings model (each member kind's, :attr:`MEMBER_SETTINGS`, adds its own)."""
    MEMBER_SETTINGS: dict[str, type[IMMSettings]] = {"ekf": IMMEKFSettings, "ukf": IMMUKFSettings}
    """The settings model of a bank of each member kind (``estimator.kind`` ``imm-ekf`` / ``imm-ukf``)."""

    def __init__(self, setup: FilterSetup, settings: IMMSettings, member: str = "ukf", *,
                 hypotheses: tuple[Hypothesis, ...] | None = None, transition: np.ndarray | None = None,
                 variant: str | None = None) -> None:
        self.setup = setup
        self.member = member
        self.hypotheses: tuple[Hypothesis, ...] = (tuple(hypotheses) if hypotheses is not None
                                                   else configured_bank(settings))
        """What each member assumes, in the order of the mode probabilities."""
        n = len(self.hypotheses)
        self.Pi = np.asarray(transition if transition is not None else configured_transition(settings, n), float)
        self.variant = variant if variant is not None else settings.imm_variant
        self._st = FilterBuffers(self.setup, n)
        self._step = imm_step_ekf if member == "ekf" else imm_step_ukf  # compiled per member kind
        self._init_constants(settings)
        self._init_state()

    @classmethod
    def from_context(cls, settings: IMMSettings, context: RunContext, member: str = "ukf") -> IMM:
        """The bank of its settings in a run, of ``member`` (``"ekf"``/``"ukf"``) filters (the sensors' noise,
        the geometry and the initial pose from the run context): the factory the registry calls."""
        return cls(FilterSetup.from_context(settings, context), settings, member)

    @classmethod
    def from_settings(cls, member: str = "ukf", settings: IMMSettings | Any = None, sensors: Any = None,
                      **geometry: Any) -> IMM:
        """The bank built from its own settings, without a run config (models or plain tables, one-line
        errors; ``geometry`` as :func:`.setup.setup_from_settings`)."""
        est, setup = setup_from_settings(settings, sensors, model=cls.MEMBER_SETTINGS[member], **geometry)
        return cls(setup, est, member)

    def _init_constants(self, settings: IMMSettings) -> None:
        """The bank's constants in the buffers: transition matrix, pinned radii (m), the covariance
        masks of the hypothesis variant and the ramp step (m per step)."""
        n, R0, st = self.n_modes, self.setup.nominal_radius, self._st
        hyp = self.variant == "hypothesis"
        frac = np.array([[h.frac_R, h.frac_L] for h in self.hypotheses])
        ramp = np.array([hyp and h.ramp for h in self.hypotheses])
        pin = np.zeros((n, 2), dtype=bool)
        if hyp:
            pin[:, 0] = True
            pin[:, 1] = ~ramp
        reimposed = pin | np.stack([np.zeros(n, bool), ramp], axis=1)
        keep = np.ones((n, 5, 5))
        reset_var = np.zeros((n, 5, 5))
        for j in range(n):
            for c in (0, 1):
                if reimposed[j, c]:
                    keep[j, 3 + c, :] = 0.0
                    keep[j, :, 3 + c] = 0.0
                    reset_var[j, 3 + c, 3 + c] = settings.hypothesis_sigma**2
        st.Pi[:] = self.Pi
        st.pin_value[:], st.pin[:] = frac * R0, pin
        st.keep[:], st.reset_var[:], st.ramp[:] = keep, reset_var, ramp
        st.prm[P_RAMP_STEP] = settings.ramp_rate * self.setup.dt
        st.cnt[C_HYP] = hyp

    def _init_state(self) -> None:
        """Members start at their hypothesised radii (scaled by configured initial radii), ``P0``, uniform
        ``μ``; the hypothesis variant imposes its hypotheses, then the bank is combined."""
        n, R0, x0 = self.n_modes, self.setup.nominal_radius, self.setup.x0
        X = np.repeat(x0[None, :], n, axis=0)
        X[:, 3] = self._st.pin_value[:, 0]
        X[:, 4] = self._st.pin_value[:, 1]
        if x0[3] != R0 or x0[4] != R0:
            # configured initial radii scale the members' *initial* radii (the paper variant's only
            # difference between members); the hypothesis variant pins fractions of nominal R0
            X[:, 3] *= x0[3] / R0
            X[:, 4] *= x0[4] / R0
        self.X = X
        self.P = np.repeat(self.setup.P0[None, :, :], n, axis=0)
        self.mu = np.full(n, 1.0 / n)
        if self.variant == "hypothesis":
            impose_hypotheses(self._st.buf, n, self._st.X, self._st.P)
        imm_combine(self._st.buf, n)

    @property
    def n_modes(self) -> int:
        """Members of the bank."""
        return len(self.hypotheses)

    # ---------------------------------------------------------------- state (views of the buffers)
    X = BufferView("X", "Member estimates (M, 5) (m, m, rad, m, m).")
    P = BufferView("P", "Member covariances (M, 5, 5).")
    mu = BufferView("mu", "Mode probabilities (M,).")
    loglik = BufferView("loglik", "Members' log-likelihoods of the last accepted measurement (M,) (0 before any).")
    x = BufferView("x", "Combined estimate (5,).")
    P_comb = BufferView("Pc", "Combined covariance (5, 5).")

    # ---------------------------------------------------------------- step
    def step(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        """One IMM cycle with wheel rates ``u`` = [omega_R, omega_L] (rad/s) and measurement ``z``."""
        st = self._st
        nis, sp_innov, sp_std, m, rejected, reset, pose_rej = self._step(st.buf, st.cnt,
                                                                         *kernel_inputs(self.setup, u, z))
        return FilterOutput(
            x=st.x.copy(), P=st.Pc.copy(), innovation=st.y_of[m].copy(), S=st.S_of[m].copy(),
            nis=nis, speed_innovation=sp_innov, speed_innovation_std=sp_std,
            mode_probs=st.mu.copy(), hypotheses=self.hypotheses, model_x=st.X.copy(), rejected=rejected, reset=reset,
            pose_rejected=pose_rej,
        )

    @property
    def wheels(self) -> tuple[str | None, ...]:
        """Faulty wheel(s) hypothesised by each member (``None`` = no fault)."""
        return tuple(h.wheel for h in self.hypotheses)
