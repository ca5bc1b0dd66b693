"""Compiled (numba) cores of the FDI filters: one call per filter step.

Why: a filter step is a few hundred flops on 5x5 matrices; in numpy it is dominated by the overhead of
some fifty small array calls. Here the whole step — predict, update, gating, symmetrising, divergence
check, reset, covariance repair and, for an IMM, mixing, mode probabilities and combination — is one
compiled call on preallocated buffers.

Modules, one concept each: :mod:`.layout` (the buffers), :mod:`.generated` (the kinematic model,
generated from the single CasADi definition), :mod:`.linalg` (5x5 linear algebra), :mod:`.kalman`
(UKF/EKF predict and update of a bank), :mod:`.bank` (what the steps share), :mod:`.single` and
:mod:`.imm` (the whole steps). The numpy reference in ``tests/support/numpy_filters.py`` gives the same
maths in matrix form; the tests require agreement to round-off (BLAS and these loops sum in
different orders).

Compiled code is cached on disk (``cache=True``); no fastmath, so results are bit-for-bit reproducible
from run to run. ``error_model="numpy"``: a division by zero gives inf/NaN as in numpy (then a reset)
instead of raising. numba invalidates a cached function when its own file changes, not when a callee
in another file does: each module that calls the generated model carries its digest
(``MODEL_DIGEST``, rewritten by :mod:`ftc_mj.estimation.codegen`), and after a hand edit of a callee
(:mod:`.linalg`, :mod:`.kalman`, :mod:`.bank`) delete ``ftc_mj/estimation/kernels/__pycache__``.
"""
