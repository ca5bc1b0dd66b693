"""The one place the compiled kernels get numba's ``njit`` from, with numba's optimisation level 2.

numba hands its ``NUMBA_OPT`` level (default 3) to LLVM. Without fastmath, LLVM may not reorder
floating-point operations at any level, so the level changes compile time, not results: the golden runs
(``benchmarks/golden.py``) are bitwise equal at 2 and 3, and the filter steps run at the same speed
(``benchmarks/bench_loop_split.py``), while the first run's compile of the UKF kernels drops by about a
quarter (``benchmarks/bench_first_run.py``). numba reads ``NUMBA_OPT`` once, when it is first imported,
so the level is set here, before that import, and only when the user has not set it: a process that
imported numba earlier, or sets ``NUMBA_OPT`` itself, compiles at its own level with the same results.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_OPT", "2")

from numba import njit  # noqa: E402  (after the level is set)

__all__ = ["njit"]
