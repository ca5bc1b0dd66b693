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


def test_a_short_run_imports_no_scipy_stats() -> None:
    """``scipy.stats`` (≈ 0.3–0.5 s of imports) is never needed by a run: the pose gate's χ²₂ quantile is
    in closed form (:func:`ftc_mj.estimation.setup.gate_quantile`)."""
    code = ("import sys, tempfile\nfrom ftc_mj.cli import app\n"
            "try:\n    app(['run', 'scenario2', '--duration', '0.05', '--no-rrd', '-q', '--out', tempfile.mkdtemp()])\n"
            "except SystemExit:\n    pass\nassert 'scipy.stats._stats_py' not in sys.modules")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]


def test_pose_gate_quantile_is_scipys() -> None:
    """The closed form ``−2 ln p`` of the χ²₂ quantile equals SciPy's at the default 1e-4 bitwise and within
    1e-14 relative over 12 decades."""
    import math

    import numpy as np
    from scipy.stats import chi2

    from ftc_mj.estimation.setup import FilterSettings, gate_quantile

    default = FilterSettings.model_fields["pose_gate"].default
    assert gate_quantile(default) == float(chi2.isf(default, 2))
    assert gate_quantile(None) == math.inf
    for p in np.logspace(-12, -0.01, 200):
        assert math.isclose(gate_quantile(float(p)), float(chi2.isf(p, 2)), rel_tol=1e-14, abs_tol=0.0)


def test_listing_the_studies_imports_no_scipy() -> None:
    """``ftc-mj studies`` reaches the paper's verdicts, whose binomial interval imports ``scipy.stats`` (and
    with it SciPy's linear algebra and special functions) only when it computes one."""
    code = "from ftc_mj.cli import app\ntry:\n    app(['studies'])\nexcept SystemExit:\n    pass"
    assert not {"scipy.linalg", "scipy.special"} & loaded_after(code)
