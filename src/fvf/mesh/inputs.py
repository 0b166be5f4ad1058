"""Checking and converting user arrays: PL functions, PC functions, PC vector fields.

Every public function of fvf passes its array arguments through these, so a wrong shape,
a NaN or a normal component is reported the same way everywhere.

Tangency policy (documented in ``docs/conventions.md``): a per-face field with a normal
component larger than :func:`tangent_rtol` times the field's largest vector is projected
onto the face planes and a :class:`~fvf.errors.NonTangentFieldWarning` is emitted
(``tangent="project"``, the default of the operators), or rejected with
:class:`~fvf.errors.FieldShapeError` (``tangent="raise"``). The tolerance follows the
precision of the array given: :data:`TANGENT_RTOL` for float64, more for float32 or
float16 fields, whose own rounding leaves a normal component of that size.

Scalar options (counts, positive numbers, limits, policy names) are checked here too
(:func:`as_count`, :func:`as_positive`, :func:`as_growth_limit`,
:func:`check_tangent_policy`), so a bad option raises :class:`~fvf.errors.ParameterError`
the same way everywhere.
"""

from __future__ import annotations

import numbers
import warnings
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from ..errors import (
    DirectionCountError,
    FieldShapeError,
    FieldValueError,
    NonTangentFieldWarning,
    ParameterError,
    format_indices,
)
from .convert import takes_mesh

if TYPE_CHECKING:
    from .trimesh import TriMesh

__all__ = [
    "as_vertex_function",
    "as_face_function",
    "as_face_field",
    "as_direction_count",
    "TANGENT_RTOL",
    "tangent_rtol",
    "check_tangent_policy",
    "as_count",
    "as_positive",
    "as_growth_limit",
    "max_row_norm",
    "unit_scale",
    "real_array",
    "check_finite",
]

#: Normal components up to this times max_t |u_t| count as round-off and are kept
#: (float64 fields; see :func:`tangent_rtol` for other precisions).
TANGENT_RTOL = 1e-8

TangentPolicy = Literal["project", "raise", "ignore"]
_TANGENT_POLICIES = ("project", "raise", "ignore")


def tangent_rtol(dtype: npt.DTypeLike) -> float:
    """The relative normal component that counts as round-off for a field of ``dtype``:
    :data:`TANGENT_RTOL` for float64 (and integers), ``64 eps`` for coarser floats
    (7.6e-6 for float32), whose projection onto a face leaves that much."""
    dtype = np.dtype(dtype)
    if np.issubdtype(dtype, np.floating):
        return max(TANGENT_RTOL, 64.0 * float(np.finfo(dtype).eps))
    return TANGENT_RTOL


def check_tangent_policy(tangent: str) -> str:
    """``tangent`` if it is one of "project", "raise", "ignore"; else ParameterError."""
    if not isinstance(tangent, str) or tangent not in _TANGENT_POLICIES:
        raise ParameterError(
            f"tangent must be one of {', '.join(map(repr, _TANGENT_POLICIES))}; got {tangent!r}"
        )
    return tangent


