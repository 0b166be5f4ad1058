"""Midpoint (1-to-4) subdivision that keeps the surface: finer canvases for textures.

Every face is split into four coplanar faces, so a per-face field carries over exactly
(each child face keeps its parent's vector) and a PL function by linear interpolation.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.shapes import midpoint_subdivision
from ..mesh.trimesh import TriMesh

__all__ = ["subdivide"]


@takes_mesh
def subdivide(
    mesh: TriMesh, field: npt.ArrayLike | None = None, levels: int = 1
) -> tuple[TriMesh, np.ndarray | None, np.ndarray]:
    """Split every face into four at its edge midpoints, ``levels`` times.

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3), optional
        Per-face tangent field to carry over (children keep the parent's vector).
    levels : int
        Number of subdivisions (each multiplies the face count by 4).

    Returns
    -------
    fine : TriMesh
        ``n + E`` vertices (the old ones first, then one per edge midpoint) and ``4 m``
        faces per level; the same surface.
    fine_field : ndarray (4^levels m, 3) or None
    parent : ndarray int64 (4^levels m,)
        The original face of each fine face.
    """
    X, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    v = None if field is None else as_face_field(mesh, field, "field")
    parent = np.arange(F.shape[0])
    for _ in range(int(levels)):
        X, F = midpoint_subdivision(X, F)
        parent = np.tile(parent, 4)
    fine = TriMesh(X, F)
    return fine, (None if v is None else v[parent]), parent
