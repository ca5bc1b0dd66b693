"""Generate the kinematic-model functions of the compiled filter kernels from the single model definition.

The numba kernels need the Euler step, the speed/yaw-rate measurement and their Jacobians as
compilable scalar code. Rather than typing the equations a second time, they are transcribed from the
CasADi expressions of :func:`ftc_mj.model.kinematics.casadi_parametric_functions` (the same
:func:`~ftc_mj.model.kinematics.pose_rates`/``body_rates`` as everywhere, Jacobians by CasADi's
automatic differentiation, half track ``b`` an argument) by
:func:`~ftc_mj.model.kinematics.casadi_to_scalar_source`, into :mod:`.kernels.generated`.

numba's on-disk cache is invalidated by a change of the cached function's own source file only, so
every kernel module that calls the generated functions carries the generated block's digest
(``MODEL_DIGEST = "…"``), rewritten here: a model change changes their source too. After a change of
the model run ``python -m ftc_mj.estimation.codegen``; a test fails while the files are stale.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

from ..model.kinematics import casadi_parametric_functions, casadi_to_scalar_source

KERNELS_DIR = Path(__file__).with_name("kernels")
GENERATED = KERNELS_DIR / "generated.py"
DEPENDENTS = tuple(KERNELS_DIR / name for name in ("kalman.py", "bank.py", "single.py", "imm.py"))
"""Kernel modules whose compiled code includes the generated functions (they carry the digest)."""
BEGIN = "# ---- BEGIN GENERATED: kinematic model (python -m ftc_mj.estimation.codegen; do not edit) ----\n"
END = "# ---- END GENERATED ----\n"
NAMES = {"step": "kin_step", "F": "kin_F", "rates": "kin_rates", "H": "kin_H"}
"""CasADi Function → name of the generated numba function."""
DIGEST = re.compile(r'^MODEL_DIGEST = "[0-9a-f]*"$', re.M)


def generated_block() -> str:
    """The code between the markers: one compiled (cached) function per model Function."""
    fns = casadi_parametric_functions()
    deco = '@njit(cache=True, error_model="numpy")'
    parts = [f"{deco}\n{casadi_to_scalar_source(fns[key], name)}" for key, name in NAMES.items()]
    return "\n\n".join(parts)


def split(text: str) -> tuple[str, str, str]:
    """``(before, block, after)`` of a source text around the generated block."""
    i = text.index(BEGIN) + len(BEGIN)
    j = text.index(END, i)
    return text[:i], text[i:j], text[j:]


def digest(block: str) -> str:
    """The 16-hex-digit digest of a generated block."""
    return hashlib.sha256(block.encode()).hexdigest()[:16]


def digest_line(block: str) -> str:
    """The line a dependent kernel module carries for ``block``."""
    return f'MODEL_DIGEST = "{digest(block)}"'


def main() -> None:
    """Rewrite the generated block and the dependents' digests if they differ from the model's code."""
    before, block, after = split(GENERATED.read_text())
    new = generated_block()
    changed = block != new
    if changed:
        GENERATED.write_text(before + new + after)
    line = digest_line(new)
    for path in DEPENDENTS:
        text = path.read_text()
        if DIGEST.search(text) and DIGEST.sub(line, text) != text:
            path.write_text(DIGEST.sub(line, text))
            changed = True
    print(f"{GENERATED.name}: {'rewritten' if changed else 'up to date'}")


if __name__ == "__main__":
    main()
