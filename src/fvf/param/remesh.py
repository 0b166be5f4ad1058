r"""Triangle meshes remeshed at the quad scale: quads that do not depend on the input's triangles.

A seamless parameterization is only as good as the triangles it is fitted on: CAD
exports carry slivers and fans with one vertex of valence 60 (the curvature-aligned
field gets a cone of index beyond ±1/2 there), coarse files have fewer triangles than
quads. QuadWild and QuadriFlow therefore remesh the input before designing the field;
:func:`fvf.quad_mesh` does the same first when the input's triangles are thin
(:func:`needs_remesh`: slivers), and after the input itself failed when they are only
coarse (a coarse but well-shaped input, such as a decimated scan, often meshes as it is).

Two remeshers:

* ``"pymeshlab"`` (the optional extra ``[remesh]``; MeshLab is GPL-3.0): isotropic
  explicit remeshing (split, collapse, flip, tangential smoothing, reprojection) to the
  edge length :data:`REMESH_FRACTION` · h, keeping the edges whose dihedral angle exceeds
  the crease angle as edges (the features) and the boundary. Along a kept crease it can
  leave zero-area triangles whose three vertices lie on the crease line (on thin-walled
  CAD parts, 5–70 of them); each is removed and the triangle across its longest side split
  at its apex (:func:`fvf.split_t_junctions`), which keeps the surface, and where some lie
  in a row (a pocket of collinear triangles) the remeshing runs again at a slightly other
  edge length (:data:`RETARGET`);
* ``"subdivide"`` (NumPy only, the fallback): midpoint subdivision of every triangle into
  four until the mean edge is at most :data:`REMESH_FRACTION` · h. It keeps the surface
  and its features exactly but improves no triangle's shape.

The remeshed surface is a new :class:`fvf.TriMesh`; quad vertices made on it are put
back on the input surface at their closest points
(:func:`fvf.param.quad_folds.closest_surface_points`).
"""

from __future__ import annotations

import contextlib
import io
import os
from typing import Literal

import numpy as np

from ..errors import MeshError, QuadExtractionError
from ..mesh.defects import zero_area_faces
from ..mesh.repair import split_t_junctions
from ..mesh.shapes import midpoint_subdivision
from ..mesh.trimesh import DEGENERATE_AREA_RTOL, TriMesh

__all__ = [
    "REMESH_FRACTION",
    "FINE_REMESH_FRACTION",
    "Remesher",
    "available_remesher",
    "needs_remesh",
    "remesh_for_quads",
    "min_angles",
]

Remesher = Literal["auto", "pymeshlab", "subdivide"]
#: Remeshed edge length as a fraction of the quad edge length h. Measured against 0.5 on
#: the 40 random CSG parts of ``benchmarks/random_parts.py`` in runs beside each other:
#: 34 vs 33 valid, 443 vs 662 CPU s (0.85: 33 valid, 354 s).
REMESH_FRACTION = 0.7
#: The edge length of a second, finer remeshing (× h), whose attempts with the features as
#: iso-lines follow those on the first (:func:`fvf.quad_mesh`): thin fins and walls that
#: need it (the random parts: 35 valid with them, 34 without, 499 vs 453 CPU s).
FINE_REMESH_FRACTION = 0.5
#: pymeshlab's remeshing of an input with more than PRE_DECIMATE times the triangles it
#: makes (about 2.31 A / ℓ² at edge ℓ) first decimates the input to PRE_DECIMATE_TO times
#: them by MeshLab's quadric edge collapse with planar quadrics, normals and topology kept
#: (a random CSG part midpoint-subdivided to 418k triangles, remeshed at 0.7 h: 12 s
#: instead of 85 s, the same faces within 0.5 %, distance to the input 0.06–0.07 h both,
#: the same χ and sharp edges within 2 %): each remeshing iteration reprojects onto the
#: input, which then costs with its triangles, not the quads'.
PRE_DECIMATE = 8.0
PRE_DECIMATE_TO = 4.0
#: Edge lengths (× the asked one) pymeshlab's remeshing is run at again while zero-area
#: triangles are left (a random thin-walled box: 3 left at the asked length, none at 1.02×).
RETARGET = (1.02, 0.98)
#: The input is remeshed first when its mean edge exceeds this fraction of h (too coarse:
#: fewer than about two triangles per quad)…
COARSE_FRACTION = 1.0
#: … or when more than this fraction of its triangles have an angle below SLIVER_DEGREES.
SLIVER_SHARE = 0.01
SLIVER_DEGREES = 10.0


def available_remesher() -> str:
    """``"pymeshlab"`` when the ``[remesh]`` extra is installed, else ``"subdivide"``."""
    try:
        import pymeshlab  # noqa: F401
    except ImportError:
        return "subdivide"
    return "pymeshlab"


