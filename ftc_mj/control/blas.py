"""Numpy's BLAS threads: one, for the small dense MPC matrices and for reproducible round-off."""

from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

from ..lazy import lazy_module

ca = lazy_module("casadi")


def limit_blas_threads(n: int = 1) -> bool:
    """Set numpy's OpenBLAS thread count (process-wide) to ``n``; True if it could be set.

    The MPC matrices are ~100x150: multithreaded BLAS only adds synchronisation (much slower RTI steps on
    a loaded machine). Equivalent to ``OPENBLAS_NUM_THREADS=1`` but works after numpy has been imported.

    It also makes runs deterministic: CasADi's bundled OpenBLAS (under IPOPT's MUMPS) with two threads
    gives round-off that differs from call to call, which a saturated closed loop amplifies to different
    trajectories. CasADi loads that library lazily with its IPOPT plugin, so it is loaded here first; the
    plugin then shares this (single-threaded) instance. SciPy's OpenBLAS (its LAPACK, which the certified
    QP calls) is loaded here too for the same reason: :mod:`ftc_mj.lazy` imports SciPy only on first use.
    """
    import ctypes

    ok = False
    try:
        bundled = Path(ca.__file__).parent / "libcasadi-tp-openblas.so.0"
        if bundled.is_file():
            ctypes.CDLL(str(bundled), mode=ctypes.RTLD_GLOBAL)
    except OSError:
        pass
    load_scipy_openblas()
    try:
        with open("/proc/self/maps") as fh:
            libs = {ln.split()[-1] for ln in fh if "openblas" in ln.lower() and "/" in ln}
    except OSError:
        return False
    for path in libs:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for name in ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
                     "openblas_set_num_threads64_", "openblas_set_num_threads"):
            fn = getattr(lib, name, None)
            if fn is not None:
                fn(ctypes.c_int(n))
                ok = True
                break
    return ok


@functools.cache
def single_thread_blas() -> bool:
    """:func:`limit_blas_threads` to one thread, once per process (what it returned): every run starts with it
    (:func:`ftc_mj.sim.cache.begin_run`), the controller-less ones too — an agent's run in the Gymnasium
    environment steps the diagnoser, whose shape fit factors a 300-sample covariance; with a BLAS thread per core
    beside another process that took 165 ms instead of 2 ms, and threaded round-off need not repeat."""
    return limit_blas_threads(1)


def load_scipy_openblas() -> None:
    """Load SciPy's own OpenBLAS (the certified QP's LAPACK; SciPy is imported lazily) now, so that
    :func:`limit_blas_threads` limits it too (else ``dpotrf`` spins threads: ~1 s a solve).

    A wheel's SciPy ships it in ``scipy.libs/``: loading that file with ``ctypes`` is the same library
    object SciPy's LAPACK module links to when it is imported later (the dynamic loader keeps one copy per
    file), without importing ``scipy.linalg`` (≈ 0.1–0.2 s of a short run's start-up). A SciPy built
    against another BLAS (no ``scipy.libs/``) is imported as before."""
    import ctypes

    spec = importlib.util.find_spec("scipy")
    if spec is None:
        return
    found = False
    for folder in spec.submodule_search_locations or ():
        for lib in sorted((Path(folder).parent / "scipy.libs").glob("libscipy_openblas*.so*")):
            try:
                ctypes.CDLL(str(lib))
                found = True
            except OSError:
                continue
    if not found:
        try:
            import scipy.linalg.lapack  # noqa: F401
        except ImportError:
            pass
