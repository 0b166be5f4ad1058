"""The declared quantities a :class:`~fvf.TriMesh` caches: names, memory, users.

A mesh never changes, so everything derived from it only (operators, per-face tables) is
computed once, on first use, and kept on the mesh (chapter §3.1: the operators are fixed
sparse matrices of the mesh). Those values are kept under a name declared here, as in
geometry-central's ``require``/``unrequire``: :meth:`fvf.TriMesh.cached` refuses a name
that is not in :data:`CACHED_QUANTITIES` (:class:`fvf.errors.UndeclaredCacheKeyError`),
:meth:`fvf.TriMesh.cache_info` lists what a mesh holds and its size in bytes, and
:meth:`fvf.TriMesh.clear_cache` drops values to free memory (the next call recomputes
them, bit for bit the same).

A cache key is a declared name, optionally followed by ``":"`` and a variant (the
parameters the value depends on): ``"face_mass:3"``, ``"connection_laplacian:knoppel:4"``.

Memory is given for a mesh of n vertices, m faces and E ≈ 1.5 m edges; a CSR operator
with k stored entries takes 8k bytes of values (16k complex) plus 4k (int32) or 8k (int64)
of column indices. The arrays that :class:`~fvf.TriMesh` validates at construction (edges,
face areas and normals, the 1-ring pattern) are its properties, not entries of this cache:
they stay for the mesh's life.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..errors import UndeclaredCacheKeyError

__all__ = ["CachedQuantity", "CACHED_QUANTITIES", "quantity_name", "value_nbytes"]


@dataclass(frozen=True)
class CachedQuantity:
    """One declared cached quantity.

    Attributes
    ----------
    name : str
        The key, or the part of it before the first ``":"``.
    description : str
        What the value is (shape, dtype, equation).
    memory : str
        Its size in terms of n, m and E.
    owner : str
        The function that builds it and hands it out (the one way to get it).
    users : str
        Who reads it through that function.
    variants : str
        What follows ``name:`` in the key, or ``""`` when the key is the name alone.
    """

    name: str
    description: str
    memory: str
    owner: str
    users: str
    variants: str = ""


def _declare(*quantities: CachedQuantity) -> Mapping[str, CachedQuantity]:
    return MappingProxyType({q.name: q for q in quantities})


_OPERATORS = "the operators, flows, design and spectral layers"

#: Every name :meth:`fvf.TriMesh.cached` accepts, with what it holds and costs.
CACHED_QUANTITIES: Mapping[str, CachedQuantity] = _declare(
    # -- mesh quantities
    CachedQuantity(
        "sorted_corners",
        "the corner order sorting each face's vertices, and the sorted faces; int64 (m, 3) x 2",
        "48m bytes",
        "fvf.mesh.geometry.sorted_corners",
        "fvf.calculus (I_V^F, I_F^V, grad), fvf.operators.directional and .divergence",
    ),
    CachedQuantity(
        "centered_vertices",
        "X minus its mean, float64 (n, 3)",
        "24n bytes",
        "fvf.mesh.geometry.centered_vertices",
        "extract_field and the brackets (fvf.operators), fvf.design.connection",
    ),
    CachedQuantity(
        "surface_aabb",
        "libigl's AABB tree of the triangles (igl.AABB) and the vertex and face arrays it "
        "is queried with, or None without libigl",
        "about 160m bytes in the tree (not counted by cache_info) + 24n + 24m",
        "fvf.param.quad_folds.surface_aabb",
        "closest_surface_points(exact=True) (quad vertices put back on the input, the gate)",
    ),
    CachedQuantity(
        "dihedral_angles",
        "the angle between the normals of each edge's two faces, degrees, float64 (E,)",
        "8E bytes",
        "fvf.param.features.dihedral_angles",
        "sharp_edges (quad features) and the pictures' shading (fvf.viz.ps_backend)",
    ),
    CachedQuantity(
        "surface_sample_tree",
        "a cKDTree of points spread over every triangle and the triangle of each, int64 (p,)",
        "about 56p bytes, p ≤ m · 1225 points (≈ 4m on a mesh of even triangles)",
        "fvf.param.quad_folds.surface_sample_tree",
        "closest_surface_points (quad fold repair, quad vertices put back on the input)",
    ),
    CachedQuantity(
        "vertex_vector_areas",
        "the area-weighted sum of the face normals at each vertex, float64 (n, 3)",
        "24n bytes",
        "fvf.mesh.geometry.vertex_vector_areas",
        "fvf.param.quad_folds (the surface's side under a quad), fvf.param.caps (domes)",
    ),
    CachedQuantity(
        "corner_angles",
        "the interior angle at each corner, float64 (m, 3)",
        "24m bytes",
        "fvf.mesh.geometry.corner_angles",
        "angle_defects: vertex indices (fvf.design.indices), fvf.design.holonomy",
    ),
    CachedQuantity(
        "vertex_normals",
        "unit vertex normals, float64 (n, 3)",
        "24n bytes",
        "fvf.mesh.curvature.vertex_normals",
        "principal_curvatures",
        "the weighting: ``max`` (Max's weights)",
    ),
    CachedQuantity(
        "principal_curvatures",
        "PrincipalCurvatures: k1, k2 (m,), d1, d2 (m, 3), shape operators (m, 2, 2)",
        "96m bytes",
        "fvf.mesh.curvature.principal_curvatures",
        "curvature-aligned design (fvf.design.alignment reads it when present)",
    ),
    # -- calculus (§3.1)
    CachedQuantity(
        "hat_gradients",
        "the hat-function gradients of eq. (27), float64 (m, 3, 3)",
        "72m bytes",
        "fvf.calculus.hat_gradients",
        "D^F_v, D^V_v and the brackets (fvf.operators), fvf.design, fvf.param, fvf.viz",
    ),
    CachedQuantity(
        "vertex_mass",
        "[A_V], diagonal CSR (n, n)",
        "n entries",
        "fvf.calculus.vertex_mass",
        _OPERATORS,
    ),
    CachedQuantity(
        "face_mass",
        "[A_F], diagonal CSR (m, m) or (3m, 3m)",
        "m or 3m entries",
        "fvf.calculus.face_mass",
        _OPERATORS,
        "the components per face, 1 or 3",
    ),
    CachedQuantity(
        "rotation",
        "J (eq. 27), block-diagonal CSR (3m, 3m)",
        "9m entries",
        "fvf.calculus.rotation",
        _OPERATORS,
    ),
    CachedQuantity(
        "face_to_vertex",
        "I_V^F, CSR (n, m)",
        "3m entries",
        "fvf.calculus.face_to_vertex",
        _OPERATORS,
    ),
    CachedQuantity(
        "vertex_to_face",
        "I_F^V, CSR (m, n)",
        "3m entries",
        "fvf.calculus.vertex_to_face",
        _OPERATORS,
    ),
    CachedQuantity(
        "grad", "grad (eqs. 27-28), CSR (3m, n)", "9m entries", "fvf.calculus.grad", _OPERATORS
    ),
    CachedQuantity(
        "div", "div (eq. 29), CSR (n, 3m)", "9m entries", "fvf.calculus.div", _OPERATORS
    ),
    CachedQuantity(
        "stiffness",
        "W, the cotangent matrix (eq. 30), CSR (n, n)",
        "n + 2E entries",
        "fvf.calculus.stiffness",
        _OPERATORS,
    ),
    CachedQuantity(
        "laplacian",
        "L = [A_V]^-1 W, CSR (n, n), sharing W's index arrays",
        "n + 2E values",
        "fvf.calculus.laplacian",
        _OPERATORS,
    ),
    # -- functional vector fields (§3.2)
    CachedQuantity(
        "D_V_scatter",
        "the map from per-corner derivatives to the data of D^V_v (eq. 36), CSR (n + 2E, 3m)",
        "9m entries",
        "fvf.operators.directional.D_V",
        "D_V and every operator built on it (brackets, flows)",
    ),
    # -- field design
    CachedQuantity(
        "connection_pairs",
        "coupled face pairs int64 (P, 2), transports complex128 (P,), weights float64 (P,)",
        "40P bytes (P: the interior edges for knoppel, about 6m 1-ring pairs for singer_wu)",
        "fvf.design.connection.connection_pairs",
        "the connection Laplacian, fvf.design.cancellation",
        "the kind, ``knoppel`` or ``singer_wu``",
    ),
    CachedQuantity(
        "connection_laplacian",
        "the complex connection Laplacian, CSR complex128 (m, m)",
        "m + 2P entries",
        "fvf.design.connection.connection_laplacian",
        "smoothest and constrained fields, N-fields, map-consistent design (fvf.design)",
        "the kind, then the symmetry order N when N > 1, then the holonomy smoothing",
    ),
    CachedQuantity(
        "real_connection_laplacian",
        "the real symmetric form of the connection Laplacian, CSR float64 (2m, 2m)",
        "4(m + 2P) entries",
        "fvf.design.connection.real_connection_laplacian",
        "ACAP and map-consistent design (fvf.design.commuting, fvf.design.symmetric)",
        "the kind",
    ),
    CachedQuantity(
        "connection_mass",
        "[A_F] of the connection Laplacian, diagonal CSR (m, m) or (2m, 2m)",
        "m or 2m entries",
        "fvf.design.connection.connection_mass",
        "the eigenproblems of fvf.design",
        "the size per face: 1 (complex form) or 2 (real form)",
    ),
    CachedQuantity(
        "circumcenters",
        "the circumcentre of each face, float64 (m, 3)",
        "24m bytes",
        "fvf.design.connection.sample_points",
        "fvf.design.connection (where knoppel fields are sampled)",
    ),
    CachedQuantity(
        "tangent_basis_matrix",
        "the face frames as CSR (3m, 2m)",
        "6m entries",
        "fvf.design.connection.tangent_basis_matrix",
        "fvf.design.commuting",
    ),
    CachedQuantity(
        "holonomy_rotations",
        "transport angles making the holonomy the smoothed angle defect, float64 (E,)",
        "8E bytes per length",
        "fvf.design.holonomy.holonomy_rotations",
        "the connection Laplacian with curvature_smoothing, fvf.param.frames",
        "the smoothing length (its repr) and a digest of the conformal log scale",
    ),
    # -- geodesic distances
    CachedQuantity(
        "edge_graph",
        "the edge graph weighted by length, CSR (n, n)",
        "2E entries",
        "fvf.spectral.evaluation.geodesic_distances",
        "geodesic_distances(method='edges'), the correspondence errors",
    ),
    CachedQuantity(
        "unfolded_graph",
        "the edge graph plus the unfolded diagonals of face pairs, CSR (n, n)",
        "at most 4E entries",
        "fvf.spectral.evaluation.geodesic_distances",
        "geodesic_distances(method='unfolded'), the correspondence errors",
    ),
    CachedQuantity(
        "heat_geodesic_solver",
        "the two sparse LU factorizations of the heat method, with grad and grad^T [A_F]",
        "the LU factors (their fill-in, not counted by cache_info) plus 18m entries",
        "fvf.spectral.evaluation.geodesic_distances",
        "geodesic_distances(method='heat')",
    ),
)


def quantity_name(key: str) -> str:
    """The declared name of a cache key (the part before the first ``":"``).

    Raises
    ------
    UndeclaredCacheKeyError
        The name is not in :data:`CACHED_QUANTITIES`.
    """
    name = key.split(":", 1)[0]
    if name not in CACHED_QUANTITIES:
        raise UndeclaredCacheKeyError(
            f"{key!r} names no declared cached quantity ({name!r} is not one of "
            f"{sorted(CACHED_QUANTITIES)}). Fix: declare it in fvf.mesh.cache."
            "CACHED_QUANTITIES (name, what it holds, its memory, its users), or use a "
            "declared name followed by ':' and the variant."
        )
    return name


def value_nbytes(value: Any) -> int:
    """Bytes of the numpy and scipy arrays a cached value holds (each buffer once).

    Walks tuples, lists, dict values and instance attributes (not into meshes); a view
    counts its base array. Objects that keep memory out of Python's sight (sparse LU and
    Cholesky factorizations) count as zero, so this is a lower bound for them.
    """
    from .trimesh import TriMesh

    seen: set[int] = set()

    def walk(x: Any, depth: int) -> int:
        if isinstance(x, np.ndarray):
            while isinstance(x.base, np.ndarray):
                x = x.base
            if id(x) in seen:
                return 0
            seen.add(id(x))
            return int(x.nbytes)
        if sp.issparse(x):
            parts = ("data", "indices", "indptr", "offsets", "coords")
            return sum(walk(getattr(x, p), depth) for p in parts if hasattr(x, p))
        if depth > 4 or isinstance(x, (TriMesh, str, bytes)):
            return 0
        if isinstance(x, (tuple, list)):
            return sum(walk(v, depth + 1) for v in x)
        if isinstance(x, dict):
            return sum(walk(v, depth + 1) for v in x.values())
        attributes = getattr(x, "__dict__", None)
        return sum(walk(v, depth + 1) for v in attributes.values()) if attributes else 0

    return walk(value, 0)
