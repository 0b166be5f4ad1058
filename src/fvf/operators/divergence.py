"""Divergence-based operators D̃_v and their duals (chapter §4.2, eqs. 51–53).

Smoothly, D̃_v f = ∇·(f v) − f ∇·v equals D_v f; discretely (eq. 52) it is built from the
weak divergence instead of the gradient, which makes the mixed Lie bracket (eq. 54) a
1-ring operator (Lemma 16).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..calculus import (
    div,
    face_rows_csr,
    face_to_vertex,
    hat_gradients,
    vertex_to_face,
)
from ..mesh.convert import takes_mesh
from ..mesh.geometry import sorted_corners
from ..mesh.inputs import TangentPolicy, as_face_field, as_face_function, as_vertex_function
from ..mesh.trimesh import TriMesh

__all__ = ["dtilde_entries", "Dtilde_F", "Dtilde_V", "Dtilde_dual_F", "Dtilde_dual_V"]


def _weighted_hat_products(mesh: TriMesh, v: np.ndarray) -> np.ndarray:
    """−A_F(t)/A_V(i) ⟨∇φ_i, v(t)⟩ per face and corner: the entries of div [v]•, (m, 3)."""
    d = np.einsum("tij,tj->ti", hat_gradients(mesh), v)
    return -d * mesh.face_areas[:, None] / mesh.vertex_areas[mesh.faces]


@takes_mesh
def dtilde_entries(mesh: TriMesh, v: np.ndarray) -> np.ndarray:
    """The entries D̃^F_v(F[t, a], t) per face and corner, float64 (m, 3) (eq. 52).

    Parameters
    ----------
    v : float64 (m, 3)
        A checked per-face field.
    """
    divv = div(mesh) @ v.ravel()  # (n,)
    F = mesh.faces
    return _weighted_hat_products(mesh, v) - divv[F] * (
        mesh.face_areas[:, None] / (3.0 * mesh.vertex_areas[F])
    )


@takes_mesh
def Dtilde_F(mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project") -> sp.csr_array:
    """D̃^F_v = div [v]• − [div v] I_V^F: sparse (n, m) (eq. 52), PC functions to PL.

    Column t has the three entries of the corners of face t.
    """
    v = as_face_field(mesh, v, "v", tangent)
    order, Fs = sorted_corners(mesh)
    vals = np.take_along_axis(dtilde_entries(mesh, v), order, axis=1)
    T = face_rows_csr(vals, Fs, mesh.n_vertices)  # (m, n): the transpose, row t = face t
    return T.T.tocsr()


@takes_mesh
def Dtilde_V(mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project") -> sp.csr_array:
    """D̃^V_v = div [v]• I_F^V − [div v]: sparse (n, n) (eq. 52), on the 1-ring pattern."""
    v = as_face_field(mesh, v, "v", tangent)
    divv = div(mesh) @ v.ravel()
    a = _weighted_hat_products(mesh, v) / 3.0  # (m, 3): row corner a, any column corner b
    return mesh.assemble_vertex_operator(np.repeat(a[:, :, None], 3, axis=2), diagonal=-divv)


def _scaled_div(mesh: TriMesh, face_values: np.ndarray, vertex_values: np.ndarray) -> sp.csr_array:
    """Entry (i, 3t+k) of div times (face_values[t] − vertex_values[i]): sparse (n, 3m)."""
    D = div(mesh)
    rows = np.repeat(np.arange(D.shape[0]), np.diff(D.indptr))
    data = D.data * (face_values[D.indices // 3] - vertex_values[rows])
    return sp.csr_array((data, D.indices, D.indptr), shape=D.shape)


@takes_mesh
def Dtilde_dual_F(mesh: TriMesh, f_faces: npt.ArrayLike) -> sp.csr_array:
    """D̃^F_𝐟 = div [𝐟] − [I_V^F 𝐟] div: sparse (n, 3m), dual of D̃^F (eq. 53).

    For a PC function 𝐟 (m,): ``Dtilde_dual_F(mesh, f) @ v.ravel() == Dtilde_F(mesh, v) @ f``.
    """
    f = as_face_function(mesh, f_faces, "f_faces")
    return _scaled_div(mesh, f, face_to_vertex(mesh) @ f)


@takes_mesh
def Dtilde_dual_V(mesh: TriMesh, f: npt.ArrayLike) -> sp.csr_array:
    """D̃^V_f = div [I_F^V f] − [f] div: sparse (n, 3m), dual of D̃^V (eq. 53).

    For a PL function f (n,): ``Dtilde_dual_V(mesh, f) @ v.ravel() == Dtilde_V(mesh, v) @ f``.
    """
    f = as_vertex_function(mesh, f)
    return _scaled_div(mesh, vertex_to_face(mesh) @ f, f)
