"""Generate the kinematic-model functions of the compiled filter kernels from the single model definition.

The numba kernels (:mod:`._kernels`) need the Euler step, the speed/yaw-rate measurement and their
Jacobians as compilable scalar code. Rather than typing the equations a second time, they are
transcribed from the CasADi expressions of :func:`ftc_mj.model.kinematics.casadi_parametric_functions`
(the same :func:`~ftc_mj.model.kinematics.pose_rates`/``body_rates`` as everywhere, Jacobians by
CasADi's automatic differentiation, half track ``b`` an argument) by
:func:`~ftc_mj.model.kinematics.casadi_to_scalar_source`.

The result is written *into* ``_kernels.py`` between two marker lines rather than into a module of its
own: numba's on-disk cache is invalidated by a change of the cached function's own source file only, so
generated code living in the same file keeps the cache honest. After a change of the model run
``python -m ftc_mj.estimation._codegen``; ``tests/test_estimation_numba.py`` fails while the block is stale.
"""

from __future__ import annotations

from pathlib import Path

from ..model.kinematics import casadi_parametric_functions, casadi_to_scalar_source

KERNELS = Path(__file__).with_name("_kernels.py")
BEGIN = "# ---- BEGIN GENERATED: kinematic model (python -m ftc_mj.estimation._codegen; do not edit) ----\n"
END = "# ---- END GENERATED ----\n"
NAMES = {"step": "_kin_step", "F": "_kin_F", "rates": "_kin_rates", "H": "_kin_H"}
"""CasADi Function → name of the generated numba function."""


def generated_block() -> str:
    """The code between the markers: one compiled (cached) function per model Function."""
    fns = casadi_parametric_functions()
    deco = '@njit(cache=True, error_model="numpy")'
    parts = [f"{deco}\n{casadi_to_scalar_source(fns[key], name)}" for key, name in NAMES.items()]
    return "\n\n".join(parts)


def split(text: str) -> tuple[str, str, str]:
    """``(before, block, after)`` of a kernels source text around the generated block."""
    i = text.index(BEGIN) + len(BEGIN)
    j = text.index(END, i)
    return text[:i], text[i:j], text[j:]


def main() -> None:
    """Rewrite the generated block of ``_kernels.py`` if it differs from the model's current code."""
    text = KERNELS.read_text()
    before, block, after = split(text)
    new = generated_block()
    if block == new:
        print(f"{KERNELS.name}: generated block is up to date")
        return
    KERNELS.write_text(before + new + after)
    print(f"{KERNELS.name}: generated block rewritten")


if __name__ == "__main__":
    main()
