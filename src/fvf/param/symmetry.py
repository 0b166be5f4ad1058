r"""Symmetric quads: a cross field made consistent with a self-map, and the symmetry error.

A self-map φ of the mesh given as a vertex permutation π (e.g. a mirror symmetry) maps
each face t = (a, b, c) onto the face σ(t) with vertices (π a, π b, π c) (in either
orientation: a mirror reverses it). Its differential on t is the linear map dφ_t taking
t's edge vectors to σ(t)'s. A cross field u is made map-consistent by averaging, in the
power representation, each face's cross with the pushed-forward cross of its preimage:

.. math::

    z_s \leftarrow \frac{\hat z_s + \widehat{(d\varphi\, u)}_{s}}{2}, \qquad
    \hat z = z/|z|, \quad z = e^{4i\arg u},

repeated a few times (the average of a field and its image is invariant under an
involution after one step). The quad mesh of a map-consistent field is nearly symmetric;
:func:`quad_symmetry_error` measures how nearly: the distance from the image of each quad
vertex to the nearest quad vertex, in units of the mean quad edge length.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from ..errors import ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.nfield import NField, require_order
from ..mesh.trimesh import TriMesh

__all__ = ["face_map_from_vertex_map", "symmetrize_cross_field", "quad_symmetry_error"]


@takes_mesh
def face_map_from_vertex_map(mesh: TriMesh, vertex_map: npt.ArrayLike) -> np.ndarray:
    """σ (m,) int64: the face whose vertex set is the image of each face's under π.

    Raises :class:`fvf.ParameterError` when π is not a permutation or does not map faces
    onto faces.
    """
    pi = np.asarray(vertex_map, dtype=np.int64)
    n = mesh.n_vertices
    if pi.shape != (n,) or not np.array_equal(np.sort(pi), np.arange(n)):
        raise ParameterError(f"vertex_map must be a permutation of {n} vertices")
    key = np.sort(mesh.faces, axis=1)
    code = (key[:, 0] * n + key[:, 1]) * n + key[:, 2]
    img = np.sort(pi[mesh.faces], axis=1)
    icode = (img[:, 0] * n + img[:, 1]) * n + img[:, 2]
    order = np.argsort(code)
    pos = np.clip(np.searchsorted(code[order], icode), 0, code.size - 1)
    hit = code[order][pos] == icode
    if not hit.all():
        raise ParameterError(
            f"vertex_map does not map faces onto faces ({int((~hit).sum())} faces have no image)"
        )
    return order[pos]


def _pushforward(mesh: TriMesh, pi: np.ndarray, sigma: np.ndarray, u: np.ndarray) -> np.ndarray:
    """dφ_t u_t as a tangent vector of face σ(t), float64 (m, 3)."""
    X, F = mesh.vertices, mesh.faces
    E = np.stack([X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]]], axis=2)  # (m, 3, 2)
    Y = X[pi[F]]  # images of the corners, in t's corner order
    Ei = np.stack([Y[:, 1] - Y[:, 0], Y[:, 2] - Y[:, 0]], axis=2)
    G = np.einsum("mki,mkj->mij", E, E)
    rhs = np.einsum("mki,mk->mi", E, u)
    c = np.linalg.solve(G, rhs[..., None])[..., 0]  # u = E c
    v = np.einsum("mki,mi->mk", Ei, c)
    out = np.empty_like(v)
    out[sigma] = v
    return out


@takes_mesh
def symmetrize_cross_field(
    mesh: TriMesh, u: npt.ArrayLike, vertex_map: npt.ArrayLike, iterations: int = 2
) -> NField:
    """A cross field consistent with a self-map given by a vertex permutation.

    Parameters
    ----------
    mesh : TriMesh
    u : array_like (m, 3)
        A cross field (one representative per face).
    vertex_map : array_like (n,) int
        π: vertex i maps to vertex π[i] (an isometric involution such as a mirror for
        an exactly symmetric result).
    iterations : int
        Averaging rounds.

    Returns
    -------
    NField, float64 (m, 3), n = 4
        Unit representatives of the averaged cross field.
    """
    require_order(u, 4, "symmetrize_cross_field", "u")
    pi = np.asarray(vertex_map, dtype=np.int64)
    sigma = face_map_from_vertex_map(mesh, pi)
    v = as_face_field(mesh, u, "u")
    for _ in range(iterations):  # a couple of averaging rounds
        w = mesh.project_tangent(_pushforward(mesh, pi, sigma, v))
        z = mesh.to_complex(v) ** 4
        zw = mesh.to_complex(w) ** 4
        avg = z / np.maximum(np.abs(z), 1e-300) + zw / np.maximum(np.abs(zw), 1e-300)
        v = mesh.from_complex(np.exp(0.25j * np.angle(avg)))
    return NField(v, 4)


def quad_symmetry_error(
    vertices: npt.ArrayLike,
    quads: npt.ArrayLike,
    transform: Callable[[np.ndarray], npt.ArrayLike],
) -> tuple[float, float]:
    """(median, max) distance from transform(vertex) to the nearest quad vertex.

    In units of the mean quad edge length. ``transform`` maps (k, 3) points to (k, 3)
    points (e.g. a mirror ``lambda P: P * [-1, 1, 1]``).
    """
    V = np.asarray(vertices, dtype=np.float64)
    Q = np.asarray(quads, dtype=np.int64)
    edge = np.linalg.norm(V[Q] - V[np.roll(Q, -1, axis=1)], axis=2).mean()
    d, _ = cKDTree(V).query(np.asarray(transform(V), dtype=np.float64))
    return float(np.median(d) / edge), float(d.max() / edge)
