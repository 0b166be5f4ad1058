r"""Principal curvatures and directions per face, from the variation of the vertex normals.

On each face t the shape operator S_t = dN (a symmetric 2 × 2 matrix in the face frame
``mesh.face_bases[t]``) is the least-squares fit of

.. math::

    S_t \, \hat e_i \approx \widehat{n_{i+2} - n_{i+1}}, \qquad i = 0, 1, 2,

where e_i = x_{i+2} − x_{i+1} are the face's edge vectors, n_j unit vertex normals and
the hat denotes coordinates in the face frame (the normal differences projected onto the
face plane). This is the per-face normal-variation estimator of Rusinkiewicz (2004,
"Estimating curvatures and their derivatives on triangle meshes"), without his averaging
to vertices. Its eigenvalues are the principal curvatures κ_1 ≥ κ_2 and its eigenvectors
the principal directions.

Vertex normals are weighted as in Max (1999, "Weights for computing vertex normals from
facet normals": each face normal by sin(angle) / (|e_1| |e_2|) at the corner), which are
exact for vertices on a sphere; on an icosphere-based ellipsoid they gave a 2-3x smaller
error in κ_2 and the principal directions than corner-angle weights. Measured on analytic
surfaces (``tests/mesh/test_curvature.py``): exact on a cylinder grid, first order in the mean
edge length pointwise on a torus of revolution; on an icosphere-based ellipsoid (irregular
valences) the RMS error converges while the maximum does not.

Sign convention: S = dN for the orientation's normals N (right-hand rule on the faces), so
a sphere of radius R with outward normals has κ_1 = κ_2 = +1/R; reversing the orientation
flips the signs.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from ..numerics.summary import html_repr, short_repr
from .convert import takes_mesh
from .geometry import cross_rows, readonly

if TYPE_CHECKING:
    from .trimesh import TriMesh

__all__ = ["PrincipalCurvatures", "principal_curvatures", "vertex_normals"]


@dataclasses.dataclass(frozen=True)
class PrincipalCurvatures:
    """Principal curvatures and directions per face (:func:`principal_curvatures`).

    Attributes
    ----------
    k1, k2 : float64 (m,)
        κ_1 ≥ κ_2, eigenvalues of the shape operator dN.
    d1, d2 : float64 (m, 3)
        Unit tangent principal directions of κ_1 and κ_2 (d2 = N × d1); each is defined up
        to sign (a 2-direction), and arbitrary where κ_1 = κ_2 (umbilics, flat faces).
    shape_operator : float64 (m, 2, 2)
        S_t in the coordinates of ``mesh.face_bases``.
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    k1: np.ndarray
    k2: np.ndarray
    d1: np.ndarray
    d2: np.ndarray
    shape_operator: np.ndarray

    @property
    def mean(self) -> np.ndarray:
        """H = (κ_1 + κ_2)/2, float64 (m,)."""
        return 0.5 * (self.k1 + self.k2)

    @property
    def gaussian(self) -> np.ndarray:
        """K = κ_1 κ_2, float64 (m,)."""
        return self.k1 * self.k2

    @property
    def anisotropy(self) -> np.ndarray:
        """κ_1 − κ_2 ≥ 0, float64 (m,): zero at umbilics and on flat faces."""
        return self.k1 - self.k2


@takes_mesh
def vertex_normals(mesh: TriMesh) -> np.ndarray:
    """Unit vertex normals with Max's (1999) weights, float64 (n, 3) (cached).

    Each face normal counts at its corner with weight sin θ / (|e_1| |e_2|) =
    2 A_F / (|e_1|² |e_2|²), θ the corner angle and e_1, e_2 the two edges leaving it.
    """

    def build():
        e = mesh.face_edge_vectors  # e[t, i] = x_{i+2} - x_{i+1}
        a = -np.roll(e, -2, axis=1)  # x_{i+1} - x_i
        b = np.roll(e, -1, axis=1)  # x_{i+2} - x_i
        ang = 1.0 / (np.einsum("tik,tik->ti", a, a) * np.einsum("tik,tik->ti", b, b))
        ang = ang * (2 * mesh.face_areas)[:, None]
        N = mesh.face_normals
        F, nv = mesh.faces.ravel(), mesh.n_vertices
        w = (ang[:, :, None] * N[:, None, :]).reshape(-1, 3)
        out = np.stack([np.bincount(F, weights=w[:, j], minlength=nv) for j in range(3)], 1)
        length = np.linalg.norm(out, axis=1)
        return readonly(out / np.where(length > 0, length, 1.0)[:, None])

    return mesh.cached("vertex_normals:max", build)


