"""Checks on what the components hand the loop: a non-finite number is a failure, not data.

A controller command or an estimator's state or covariance holding a NaN or an infinity would
otherwise flow on silently (the plant turns a NaN wheel-rate command into zero, the trace fills with
NaN and the run still ends ``ok``). :class:`NonFiniteOutput` ends the run instead (status ``failed``,
exit code 1, ``error_where`` naming the component). The checks only read the arrays (no arithmetic of
the run changes) and cost one ``np.isfinite`` over a few numbers per step.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import RunFailed


class BuildFailed(RunFailed):
    """A component of the run could not be built (its constructor raised); ``str()`` is one line with the
    exception and where it was raised."""


class NonFiniteOutput(RuntimeError):
    """A component returned a value that is not finite; ``where`` names the component and its method."""

    def __init__(self, message: str, where: str) -> None:
        super().__init__(message)
        self.where = where


def _method(component: Any, method: str) -> str:
    """``module.Class.method`` of the component that produced the value."""
    cls = type(component)
    return f"{cls.__module__}.{cls.__qualname__}.{method}"


def _shown(values: np.ndarray) -> str:
    """The values in one short line (at most 6 shown)."""
    flat = np.asarray(values, dtype=float).ravel()
    text = ", ".join(f"{v:.4g}" for v in flat[:6])
    return f"[{text}{', …' if flat.size > 6 else ''}]"


def check_command(omega: Any, t: float, kind: str, controller: Any) -> None:
    """Raise :class:`NonFiniteOutput` unless the wheel-rate command ``omega`` (rad/s) of the controller
    registered as ``kind`` is two finite real numbers (at ``t``, s)."""
    a = np.asarray(omega)
    if a.shape == (2,) and a.dtype.kind in "fiu" and np.isfinite(a).all():
        return
    what = _shown(a) if a.dtype.kind in "fiuc" and a.size else repr(omega)[:60]
    raise NonFiniteOutput(f"controller {kind!r} returned a wheel-rate command that is not two finite numbers: "
                          f"{what} at t = {t:.3f} s", f"controller {kind!r} ({_method(controller, 'solve')})")


def check_estimate(out: Any, t: float, kind: str, estimator: Any) -> None:
    """Raise :class:`NonFiniteOutput` unless the state ``out.x`` and covariance ``out.P`` of the estimator
    registered as ``kind`` are finite (at ``t``, s)."""
    for name, value in (("state", out.x), ("covariance", out.P)):
        a = np.asarray(value)
        if a.dtype.kind not in "fiu" or not np.isfinite(a).all():
            shown = _shown(a) if a.dtype.kind in "fiuc" and a.size else repr(value)[:60]
            raise NonFiniteOutput(f"estimator {kind!r} returned a non-finite {name} {shown} at t = {t:.3f} s",
                                  f"estimator {kind!r} ({_method(estimator, 'step')})")
