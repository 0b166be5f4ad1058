"""Checking and converting user arrays: PL functions, PC functions, PC vector fields.

Every public function of fvf passes its array arguments through these, so a wrong shape,
a NaN or a normal component is reported the same way everywhere.

Tangency policy (documented in ``docs/conventions.md``): a per-face field with a normal
component larger than :data:`TANGENT_RTOL` times the field's largest vector is projected
onto the face planes and a :class:`~fvf.errors.NonTangentFieldWarning` is emitted
(``tangent="project"``, the default of the operators), or rejected with
:class:`~fvf.errors.FieldShapeError` (``tangent="raise"``).
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt

from ..errors import (
    DirectionCountError,
    FieldShapeError,
    FieldValueError,
    NonTangentFieldWarning,
    format_indices,
)

if TYPE_CHECKING:
    from .trimesh import TriMesh

__all__ = [
    "as_vertex_function",
    "as_face_function",
    "as_face_field",
    "as_direction_count",
    "TANGENT_RTOL",
]

#: Normal components up to this times max_t |u_t| count as round-off and are kept.
TANGENT_RTOL = 1e-8

TangentPolicy = Literal["project", "raise", "ignore"]


def _real_array(a: npt.ArrayLike, name: str) -> np.ndarray:
    try:
        a = np.asarray(a)
    except ValueError as exc:  # ragged nested lists
        raise FieldShapeError(f"{name} could not be read as an array ({exc}).") from exc
    if a.dtype == object or not (
        np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)
    ):
        raise FieldShapeError(f"{name} must be a real numeric array; got dtype {a.dtype}.")
    return np.asarray(a, dtype=np.float64)


def _check_finite(a: np.ndarray, name: str, what: str) -> None:
    bad = ~np.isfinite(a)
    if bad.any():
        idx = np.flatnonzero(bad.reshape(a.shape[0], -1).any(axis=1))
        raise FieldValueError(
            f"{name} has NaN or inf values at {what} {format_indices(idx)}. Fix: replace them "
            "(e.g. np.nan_to_num) or recompute the input."
        )


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
    a = _real_array(f, name)
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
    _check_finite(a, name, "vertices")
    return a


def as_face_function(mesh: TriMesh, f: npt.ArrayLike, name: str = "f") -> np.ndarray:
    """Check a PC function: float64 (m,).

    Raises
    ------
    FieldShapeError
        Wrong length or dtype.
    FieldValueError
        Non-finite values (naming the faces).
    """
    a = _real_array(f, name)
    m = mesh.n_faces
    if a.shape != (m,):
        raise FieldShapeError(
            f"{name} must be a function on the {m} faces, shape ({m},); got shape {a.shape}."
        )
    _check_finite(a, name, "faces")
    return a


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
        What to do with a normal component above :data:`TANGENT_RTOL` (relative to the
        largest vector): project it away with a
        :class:`~fvf.errors.NonTangentFieldWarning`, raise, or keep it.

    Returns
    -------
    ndarray, float64 (m, 3)

    Raises
    ------
    FieldShapeError
        Wrong shape or dtype, or (``tangent="raise"``) a normal component.
    FieldValueError
        Non-finite values (naming the faces).
    """
    a = _real_array(u, name)
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
    _check_finite(a, name, "faces")
    if tangent == "ignore":
        return a
    N = mesh.face_normals
    normal = np.einsum("ij,ij->i", a, N)  # (m,)
    scale = np.sqrt(np.einsum("ij,ij->i", a, a).max())
    bad = np.abs(normal) > TANGENT_RTOL * scale
    if bad.any():
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


def as_direction_count(n, name: str = "n") -> int:
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
