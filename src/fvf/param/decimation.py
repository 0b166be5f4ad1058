r"""Inputs far finer than the quads, decimated to the quad scale before the field is designed.

A scan of 750,000 triangles asked for 20,000 quads has 37 triangles per quad. The cross
field, the factorization of the seamless parameterization and its mixed-integer rounding
all cost with the triangles, not the quads; a few triangles per quad describe the surface
at the quad scale as well. :func:`fvf.quad_mesh` therefore decimates a component with
more than :data:`MAX_TRIANGLES_PER_QUAD` triangles per quad of edge $h$ (quads
$\approx A / h^2$ for area $A$) to :data:`TRIANGLES_PER_QUAD` per quad, by quadric edge
collapse (Garland & Heckbert 1997: each collapse puts the new vertex where the summed
squared distance to the planes of the faces merged into it is least, so that the
decimated surface stays within a small fraction of a quad edge of the input), and runs its
attempts on the input surface there instead.

The decimated surface is used where the input would be, nowhere else: the quad vertices
made on it are put back on the input at their closest points, and the result is judged
against the input (:func:`fvf.param.quad_validity.check_quad_mesh`), as for a remeshed
surface. A component with sharp features is not decimated (:func:`fvf.quad_mesh` checks:
the collapses move creases). The decimation is the optional ``fast-simplification`` (the
``[remesh]`` extra, MIT); without it, or when its result is not a closed manifold with the
input's Euler characteristic and components and no zero-area triangle, the input is used
as it is.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshError
from ..mesh.defects import zero_area_faces
from ..mesh.repair import remove_unreferenced_vertices
from ..mesh.trimesh import DEGENERATE_AREA_RTOL, TriMesh

__all__ = [
    "MAX_TRIANGLES_PER_QUAD",
    "TRIANGLES_PER_QUAD",
    "triangles_per_quad",
    "decimated_for_quads",
]

#: A component with more triangles than this per quad asked is decimated
#: (:func:`decimated_for_quads`).
MAX_TRIANGLES_PER_QUAD = 16.0
#: Triangles per quad after the decimation (a surface remeshed at 0.7 h has about 4.7).
TRIANGLES_PER_QUAD = 8.0


def triangles_per_quad(mesh: TriMesh, edge_length: float) -> float:
    r"""Triangles of ``mesh`` per quad of edge ``edge_length``: $m h^2 / A$ (float)."""
    return mesh.n_faces * float(edge_length) ** 2 / max(float(mesh.total_area), 1e-300)


def decimated_for_quads(mesh: TriMesh, edge_length: float) -> TriMesh | None:
    """``mesh`` decimated to :data:`TRIANGLES_PER_QUAD` triangles per quad of edge h.

    Parameters
    ----------
    mesh : TriMesh
        One closed component.
    edge_length : float
        The quad edge length h, > 0.

    Returns
    -------
    TriMesh or None
        The decimated surface (vertices float64 (n', 3), faces int64 (m', 3)); None when
        ``mesh`` has at most :data:`MAX_TRIANGLES_PER_QUAD` triangles per quad, when
        ``fast-simplification`` is not installed, or when its result is not a closed
        manifold with ``mesh``'s Euler characteristic and components and no zero-area
        triangle (the input is then used as it is).
    """
    per_quad = triangles_per_quad(mesh, edge_length)
    if per_quad <= MAX_TRIANGLES_PER_QUAD:
        return None
    try:
        import fast_simplification
    except ImportError:
        return None
    target = int(np.ceil(mesh.n_faces * TRIANGLES_PER_QUAD / per_quad))
    try:
        V, F = fast_simplification.simplify(
            np.array(mesh.vertices, dtype=np.float64, order="C"),
            np.array(mesh.faces, dtype=np.int32, order="C"),
            target_count=target,
        )
    except Exception:  # the library's own errors: the input is used instead
        return None
    return _checked(mesh, np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64))


def _checked(mesh: TriMesh, V: np.ndarray, F: np.ndarray) -> TriMesh | None:
    """The decimated surface as a TriMesh, or None when it is not one the attempts can use
    in place of ``mesh`` (:func:`decimated_for_quads`)."""
    if F.shape[0] == 0:
        return None
    try:
        V, F, _ = remove_unreferenced_vertices(V, F)
        if zero_area_faces(V, F, DEGENERATE_AREA_RTOL).any():
            return None
        out = TriMesh(V, F)
    except MeshError:
        return None
    same = (out.euler_characteristic, out.n_components) == (
        mesh.euler_characteristic,
        mesh.n_components,
    )
    return out if same and out.is_closed and mesh.is_closed else None
