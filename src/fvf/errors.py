"""Typed errors and warnings raised by fvf.

Every user-facing error is a :class:`ValueError` subclass whose message names the
offending indices (at most a handful, then a count) and says how to fix the input.
Recoverable trouble is reported with :func:`warnings.warn` and one of the
:class:`FvfWarning` subclasses, never printed.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "FvfError",
    "MeshError",
    "MeshShapeError",
    "MeshIndexError",
    "NonFiniteError",
    "DegenerateFaceError",
    "UnreferencedVertexError",
    "NonManifoldError",
    "OrientationError",
    "FieldShapeError",
    "MeshReadError",
    "FlowOverflowError",
    "ParameterError",
    "FvfWarning",
    "NonTangentFieldWarning",
    "FlowGrowthWarning",
    "format_indices",
]


class FvfError(ValueError):
    """Base class of every error fvf raises on bad input."""


class MeshError(FvfError):
    """The vertices or faces given to :class:`fvf.TriMesh` are not a valid mesh."""


class MeshShapeError(MeshError):
    """Vertices or faces have the wrong shape or dtype."""


class MeshIndexError(MeshError):
    """A face refers to a vertex index outside ``[0, n)`` or repeats a vertex."""


class NonFiniteError(MeshError):
    """Vertex coordinates (or another input array) contain NaN or inf."""


class DegenerateFaceError(MeshError):
    """Some faces have zero area, so their gradient and normal are undefined."""


class UnreferencedVertexError(MeshError):
    """Some vertices belong to no face, so their vertex area is zero."""


class NonManifoldError(MeshError):
    """An edge is shared by more than two faces, or a vertex's faces form several fans."""


class OrientationError(MeshError):
    """Two faces sharing an edge traverse it in the same direction."""


class FieldShapeError(FvfError):
    """A function or vector field has the wrong shape, dtype, or non-finite values."""


class MeshReadError(FvfError):
    """A mesh file could not be parsed."""


class FlowOverflowError(FvfError, FloatingPointError):
    """A flow or exponential action cannot be computed in floating point: its values
    overflow, or the time is so long (|t| times the operator's norm) that the steps it
    needs underflow. Also a :class:`FloatingPointError`."""


class ParameterError(FvfError):
    """A scalar or option argument is invalid: a non-finite or out-of-range time, step,
    weight, tolerance or count, or an unknown option name (the message lists the valid
    ones)."""


class FvfWarning(UserWarning):
    """Base class of every warning fvf emits."""


class NonTangentFieldWarning(FvfWarning):
    """A per-face field had a normal component, which was projected away."""


class FlowGrowthWarning(FvfWarning):
    """A flow is estimated (or observed) to grow a function's norm beyond the limit."""


def user_stacklevel() -> int:
    """The ``stacklevel`` for :func:`warnings.warn` that points at the first frame outside
    the fvf package (the user's call), however deep inside fvf the warning is raised."""
    import sys
    from pathlib import Path

    package = str(Path(__file__).resolve().parent)
    frame, level = sys._getframe(1), 1  # the caller of user_stacklevel() is level 1
    while frame is not None and str(Path(frame.f_code.co_filename).resolve()).startswith(package):
        frame, level = frame.f_back, level + 1
    return level


def format_indices(idx, limit: int = 8) -> str:
    """Format an index list for an error message: the first few and a count.

    Parameters
    ----------
    idx : array_like of int, shape (k,)
        Offending indices.
    limit : int
        How many to print before summarising.

    Returns
    -------
    str
        For example ``"[3, 17, 42] (3 in all)"``.
    """
    idx = np.asarray(idx).ravel()
    shown = ", ".join(str(int(i)) for i in idx[:limit])
    more = ", ..." if idx.size > limit else ""
    return f"[{shown}{more}] ({idx.size} in all)"
