"""The kinematic model of the differential-drive robot, defined once.

State ``x = [x, y, psi, R_R, R_L]`` (m, m, rad, m, m), input ``u = [omega_R, omega_L]`` (rad/s),
parameter ``b`` = half track (m, wheel centre to axle midpoint)::

    V      = (R_R omega_R + R_L omega_L) / 2
    psidot = (R_R omega_R - R_L omega_L) / (2 b)
    xdot   = V cos psi,   ydot = V sin psi,   Rdot = 0

:func:`pose_rates` is the single definition. It is written against a math namespace (``numpy`` or
``casadi``), so the same lines give the vectorised numeric evaluation (all sigma points of a UKF in
one call), the CasADi symbolic expression used by the MPCs, and, through CasADi's automatic
differentiation, every Jacobian. Nothing else in the package writes these equations again.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache, cached_property
from types import ModuleType
from typing import Any

import numpy as np

from ..lazy import lazy_module

ca = lazy_module("casadi")

STATE_NAMES: tuple[str, ...] = ("x", "y", "psi", "R_R", "R_L")
INPUT_NAMES: tuple[str, ...] = ("omega_R", "omega_L")
NX = 5
NU = 2


def forward_speed(R_R: Any, R_L: Any, omega_R: Any, omega_L: Any) -> Any:
    """Forward speed ``V = (R_R omega_R + R_L omega_L)/2`` (m/s) of the axle midpoint."""
    return 0.5 * (R_R * omega_R + R_L * omega_L)


def body_rates(R_R: Any, R_L: Any, omega_R: Any, omega_L: Any, b: Any) -> tuple[Any, Any]:
    """Forward speed ``V`` (m/s) of the axle midpoint and yaw rate (rad/s) from wheel rates."""
    V = forward_speed(R_R, R_L, omega_R, omega_L)
    psidot = (R_R * omega_R - R_L * omega_L) / (2.0 * b)
    return V, psidot


def pose_rates(
    psi: Any, R_R: Any, R_L: Any, omega_R: Any, omega_L: Any, b: Any, lib: ModuleType = np
) -> tuple[Any, Any, Any]:
    """Time derivatives ``(xdot, ydot, psidot)`` of the pose; ``lib`` is ``numpy`` or ``casadi``."""
    V, psidot = body_rates(R_R, R_L, omega_R, omega_L, b)
    return V * lib.cos(psi), V * lib.sin(psi), psidot


def inverse_rates(V: Any, psidot: Any, R_R: Any, R_L: Any, b: Any) -> tuple[Any, Any]:
    """Wheel rates ``(omega_R, omega_L)`` (rad/s) that give speed ``V`` and yaw rate ``psidot``."""
    return (V + b * psidot) / R_R, (V - b * psidot) / R_L


def max_path_speed(curvature: Any, R_R: Any, R_L: Any, b: Any, omega_max: Any) -> Any:
    """Largest forward speed ``V`` (m/s) at which both wheel rates of :func:`inverse_rates` for the yaw
    rate ``V curvature`` stay within ``±omega_max`` (rad/s): ``omega_R = V (1 + b κ) / R_R`` and
    ``omega_L = V (1 − b κ) / R_L``, so ``V ≤ R_R omega_max / |1 + b κ|`` and ``V ≤ R_L omega_max /
    |1 − b κ|`` (curvature κ in 1/m; on a circle of radius R_p turning left the inner wheel gives
    ``R_L omega_max / (1 − b/R_p)``)."""
    with np.errstate(divide="ignore"):
        right = R_R * omega_max / np.abs(1.0 + b * curvature)
        left = R_L * omega_max / np.abs(1.0 - b * curvature)
    return np.minimum(right, left)


def _sx_derivative(x: ca.SX, u: ca.SX, b: Any) -> ca.SX:
    """Symbolic ``xdot`` (5x1) of :func:`pose_rates`; ``b`` is a number or a CasADi symbol."""
    xd, yd, pd = pose_rates(x[2], x[3], x[4], u[0], u[1], b, ca)
    return ca.vertcat(xd, yd, pd, 0, 0)


def _sx_step(x: ca.SX, u: ca.SX, dt: Any, b: Any) -> ca.SX:
    """Symbolic Euler step ``x + dt f(x, u)``."""
    return x + dt * _sx_derivative(x, u, b)


def _sx_rates(x: ca.SX, u: ca.SX, b: Any) -> ca.SX:
    """Symbolic ``[V, psidot]`` (2x1) of :func:`body_rates`."""
    V, pd = body_rates(x[3], x[4], u[0], u[1], b)
    return ca.vertcat(V, pd)


@dataclass(frozen=True)
class KinematicModel:
    """The kinematic model with half track ``b`` (m) and filter step ``dt`` (s).

    Numeric methods take stacked arrays: states of shape ``(..., 5)`` and inputs of shape
    ``(..., 2)`` broadcast against each other, so one call propagates a batch of sigma points.
    Symbolic methods return CasADi ``Function`` objects built from the same :func:`pose_rates`.
    """

    b: float = 1.0
    dt: float = 0.01
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    # ---------------------------------------------------------------- numeric (numpy)
    def derivative(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Continuous-time ``xdot`` (..., 5) for states (..., 5) and inputs (..., 2)."""
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        xd, yd, pd = pose_rates(x[..., 2], x[..., 3], x[..., 4], u[..., 0], u[..., 1], self.b, np)
        zeros = np.zeros_like(xd)
        return np.stack([xd, yd, pd, zeros, zeros], axis=-1)

    def step(self, x: np.ndarray, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        """Euler step ``x + dt f(x, u)`` (the paper's filter prediction)."""
        return np.asarray(x, dtype=float) + (self.dt if dt is None else dt) * self.derivative(x, u)

    def step_batch(self, x: np.ndarray, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        """Fast :meth:`step` for a float array ``x`` (..., 5) whose batch shape already contains ``u``'s.

        Same equations (:func:`pose_rates`) and the same floating-point operations as :meth:`step`
        (``x + dt f``; the radius rates are zero), without the generic conversions and stacking, so
        the filters' hot path stays cheap. Returns a new array.
        """
        h = self.dt if dt is None else dt
        wR, wL = (u[0], u[1]) if u.ndim == 1 else (u[..., 0], u[..., 1])
        d = np.zeros_like(x)
        d[..., 0], d[..., 1], d[..., 2] = pose_rates(x[..., 2], x[..., 3], x[..., 4], wR, wL, self.b, np)
        return x + h * d

    def speed(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Measurement function of the speed sensor: ``V`` (m/s) for states (..., 5)."""
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        return body_rates(x[..., 3], x[..., 4], u[..., 0], u[..., 1], self.b)[0]

    def yaw_rate(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Measurement function of the yaw-rate gyro (rad/s) for states (..., 5)."""
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        return body_rates(x[..., 3], x[..., 4], u[..., 0], u[..., 1], self.b)[1]

    def step_jacobian(self, x: np.ndarray, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        """``d step / d x`` (5x5) at one state, from CasADi automatic differentiation."""
        J = self.casadi_step_jacobian()(np.asarray(x, float), np.asarray(u, float), self.dt if dt is None else dt)
        return np.asarray(J)

    def measurement_jacobian(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``d [V, psidot] / d x`` (2x5) at one state, from CasADi automatic differentiation."""
        return np.asarray(self.casadi_rates_jacobian()(np.asarray(x, float), np.asarray(u, float)))

    # ---------------------------------------------------------------- symbolic (CasADi)
    @cached_property
    def _symbols(self) -> tuple[ca.SX, ca.SX, ca.SX]:
        return ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("dt")

    def _function(self, name: str, out: str, with_dt: bool,
                  expr: Callable[[ca.SX, ca.SX, ca.SX], ca.SX]) -> ca.Function:
        """The CasADi Function ``name(x, u[, dt]) -> out`` of the SX ``expr(x, u, dt)``, built once per
        model."""
        if name not in self._cache:
            x, u, dt = self._symbols
            args, names = ([x, u, dt], ["x", "u", "dt"]) if with_dt else ([x, u], ["x", "u"])
            self._cache[name] = ca.Function(name, args, [expr(x, u, dt)], names, [out])
        return self._cache[name]

    def casadi_derivative(self) -> ca.Function:
        """``f(x[5], u[2]) -> xdot[5]`` as a CasADi Function (SX)."""
        return self._function("f", "xdot", False, lambda x, u, _: _sx_derivative(x, u, self.b))

    def casadi_step(self) -> ca.Function:
        """``step(x, u, dt) -> x + dt f(x, u)`` as a CasADi Function."""
        return self._function("step", "x_next", True, lambda x, u, dt: _sx_step(x, u, dt, self.b))

    def casadi_step_jacobian(self) -> ca.Function:
        """``F(x, u, dt) = d step / d x`` by automatic differentiation."""
        return self._function("F", "F", True, lambda x, u, dt: ca.jacobian(self.casadi_step()(x, u, dt), x))

    def casadi_rates(self) -> ca.Function:
        """``rates(x, u) -> [V, psidot]`` as a CasADi Function."""
        return self._function("rates", "Vpsidot", False, lambda x, u, _: _sx_rates(x, u, self.b))

    def casadi_rates_jacobian(self) -> ca.Function:
        """``d [V, psidot] / d x`` by automatic differentiation."""
        return self._function("H", "H", False, lambda x, u, _: ca.jacobian(self.casadi_rates()(x, u), x))


# ---------------------------------------------------------------------------- numpy code from CasADi
@cache
def _np_operations() -> tuple[dict[int, str], dict[int, str]]:
    """numpy templates of CasADi's unary and binary operations by operation id (built on first use: the
    ids are CasADi's, and this module does not import CasADi until it transcribes a function)."""
    unary = {
        ca.OP_NEG: "(-{0})", ca.OP_SIN: "np.sin({0})", ca.OP_COS: "np.cos({0})", ca.OP_TAN: "np.tan({0})",
        ca.OP_SQRT: "np.sqrt({0})", ca.OP_SQ: "({0}*{0})", ca.OP_TWICE: "(2.0*{0})", ca.OP_INV: "(1.0/{0})",
        ca.OP_EXP: "np.exp({0})", ca.OP_LOG: "np.log({0})", ca.OP_FABS: "np.abs({0})", ca.OP_ASSIGN: "{0}",
        ca.OP_ATAN: "np.arctan({0})", ca.OP_TANH: "np.tanh({0})",
    }
    binary = {
        ca.OP_ADD: "({0}+{1})", ca.OP_SUB: "({0}-{1})", ca.OP_MUL: "({0}*{1})", ca.OP_DIV: "({0}/{1})",
        ca.OP_POW: "({0}**{1})", ca.OP_CONSTPOW: "({0}**{1})", ca.OP_FMIN: "np.minimum({0},{1})",
        ca.OP_FMAX: "np.maximum({0},{1})", ca.OP_ATAN2: "np.arctan2({0},{1})",
    }
    return unary, binary


def _transcribe(fn: ca.Function, scalar_in: list[bool], vector_src: str) -> tuple[list[str], list[str]]:
    """Body lines ``w<k> = ...`` of the SX instruction list of ``fn`` and, per output, the names of its
    non-zeros in sparsity order. A vector input ``i`` element ``j`` is read as ``vector_src.format(i, j)``."""
    lines: list[str] = []
    outs: list[list[str]] = [[] for _ in range(fn.n_out())]
    unary, binary = _np_operations()
    for k in range(fn.n_instructions()):
        op = fn.instruction_id(k)
        ins = fn.instruction_input(k)
        outk = fn.instruction_output(k)
        if op == ca.OP_CONST:
            lines.append(f"    w{outk[0]} = {float(fn.instruction_constant(k))!r}")
        elif op == ca.OP_INPUT:
            src = f"a{ins[0]}" if scalar_in[ins[0]] else vector_src.format(ins[0], ins[1])
            lines.append(f"    w{outk[0]} = {src}")
        elif op == ca.OP_OUTPUT:
            outs[outk[0]].append(f"o{outk[0]}_{outk[1]}")
            lines.append(f"    o{outk[0]}_{outk[1]} = w{ins[0]}")
        elif op in unary:
            lines.append(f"    w{outk[0]} = " + unary[op].format(f"w{ins[0]}"))
        elif op in binary:
            lines.append(f"    w{outk[0]} = " + binary[op].format(f"w{ins[0]}", f"w{ins[1]}"))
        else:
            raise ValueError(f"casadi code generation: unsupported operation id {op}")
    return lines, [names for names in outs]


def _sx(fn: ca.Function) -> tuple[ca.Function, list[bool]]:
    if not fn.is_a("SXFunction"):
        fn = fn.expand()
    return fn, [fn.sparsity_in(i).numel() == 1 for i in range(fn.n_in())]


def casadi_to_numpy(fn: ca.Function) -> Any:
    """Translate an SX CasADi Function into a vectorised numpy function (generated once).

    The returned callable takes one argument per CasADi input: a vector input of length ``n > 1`` as an
    array of shape ``(..., n)``, a scalar input as a float or an array of shape ``(...)``; it returns
    one array per output (a tuple if there are several): a column output ``(rows, 1)`` as ``(..., rows)``,
    a matrix output as ``(..., rows, cols)``, dense, with structural zeros filled in. The code is a
    straight transcription of the SX instruction list, so it is exactly the CasADi expression (the same
    derivative CasADi's AD produced), without the several-µs call overhead of ``Function.__call__``.
    """
    fn, scalar_in = _sx(fn)
    n_in, n_out = fn.n_in(), fn.n_out()
    lines = [f"def _generated({', '.join(f'a{i}' for i in range(n_in))}):"]
    for i in range(n_in):
        if not scalar_in[i]:
            lines.append(f"    a{i} = np.asarray(a{i}, dtype=float)")
    shape_terms = [f"np.shape(a{i})" if scalar_in[i] else f"a{i}.shape[:-1]" for i in range(n_in)]
    # one point (1-D vectors, float scalars) is the hot case: its batch shape is () without a broadcast_shapes call
    one = [f"type(a{i}) is float" if scalar_in[i] else f"a{i}.ndim == 1" for i in range(n_in)]
    lines.append(f"    _bs = () if {' and '.join(one)} else np.broadcast_shapes({', '.join(shape_terms)})")
    # components: Python floats for a single point (fast scalar arithmetic), else arrays over the batch
    for i in range(n_in):
        if not scalar_in[i]:
            lines.append(f"    c{i} = a{i}.tolist() if a{i}.ndim == 1 else np.moveaxis(a{i}, -1, 0)")
    body, outs = _transcribe(fn, scalar_in, "c{0}[{1}]")
    lines += body
    results = []
    for j in range(n_out):
        sp = fn.sparsity_out(j)
        rows, cols = sp.size1(), sp.size2()
        r_idx, c_idx = sp.get_triplet()
        shape = f"_bs + ({rows},)" if cols == 1 else f"_bs + ({rows}, {cols})"
        lines.append(f"    r{j} = np.zeros({shape})")
        for name, r, c in zip(outs[j], r_idx, c_idx, strict=True):
            idx = f"..., {r}" if cols == 1 else f"..., {r}, {c}"
            lines.append(f"    r{j}[{idx}] = {name}")
        results.append(f"r{j}")
    lines.append(f"    return {results[0] if n_out == 1 else '(' + ', '.join(results) + ',)'}")
    namespace: dict[str, Any] = {"np": np}
    exec("\n".join(lines), namespace)  # noqa: S102 - code generated from a trusted CasADi graph
    gen = namespace["_generated"]
    gen.__doc__ = f"numpy transcription of CasADi Function {fn.name()!r}"
    return gen


def casadi_to_scalar_source(fn: ca.Function, name: str) -> str:
    """Python source of ``def name(a0, ..., out0, ...)`` evaluating an SX Function at one point.

    Vector inputs are 1-D arrays, scalar inputs floats; each output is written, dense (structural
    zeros included), into a preallocated array: a column output ``(rows, 1)`` of shape ``(rows,)``, a
    matrix output of shape ``(rows, cols)``. Straight-line float arithmetic (and ``np.sin``/``np.cos``
    of floats) transcribed from the instruction list as :func:`casadi_to_numpy` does, so numba can
    compile it into the filters' kernels: the same CasADi expressions, without a second hand-typed copy.
    """
    fn, scalar_in = _sx(fn)
    args = [f"a{i}" for i in range(fn.n_in())] + [f"out{j}" for j in range(fn.n_out())]
    body, outs = _transcribe(fn, scalar_in, "a{0}[{1}]")
    lines = [f"def {name}({', '.join(args)}):", f'    """CasADi Function {fn.name()!r} at one point."""', *body]
    for j in range(fn.n_out()):
        sp = fn.sparsity_out(j)
        rows, cols = sp.size1(), sp.size2()
        nz = dict(zip(zip(*sp.get_triplet(), strict=True), outs[j], strict=True))
        for r in range(rows):
            for c in range(cols):
                idx = f"{r}" if cols == 1 else f"{r}, {c}"
                lines.append(f"    out{j}[{idx}] = {nz.get((r, c), '0.0')}")
    return "\n".join(lines) + "\n"


def casadi_parametric_functions() -> dict[str, ca.Function]:
    """The model with the half track ``b`` as an *input*, for compiled code shared by every ``b``.

    ``step(x, u, dt, b)`` (Euler step), ``F(x, u, dt, b)`` = d step/d x, ``rates(x, u, b)`` =
    ``[V, psidot]`` and ``H(x, u, b)`` = d rates/d x (CasADi automatic differentiation): the same
    expressions as :class:`KinematicModel`'s Functions, in which ``b`` is a constant.
    """
    x, u, dt, b = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("dt"), ca.SX.sym("b")
    nxt = _sx_step(x, u, dt, b)
    rates = _sx_rates(x, u, b)
    return {
        "step": ca.Function("step", [x, u, dt, b], [nxt]),
        "F": ca.Function("F", [x, u, dt, b], [ca.jacobian(nxt, x)]),
        "rates": ca.Function("rates", [x, u, b], [rates]),
        "H": ca.Function("H", [x, u, b], [ca.jacobian(rates, x)]),
    }


def _numpy_jacobians(model: KinematicModel) -> tuple[Any, Any]:
    """Cached numpy transcriptions of the AD Jacobians ``F(x, u, dt)`` (..., 5, 5), ``H(x, u)`` (..., 2, 5)."""
    if "np_F" not in model._cache:
        model._cache["np_F"] = casadi_to_numpy(model.casadi_step_jacobian())
        model._cache["np_H"] = casadi_to_numpy(model.casadi_rates_jacobian())
    return model._cache["np_F"], model._cache["np_H"]


def numpy_step_jacobian(model: KinematicModel, x: np.ndarray, u: np.ndarray, dt: float | None = None) -> np.ndarray:
    """Vectorised ``d step / d x`` (..., 5, 5) for states (..., 5): CasADi's AD Jacobian, evaluated in numpy."""
    return _numpy_jacobians(model)[0](x, u, model.dt if dt is None else dt)


def numpy_rates_jacobian(model: KinematicModel, x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Vectorised ``d [V, psidot] / d x`` (..., 2, 5): CasADi's AD Jacobian, evaluated in numpy."""
    return _numpy_jacobians(model)[1](x, u)