def _is_number(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def as_count(value: Any, name: str, minimum: int = 0) -> int:
    """An integer option (steps, k, iterations): a Python or NumPy integer, or a float
    with an integer value, at least ``minimum``; else :class:`ParameterError`."""
    number = _is_number(value) and bool(np.isfinite(float(value)))
    whole = number and float(value) == int(value)
    if not whole or int(value) < minimum:
        why = " (a count cannot be fractional)" if number and not whole else ""
        raise ParameterError(f"{name} must be an integer >= {minimum}; got {value!r}{why}")
    return int(value)


def as_positive(value: Any, name: str, allow_inf: bool = False) -> float:
    """A positive number option (a step, a tolerance, a scale): finite unless
    ``allow_inf``; else :class:`ParameterError`."""
    x = float(value) if _is_number(value) else np.nan
    if not (x > 0 and (allow_inf or np.isfinite(x))):
        kind = "a positive number" + ("" if allow_inf else " (finite)")
        raise ParameterError(f"{name} must be {kind}; got {value!r}")
    return x


def as_growth_limit(value: Any) -> float:
    """A flow's ``growth_limit``: a number >= 1 or inf (every norm growth bound is >= 1,
    so a smaller limit would always warn); else :class:`ParameterError`."""
    x = float(value) if _is_number(value) else np.nan
    if not x >= 1.0:
        raise ParameterError(
            f"growth_limit must be a number >= 1 (the largest norm growth to allow "
            f"silently), or np.inf to never warn; got {value!r}"
        )
    return x


def max_row_norm(a: np.ndarray) -> float:
    """max_i |a_i| of a (k, d) array, computed without overflow or underflow (a field of
    magnitude 1e200 has norms 1e200, not inf)."""
    if a.size == 0:
        return 0.0
    big = float(np.abs(a).max())
    if not 0.0 < big < np.inf:
        return big
    b = a / big
    return big * float(np.sqrt(np.einsum("ij,ij->i", b, b).max()))


def unit_scale(a: np.ndarray) -> float:
    """A power of two near max |a| (1.0 for an all-zero or non-finite array).

    Dividing by it brings entries to [0.5, 1) exactly (no rounding), so products and
    norms of fields of any magnitude (1e-200 to 1e200) neither overflow nor underflow;
    results are multiplied back at the end.
    """
    big = float(np.abs(a).max()) if a.size else 0.0
    if not 0.0 < big < np.inf:
        return 1.0
    return float(2.0 ** np.floor(np.log2(big)))


def real_array(a: npt.ArrayLike, name: str) -> np.ndarray:
    """``a`` as float64, any shape.

    Raises
    ------
    FieldShapeError
        Ragged nested lists, or not real numbers (``name`` in the message).
    """
    return _real_array_and_dtype(a, name)[0]


def _real_array_and_dtype(a: npt.ArrayLike, name: str) -> tuple[np.ndarray, np.dtype]:
    try:
        a = np.asarray(a)
    except ValueError as exc:  # ragged nested lists
        raise FieldShapeError(f"{name} could not be read as an array ({exc}).") from exc
    if a.dtype == object or not (
        np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)
    ):
        raise FieldShapeError(f"{name} must be a real numeric array; got dtype {a.dtype}.")
    return np.asarray(a, dtype=np.float64), a.dtype


def check_finite(a: np.ndarray, name: str, what: str) -> None:
    """Raise :class:`FieldValueError` naming the rows of ``a`` (``what``: "vertices",
    "faces", ...) that hold NaN or inf."""
    bad = ~np.isfinite(a)
    if bad.any():
        idx = np.flatnonzero(bad.reshape(a.shape[0], -1).any(axis=1))
        raise FieldValueError(
            f"{name} has NaN or inf values at {what} {format_indices(idx)}. Fix: replace them "
            "(e.g. np.nan_to_num) or recompute the input."
        )


@takes_mesh
def as_vertex_function(
    mesh: TriMesh, f: npt.ArrayLike, name: str = "f", columns: bool = False
) -> np.ndarray:
    """Check a PL function: float64 (n,), or (n, k) when ``columns`` is true.

    Raises
    ------
    FieldShapeError
        Wrong length or dtype.
    FieldValueError
        Non-finite values (naming the vertices).
    """
    a = real_array(f, name)
    n = mesh.n_vertices
    ok = a.ndim == 1 and a.shape[0] == n
    if columns:
        ok = ok or (a.ndim == 2 and a.shape[0] == n)
    if not ok:
        want = f"({n},) or ({n}, k)" if columns else f"({n},)"
        raise FieldShapeError(
            f"{name} must be a function on the {n} vertices, shape {want}; got shape "
            f"{a.shape}. Fix: one value per vertex, in the order of mesh.vertices."
        )
    check_finite(a, name, "vertices")
    return a


