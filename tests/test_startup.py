"""Start-up: a command imports only the libraries it uses. Validating a config, listing or printing help
never import CasADi, numba, SciPy's linear algebra or special functions, nor MuJoCo; the filters' kernels
import numba on their first call and are then numba's dispatchers everywhere they were imported."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = {"casadi": "casadi.casadi", "numba": "numba.core.dispatcher", "scipy.linalg": "scipy.linalg._flapack",
         "scipy.special": "scipy.special._ufuncs", "mujoco": "mujoco._structs"}
"""Library → a submodule that is in ``sys.modules`` only once the library really ran (a lazy stand-in does
not import it)."""


def loaded_after(code: str) -> set[str]:
    """The libraries of :data:`HEAVY` a fresh interpreter has loaded after running ``code``."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps([k for k, v in {HEAVY!r}.items() if v in sys.modules]))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=300, check=True)
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def test_validating_a_config_imports_no_solver_library() -> None:
    assert loaded_after("from ftc_mj.config import load_config\nload_config('scenario2')") == set()


def test_help_imports_no_solver_library() -> None:
    code = "from ftc_mj.cli import app\ntry:\n    app(['--help'])\nexcept SystemExit:\n    pass"
    assert loaded_after(code) == set()


def test_kernels_import_numba_on_first_call() -> None:
    code = ("import sys\nfrom ftc_mj.estimation.kernels import layout as m\n"
            "assert 'numba.core.dispatcher' not in sys.modules\n"
            "assert m.layout(1).size > 0\n"
            "from numba.core.registry import CPUDispatcher\n"
            "assert isinstance(m.layout, CPUDispatcher), type(m.layout)")
    assert "numba" in loaded_after(code)