def min_angles(mesh: TriMesh) -> np.ndarray:
    """Smallest corner angle of each triangle in degrees, float64 (m,)."""
    P = mesh.vertices[mesh.faces]
    a = np.linalg.norm(P[:, 1] - P[:, 2], axis=1)
    b = np.linalg.norm(P[:, 2] - P[:, 0], axis=1)
    c = np.linalg.norm(P[:, 0] - P[:, 1], axis=1)
    s = np.sort(np.stack([a, b, c], axis=1), axis=1)  # the smallest angle faces s[:, 0]
    cos = (s[:, 1] ** 2 + s[:, 2] ** 2 - s[:, 0] ** 2) / np.maximum(2 * s[:, 1] * s[:, 2], 1e-300)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def needs_remesh(mesh: TriMesh, edge_length: float) -> str | None:
    """Why ``mesh`` should be remeshed before quads of edge ``edge_length`` (or None)."""
    if mesh.mean_edge_length > COARSE_FRACTION * edge_length:
        return (
            f"its mean edge ({mesh.mean_edge_length:.3g}) is longer than "
            f"{COARSE_FRACTION} quad edges ({edge_length:.3g})"
        )
    share = float(np.mean(min_angles(mesh) < SLIVER_DEGREES))
    if share > SLIVER_SHARE:
        return f"{100 * share:.1f} % of its triangles have an angle below {SLIVER_DEGREES:g}°"
    return None


def remesh_for_quads(
    mesh: TriMesh,
    edge_length: float,
    *,
    crease_angle: float = 35.0,
    method: Remesher = "auto",
    fraction: float = REMESH_FRACTION,
) -> TriMesh:
    """``mesh`` remeshed for quads of edge length h (module docstring).

    Parameters
    ----------
    mesh : TriMesh
    edge_length : float
        The quad edge length h; triangles get edges of about ``fraction * h``.
    crease_angle : float
        Edges whose dihedral angle exceeds this many degrees stay edges (pymeshlab).
    method : {"auto", "pymeshlab", "subdivide"}
    fraction : float
        The triangles' edge length as a fraction of h (:data:`REMESH_FRACTION`;
        :func:`fvf.quad_mesh` also uses :data:`FINE_REMESH_FRACTION`).

    Returns
    -------
    TriMesh

    Raises
    ------
    QuadExtractionError
        The remesher failed or returned an invalid mesh (the message says which).
    """
    target = float(fraction) * float(edge_length)
    if method == "auto":
        method = "pymeshlab" if available_remesher() == "pymeshlab" else "subdivide"
    if method == "subdivide":
        V, F = mesh.vertices, mesh.faces
        while _mean_edge(V, F) > target and F.shape[0] < 4_000_000:
            V, F = midpoint_subdivision(V, F)
    else:
        V, F = _pymeshlab_without_flat_faces(mesh, target, crease_angle)
    try:
        return TriMesh(V, F)
    except MeshError as exc:
        raise QuadExtractionError(f"the {method} remeshing gave an invalid mesh: {exc}") from exc


def _mean_edge(V: np.ndarray, F: np.ndarray) -> float:
    return float(np.linalg.norm(V[F] - V[np.roll(F, -1, axis=1)], axis=2).mean())


def _pymeshlab_without_flat_faces(
    mesh: TriMesh, target: float, crease_angle: float
) -> tuple[np.ndarray, np.ndarray]:
    """pymeshlab's remeshing with its zero-area triangles split away
    (:func:`fvf.split_t_junctions`); where some are left (several in a row along a crease),
    the remeshing once more at each edge length of :data:`RETARGET` × ``target``."""
    for scale in (1.0, *RETARGET):
        V, F = _pymeshlab_remesh(mesh, scale * target, crease_angle)
        fixed = split_t_junctions(V, F)
        V, F = fixed.vertices, fixed.faces
        if not zero_area_faces(V, F, DEGENERATE_AREA_RTOL).any():
            break
    return V, F


def _pymeshlab_remesh(
    mesh: TriMesh, target: float, crease_angle: float
) -> tuple[np.ndarray, np.ndarray]:
    try:
        import pymeshlab
    except ImportError as exc:  # pragma: no cover - checked by available_remesher
        from ..errors import MissingExtraError

        raise MissingExtraError("remeshing needs pymeshlab: pip install 'fvf[remesh]'") from exc
    length = getattr(pymeshlab, "PureValue", None) or pymeshlab.AbsoluteValue
    ms = pymeshlab.MeshSet()
    made = 2.31 * mesh.total_area / (target * target)  # the remeshing's triangles, about
    try:
        ms.add_mesh(pymeshlab.Mesh(mesh.vertices, mesh.faces.astype(np.int32)))
        with _quiet():
            if mesh.n_faces > PRE_DECIMATE * made:
                ms.meshing_decimation_quadric_edge_collapse(
                    targetfacenum=int(PRE_DECIMATE_TO * made),
                    planarquadric=True,
                    preservenormal=True,
                    preservetopology=True,
                )
            ms.meshing_isotropic_explicit_remeshing(
                targetlen=length(target),
                featuredeg=float(crease_angle),
                maxsurfdist=length(0.5 * target),
                iterations=10,
            )
        m = ms.current_mesh()
        V = np.array(m.vertex_matrix(), dtype=np.float64)
        F = np.array(m.face_matrix(), dtype=np.int64)
    except Exception as exc:  # pymeshlab raises its own PyMeshLabException and others
        raise QuadExtractionError(f"pymeshlab's remeshing failed: {exc}") from exc
    used = np.unique(F)
    remap = np.full(V.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    return V[used], remap[F]


@contextlib.contextmanager
def _quiet():
    """Silence a C++ library's writes to standard output and error (file descriptors 1, 2)."""
    saved = []
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        for fd in (1, 2):
            saved.append((fd, os.dup(fd)))
            os.dup2(null, fd)
        os.close(null)
    except (OSError, io.UnsupportedOperation):  # pragma: no cover - no real descriptors
        pass
    try:
        yield
    finally:
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
