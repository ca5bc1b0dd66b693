"""A path's numbers as parameters of the path-following NLP: one IPOPT solver per path kind.

A draw of the benchmark has its own path (radius, direction, lobe, heading and offset of a line) and desired
speed; folded into the NLP as constants, each draw would be a new problem and a new IPOPT solver (≈ 4 s to
build and a 10 MB entry in the solver cache per draw). Here a built-in path is described by its *kind* (the
class) and a vector of numbers; the NLP is built once on a *symbolic twin* of the path, an instance of the same
class whose numbers are entries of the NLP's parameter vector, so ``geometry(s, casadi)`` runs the path's own
lines (one implementation of the geometry) on symbols. Every number is the one the numeric path holds (the
centre, the polar angle of the start, …, computed by the path's constructor), and the twin does the same
operations on it at evaluation time that the folded constants did at build time, so the NLP's values are those
of the problem with constants.

A path of another class (a plug-in reference) has no parameters: :func:`path_parameters` returns ``None`` and
the NLP folds its numbers in as before (one solver per path).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .reference import CircleReference, FigureEightReference, LineReference, Path


def _circle_numbers(c: CircleReference) -> list[float]:
    """``[centre x, centre y, radius, sign, theta0, psi0]`` (m, m, m, ±1, rad, rad)."""
    return [float(c.center[0]), float(c.center[1]), c.radius, c.sign, c.theta0, c.psi0]


def _circle_twin(p: Any) -> CircleReference:
    """A circle whose numbers are ``p[0:6]`` (the order of :func:`_circle_numbers`)."""
    c = CircleReference.__new__(CircleReference)
    c.center = (p[0], p[1])
    c.radius, c.sign, c.theta0, c.psi0 = p[2], p[3], p[4], p[5]
    return c


def _line_numbers(ln: LineReference) -> list[float]:
    """``[x0, y0, psi0, cos psi0, sin psi0]`` (m, m, rad, 1, 1)."""
    return [ln.x0, ln.y0, ln.psi0, ln.cos0, ln.sin0]


def _line_twin(p: Any) -> LineReference:
    """A line whose numbers are ``p[0:5]`` (the order of :func:`_line_numbers`)."""
    ln = LineReference.__new__(LineReference)
    ln.x0, ln.y0, ln.psi0, ln.cos0, ln.sin0 = p[0], p[1], p[2], p[3], p[4]
    return ln


def _figure8_numbers(f: FigureEightReference) -> list[float]:
    """The two lobes' circle numbers and the lap length (m)."""
    return [*_circle_numbers(f.lobes[0]), *_circle_numbers(f.lobes[1]), f.lap_length]


def _figure8_twin(p: Any) -> FigureEightReference:
    """A figure-eight whose numbers are ``p[0:13]`` (the order of :func:`_figure8_numbers`)."""
    f = FigureEightReference.__new__(FigureEightReference)
    f.lobes = (_circle_twin(p[0:6]), _circle_twin(p[6:12]))
    f.lap_length = p[12]
    return f


_KINDS: dict[type, tuple[int, Callable[[Any], list[float]], Callable[[Any], Path]]] = {
    CircleReference: (6, _circle_numbers, _circle_twin),
    LineReference: (5, _line_numbers, _line_twin),
    FigureEightReference: (13, _figure8_numbers, _figure8_twin),
}
"""Path class → (number of parameters, its numbers, its symbolic twin)."""


def path_kind(path: Path) -> str | None:
    """The kind of ``path`` whose numbers are NLP parameters (its class name), ``None`` for a path without
    parameters (the NLP folds its numbers in)."""
    return type(path).__name__ if type(path) in _KINDS else None


def path_parameters(path: Path) -> np.ndarray | None:
    """The numbers of ``path`` in the order its symbolic twin reads them; ``None`` for a path without
    parameters."""
    entry = _KINDS.get(type(path))
    return None if entry is None else np.array(entry[1](path), dtype=float)


def parameter_count(path: Path) -> int:
    """How many NLP parameters ``path`` takes (0 for a path without parameters)."""
    entry = _KINDS.get(type(path))
    return 0 if entry is None else entry[0]


def symbolic_path(path: Path, p: Any) -> Path:
    """The twin of ``path``'s kind whose numbers are the symbols ``p`` (``parameter_count(path)`` of them), or
    ``path`` itself when it has no parameters."""
    entry = _KINDS.get(type(path))
    return path if entry is None else entry[2](p)