@takes_mesh
def as_face_function(mesh: TriMesh, f: npt.ArrayLike, name: str = "f") -> np.ndarray:
    """Check a PC function: float64 (m,).

    Raises
    ------
    FieldShapeError
        Wrong length or dtype.
    FieldValueError
        Non-finite values (naming the faces).
    """
    a = real_array(f, name)
    m = mesh.n_faces
    if a.shape != (m,):
        raise FieldShapeError(
            f"{name} must be a function on the {m} faces, shape ({m},); got shape {a.shape}."
        )
    check_finite(a, name, "faces")
    return a


@takes_mesh
def as_face_field(
    mesh: TriMesh, u: npt.ArrayLike, name: str = "v", tangent: TangentPolicy = "project"
) -> np.ndarray:
    """Check a PC vector field: float64 (m, 3), one ambient vector per face.

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, (m, 3) or face-major flattened (3m,)
    name : str
        Used in messages.
    tangent : {"project", "raise", "ignore"}
        What to do with a normal component above :func:`tangent_rtol` of ``u``'s dtype
        (relative to the largest vector): project it away with a
        :class:`~fvf.errors.NonTangentFieldWarning`, raise, or keep it. A field of a
        coarser float type than float64 within that tolerance is projected silently (its
        rounding is not a normal component, but it would be one in float64).

    Returns
    -------
    ndarray, float64 (m, 3)

    Raises
    ------
    FieldShapeError
        Wrong shape or dtype, or (``tangent="raise"``) a normal component.
    FieldValueError
        Non-finite values (naming the faces).
    ParameterError
        ``tangent`` is not one of the three policies.
    """
    check_tangent_policy(tangent)
    a, dtype = _real_array_and_dtype(u, name)
    m = mesh.n_faces
    if a.shape == (3 * m,):
        a = a.reshape(m, 3)
    if a.shape != (m, 3):
        hint = (
            " (a vertex field? this needs one vector per face)"
            if a.shape[:1] == (mesh.n_vertices,)
            else ""
        )
        raise FieldShapeError(
            f"{name} must be a per-face vector field of shape ({m}, 3) or ({3 * m},); got "
            f"{a.shape}{hint}."
        )
    check_finite(a, name, "faces")
    if tangent == "ignore":
        return a
    N = mesh.face_normals
    normal = np.einsum("ij,ij->i", a, N)  # (m,)
    scale = max_row_norm(a)  # no overflow for fields of magnitude 1e200
    rtol = tangent_rtol(dtype)
    bad = np.abs(normal) > rtol * scale
    if not bad.any():
        if rtol > TANGENT_RTOL:  # a float32 (...) field: its rounding goes, silently, so
            a = a - normal[:, None] * N  # that the float64 result passes later checks
        return a
    idx = np.flatnonzero(bad)
    msg = (
        f"{name} has a normal component at faces {format_indices(idx)} (largest "
        f"{np.abs(normal).max():.3g}, relative {np.abs(normal).max() / scale:.3g})"
    )
    if tangent == "raise":
        raise FieldShapeError(msg + ". Fix: mesh.project_tangent(v).")
    warnings.warn(
        msg + "; it was projected onto the face planes. Pass mesh.project_tangent(v) "
        "to silence this.",
        NonTangentFieldWarning,
        stacklevel=3,
    )
    a = a - normal[:, None] * N
    return a


def as_direction_count(n: Any, name: str = "n") -> int:
    """Check the symmetry order N of an N-direction field: an integer >= 1.

    Integral floats (``4.0``) are accepted; booleans, fractions, strings and N < 1 are not.

    Raises
    ------
    DirectionCountError
        Naming the value and the fix.
    """
    ok = isinstance(n, int | np.integer) and not isinstance(n, bool | np.bool_)
    if not ok and isinstance(n, float | np.floating) and float(n).is_integer():
        n, ok = int(n), True
    if not ok or int(n) < 1:
        raise DirectionCountError(
            f"{name} (the number of directions of the field) must be an integer >= 1, e.g. "
            f"1 (vector), 2 (line), 4 (cross) or 6; got {n!r}."
        )
    return int(n)
