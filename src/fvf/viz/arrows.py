"""Per-face tangent vectors as arrows: segments in the faces' planes, at an absolute scale.

An arrow of face t starts at the face's centroid c_t and ends at
``c_t + scale · (a_0 b_0 + a_1 b_1)``, where ``(b_0, b_1) = mesh.face_bases[t]`` is the
face's own orthonormal tangent frame and ``(a_0, a_1) = mesh.to_local(v)[t]`` the field's
coordinates in it. The arrow therefore lies in the face's plane (to round-off) and its
length is ``scale · |v_t|`` in the mesh's units: the scale is absolute, never normalised
per picture.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.trimesh import TriMesh

__all__ = ["DEFAULT_ARROW_LENGTH", "default_arrow_scale", "arrow_segments", "spread_faces"]

#: With the default scale the longest arrow is this many mean edge lengths long.
DEFAULT_ARROW_LENGTH = 1.0


@takes_mesh
def default_arrow_scale(mesh: TriMesh, field: npt.ArrayLike) -> float:
    """The default arrow scale: ``DEFAULT_ARROW_LENGTH · mean edge length / max_t |v_t|``.

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3)
        Tangent vector per face.

    Returns
    -------
    float
        Mesh units per unit of ``|v|`` (1.0 for a zero field).
    """
    v = as_face_field(mesh, field, "field")
    top = float(np.sqrt((v * v).sum(1)).max())
    return DEFAULT_ARROW_LENGTH * mesh.mean_edge_length / top if top > 0 else 1.0


@takes_mesh
def arrow_segments(mesh: TriMesh, field: npt.ArrayLike, scale: float | None = None) -> np.ndarray:
    """Start and end points of one arrow per face, built from the face's own basis.

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3) or (3m,)
        Tangent vector per face (a normal component is projected away with a
        :class:`~fvf.errors.NonTangentFieldWarning`).
    scale : float, optional
        Arrow length per unit of ``|v|``, in mesh units (absolute). Default
        :func:`default_arrow_scale`.

    Returns
    -------
    ndarray float64 (m, 2, 3)
        ``[t, 0]`` the centroid of face t, ``[t, 1]`` the arrow's tip
        ``c_t + scale · from_local(to_local(v))[t]``.
    """
    v = as_face_field(mesh, field, "field")
    if scale is None:
        scale = default_arrow_scale(mesh, v)
    start = np.asarray(mesh.face_centroids, dtype=float)
    tip = start + float(scale) * mesh.from_local(mesh.to_local(v))
    return np.stack([start, tip], axis=1)


@takes_mesh
def spread_faces(mesh: TriMesh, count: int | None) -> np.ndarray:
    """About ``count`` faces spread evenly over the surface (one per grid cell).

    Centroids are binned in a grid of cubes whose side is ``sqrt(total_area / count)``
    and the first face of each occupied cube is kept, so the picked faces cover the
    surface evenly whatever the tessellation's density. Deterministic.

    Parameters
    ----------
    mesh : TriMesh
    count : int or None
        Wanted number of faces; None or ``>= m`` returns every face.

    Returns
    -------
    ndarray int64 (k,)
        Sorted face ids.
    """
    m = mesh.n_faces
    if count is None or count >= m:
        return np.arange(m)
    if count < 1:
        return np.empty(0, dtype=np.int64)
    side = np.sqrt(mesh.total_area / count)
    cells = np.floor((mesh.face_centroids - mesh.vertices.min(0)) / side).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    return np.sort(first)
