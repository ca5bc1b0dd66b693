"""The one place the compiled kernels get numba's ``njit`` from, with numba's optimisation level 2.

numba hands its ``NUMBA_OPT`` level (default 3) to LLVM. Without fastmath, LLVM may not reorder
floating-point operations at any level, so the level changes compile time, not results: the golden runs
(``benchmarks/golden.py``) are bitwise equal at 2 and 3, and the filter steps run at the same speed
(``benchmarks/bench_loop_split.py``), while the first run's compile of the UKF kernels drops by about a
quarter (``benchmarks/bench_first_run.py``). numba reads ``NUMBA_OPT`` once, when it is first imported,
so the level is set here, before that import, and only when the user has not set it: a process that
imported numba earlier, or sets ``NUMBA_OPT`` itself, compiles at its own level with the same results.

numba itself (≈ 1 s of imports with its lazy parts) is imported when a kernel is first called, not when
the kernels' modules are: :func:`njit` records each kernel as a :class:`LazyKernel`, and the first call of
any of them imports numba, hands every recorded kernel to numba's ``njit`` (with the same options: the
same compiled code, the same on-disk cache) and puts the dispatchers in place of the stand-ins in the
modules' namespaces, so that compiled kernels see compiled callees and Python callers call numba
directly from then on. A command that validates a config, lists scenarios or prints its help never
imports numba.
"""

from __future__ import annotations

import functools
import os
import sys
import time
from collections.abc import Callable
from typing import Any

os.environ.setdefault("NUMBA_OPT", "2")

__all__ = ["LazyKernel", "njit"]

_kernels: list[LazyKernel] = []
"""Every kernel recorded before numba was imported, in definition order."""
_numba_njit: list[Callable[..., Any]] = []
"""numba's ``njit`` once imported (one element)."""


class LazyKernel:
    """A function to be compiled by numba's ``njit`` with ``options``: a stand-in until the first call of any
    kernel, then (:func:`compile_all`) the numba dispatcher that replaced it everywhere it was imported."""

    def __init__(self, fn: Callable[..., Any], options: dict[str, Any]) -> None:
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self.options = options
        self.dispatcher: Any = None

    def __call__(self, *args: Any) -> Any:
        if self.dispatcher is None:
            compile_all()
        return self.dispatcher(*args)

    def __getattr__(self, name: str) -> Any:  # numba's attributes (``signatures``, ``stats``) of the dispatcher
        if name in ("dispatcher", "py_func", "options") or name.startswith("__"):
            raise AttributeError(name)
        if self.dispatcher is None:
            compile_all()
        return getattr(self.dispatcher, name)


class _CompileClock:
    """Wall-time spans (``perf_counter`` s) during which numba held its compiler lock in this process: compiling a
    kernel, or loading it from numba's disk cache. A listener of numba's event API (``numba.core.event``, the
    ``numba:compiler_lock`` events; nested acquisitions make one span)."""

    def __init__(self) -> None:
        self.depth = 0
        self.start = 0.0
        self.spans: list[tuple[float, float]] = []

    def notify(self, event: Any) -> None:
        if event.is_start:
            if self.depth == 0:
                self.start = time.perf_counter()
            self.depth += 1
        elif event.is_end:
            self.depth -= 1
            if self.depth == 0:
                self.spans.append((self.start, time.perf_counter()))

    def since(self, t0: float) -> float:
        """Seconds of the spans after ``t0`` (``perf_counter`` s), a span running now included."""
        now = time.perf_counter()
        done = sum(end - max(start, t0) for start, end in self.spans if end > t0)
        return done + (now - max(self.start, t0) if self.depth > 0 else 0.0)


_CLOCK = _CompileClock()


def compile_seconds_since(t0: float) -> float:
    """Wall seconds (from ``perf_counter`` time ``t0``) this process spent compiling numba kernels or loading them
    from numba's cache — what a solve's wall-time budget must not count: a first run after install compiles
    the kernels inside its first solves, and a budget that counted it would make that run fall back where
    every later run does not (a run must be a pure function of its config and seed). 0 before numba is used."""
    return _CLOCK.since(t0) if _numba_njit else 0.0


def compile_all() -> None:
    """Import numba, make every recorded kernel a numba dispatcher (compiled lazily by numba on its first
    call, from numba's cache when it has one) and replace the stand-ins by the dispatchers in the
    namespaces of the package's modules."""
    if not _numba_njit:
        from numba import njit as numba_njit
        from numba.core import event

        class CompileListener(event.Listener):
            def on_start(self, e: Any) -> None:
                _CLOCK.notify(e)

            def on_end(self, e: Any) -> None:
                _CLOCK.notify(e)

        event.register("numba:compiler_lock", CompileListener())
        _numba_njit.append(numba_njit)
    for k in _kernels:
        if k.dispatcher is None:
            k.dispatcher = _numba_njit[0](**k.options)(k.py_func)
    for name, module in list(sys.modules.items()):
        if name.startswith("ftc_mj.") and module is not None:
            space = vars(module)
            for attr, value in list(space.items()):
                if isinstance(value, LazyKernel) and value.dispatcher is not None:
                    space[attr] = value.dispatcher


def njit(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    """numba's ``njit(**options)`` as a decorator that does not import numba: the kernel is compiled on the
    first call of any kernel (module docstring); once numba is imported, numba's own decorator."""

    def decorate(fn: Callable[..., Any]) -> Any:
        if _numba_njit:
            return _numba_njit[0](**options)(fn)
        kernel = LazyKernel(fn, options)
        _kernels.append(kernel)
        return kernel

    return decorate
