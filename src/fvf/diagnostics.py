"""A validation report for a mesh that may be broken: what ``fvf info`` prints.

:class:`fvf.TriMesh` stops at the first problem; :func:`mesh_report` collects what can be
said about arbitrary vertex and face arrays without raising, so a user sees every problem
(with indices and the fix) at once.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .errors import FvfError, format_indices
from .mesh import TriMesh, _validate_arrays
from .repair import remove_unreferenced_vertices

__all__ = ["mesh_report", "NEEDLE_ANGLE_DEG"]

#: Faces with a corner angle below this are reported as needles.
NEEDLE_ANGLE_DEG = 1.0


def _corner_angles(X: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Corner angles in degrees, (m, 3); NaN for degenerate corners."""
    P = X[F]
    out = np.empty(F.shape)
    for i in range(3):  # the three corners, vectorized over faces
        a = P[:, (i + 1) % 3] - P[:, i]
        b = P[:, (i + 2) % 3] - P[:, i]
        cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        with np.errstate(invalid="ignore"):
            out[:, i] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return out


def mesh_report(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> dict:
    """Everything checkable about a triangle mesh, without raising.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)

    Returns
    -------
    dict
        ``ok`` (bool: a TriMesh can be built as is), ``problems`` (list of one-line
        messages naming indices and fixes), and, where they could be computed:
        ``n_vertices``, ``n_faces``, ``unreferenced_vertices``, ``min_angle_deg``,
        ``needle_faces`` (count below :data:`NEEDLE_ANGLE_DEG`), ``closed``,
        ``components``, ``euler_characteristic``, ``genus``, ``boundary_loops``,
        ``orientation`` ("consistent" or the error), ``manifold``.
    """
    report: dict = {"ok": False, "problems": []}
    try:
        X, F = _validate_arrays(vertices, faces)
    except FvfError as exc:
        report["problems"].append(f"{type(exc).__name__}: {exc}")
        return report
    report["n_vertices"], report["n_faces"] = X.shape[0], F.shape[0]
    n = X.shape[0]
    X, F, kept = remove_unreferenced_vertices(X, F)
    unref = np.setdiff1d(np.arange(n), kept)
    report["unreferenced_vertices"] = int(unref.size)
    if unref.size:
        report["problems"].append(
            f"UnreferencedVertexError: vertices {format_indices(unref)} belong to no face. "
            "Fix: fvf.remove_unreferenced_vertices(V, F)."
        )
    angles = _corner_angles(X, F)
    report["min_angle_deg"] = float(np.nanmin(angles)) if np.isfinite(angles).any() else 0.0
    needles = np.flatnonzero(np.nan_to_num(angles, nan=0.0).min(axis=1) < NEEDLE_ANGLE_DEG)
    report["needle_faces"] = int(needles.size)
    if needles.size:
        report["needle_face_ids"] = needles[:20].tolist()
    try:
        mesh = TriMesh(X, F)
    except FvfError as exc:
        report["problems"].append(f"{type(exc).__name__}: {exc}")
        report["manifold"] = "NonManifold" not in type(exc).__name__
        return report
    report.update(
        ok=unref.size == 0,
        manifold=True,
        orientation="consistent",
        closed=mesh.is_closed,
        components=mesh.n_components,
        euler_characteristic=mesh.euler_characteristic,
        boundary_loops=mesh.n_boundary_loops,
    )
    if mesh.n_components == 1:
        report["genus"] = mesh.genus
    return report