def _fit_shape_operators(mesh: TriMesh) -> np.ndarray:
    """Least-squares S_t (m, 2, 2) with S ê_i ≈ d̂n_i over the three edges."""
    n = vertex_normals(mesh)[mesh.faces]  # (m, 3, 3)
    dn = n[:, [2, 0, 1]] - n[:, [1, 2, 0]]  # n_{i+2} - n_{i+1}
    e = mesh.face_edge_vectors
    B = mesh.face_bases
    ex, ey = np.einsum("tik,tk->ti", e, B[:, 0]), np.einsum("tik,tk->ti", e, B[:, 1])
    dx, dy = np.einsum("tik,tk->ti", dn, B[:, 0]), np.einsum("tik,tk->ti", dn, B[:, 1])
    # unknowns (a, b, c), S = [[a, b], [b, c]]: a ex + b ey = dx, b ex + c ey = dy
    M = np.zeros((mesh.n_faces, 3, 3))
    M[:, 0, 0] = (ex * ex).sum(1)
    M[:, 0, 1] = M[:, 1, 0] = (ex * ey).sum(1)
    M[:, 1, 1] = (ey * ey + ex * ex).sum(1)
    M[:, 1, 2] = M[:, 2, 1] = (ex * ey).sum(1)
    M[:, 2, 2] = (ey * ey).sum(1)
    r = np.stack([(ex * dx).sum(1), (ey * dx + ex * dy).sum(1), (ey * dy).sum(1)], axis=1)
    abc = np.linalg.solve(M, r[..., None])[..., 0]
    S = np.empty((mesh.n_faces, 2, 2))
    S[:, 0, 0], S[:, 0, 1], S[:, 1, 0], S[:, 1, 1] = abc[:, 0], abc[:, 1], abc[:, 1], abc[:, 2]
    return S


@takes_mesh
def principal_curvatures(mesh: TriMesh) -> PrincipalCurvatures:
    """Principal curvatures and directions of every face (normal-variation estimator).

    Parameters
    ----------
    mesh : TriMesh

    Returns
    -------
    PrincipalCurvatures
        ``k1``, ``k2`` float64 (m,) with κ_1 ≥ κ_2; ``d1``, ``d2`` float64 (m, 3) unit
        tangent directions; ``shape_operator`` (m, 2, 2). See the module docstring for the
        estimator, its measured accuracy and the sign convention. Cached on the mesh.

    Examples
    --------
    >>> import fvf
    >>> pc = fvf.principal_curvatures(fvf.icosphere(3, radius=2.0))
    >>> bool(abs(pc.k1 - 0.5).max() < 1e-2 and abs(pc.k2 - 0.5).max() < 1e-2)
    True
    """

    return mesh.cached("principal_curvatures", lambda: _estimate(mesh))


#: Key of :func:`principal_curvatures` in the mesh's cache.
CACHE_KEY = "principal_curvatures"


def _estimate(mesh: TriMesh) -> PrincipalCurvatures:
    """:func:`principal_curvatures` computed afresh (not cached)."""
    S = _fit_shape_operators(mesh)
    a, b, c = S[:, 0, 0], S[:, 0, 1], S[:, 1, 1]
    mean, half = 0.5 * (a + c), np.hypot(0.5 * (a - c), b)
    theta = 0.5 * np.arctan2(2.0 * b, a - c)  # angle of the κ_1 eigenvector
    B = mesh.face_bases
    d1 = np.cos(theta)[:, None] * B[:, 0] + np.sin(theta)[:, None] * B[:, 1]
    d2 = cross_rows(mesh.face_normals, d1)
    return PrincipalCurvatures(
        readonly(mean + half),
        readonly(mean - half),
        readonly(d1),
        readonly(d2),
        readonly(S),
    )


def principal_curvatures_transient(mesh: TriMesh) -> PrincipalCurvatures:
    """:func:`principal_curvatures` from the mesh's cache when there, else computed without
    storing it: for one-shot users on big meshes (0.07 GB at 750k faces)."""
    return mesh.peek_cached(CACHE_KEY) or _estimate(mesh)
