"""Functional vector fields: D^F_v, D^V_v, their duals, and field extraction (§3.2–3.3).

A tangent field v acts on PL functions as the directional derivative
D_v f = ⟨v, ∇f⟩ (eqs. 33–34). On a mesh this is the PC result D^F_v f (m,) or its
area-weighted average on vertices D^V_v f (n,).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..calculus import (
    face_rows_csr,
    face_to_vertex,
    field_inner,
    gradient,
    hat_gradients,
)
from ..errors import FieldShapeError
from ..mesh.convert import takes_mesh

# centered_vertices is a mesh quantity; importing it from here keeps working.
from ..mesh.geometry import centered_vertices, readonly_csr, sorted_corners
from ..mesh.inputs import TangentPolicy, as_face_field
from ..mesh.trimesh import TriMesh

__all__ = ["directional_derivatives", "D_F", "D_V", "Dbar_F", "Dbar_V", "extract_field"]


@takes_mesh
def directional_derivatives(mesh: TriMesh, v: np.ndarray) -> np.ndarray:
    """⟨v(t), ∇φ_i⟩ on each face for each corner, float64 (m, 3): the entries of D^F_v.

    Parameters
    ----------
    v : array_like (m, 3)
        Per-face field; its normal component does not matter (the hat gradients are
        tangent), so it is kept without a warning.

    Raises
    ------
    FieldShapeError
        Wrong shape or dtype, or non-finite values.
    """
    v = as_face_field(mesh, v, "v", tangent="ignore")
    return np.einsum("tij,tj->ti", hat_gradients(mesh), v)


@takes_mesh
def D_F(mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project") -> sp.csr_array:
    """D^F_v = [v]•ᵀ grad: sparse (m, n), the directional derivative to faces (eq. 35).

    ``(D^F_v f)(t) = ⟨v(t), (grad f)(t)⟩``. Row t has the three entries of face t
    (Lemma 8).

    Parameters
    ----------
    mesh : TriMesh
    v : array_like, (m, 3)
        Tangent field per face; a normal component is projected away with a warning
        (``tangent="project"``; see :func:`fvf.mesh.inputs.as_face_field`). It would not change
        D^F_v, since grad is tangent.
    """
    v = as_face_field(mesh, v, "v", tangent)
    order, Fs = sorted_corners(mesh)
    vals = np.take_along_axis(directional_derivatives(mesh, v), order, axis=1)
    return face_rows_csr(vals, Fs, mesh.n_vertices)


@takes_mesh
def D_V(mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project") -> sp.csr_array:
    """D^V_v = I_V^F D^F_v: sparse (n, n), the directional derivative on vertices (eq. 36).

    Assembled directly on the mesh's cached 1-ring pattern (Lemma 8), so building it for
    a new field costs one pass over the faces.

    Notes
    -----
    [A_V] D^V_v is skew-symmetric for v = J grad g on a closed mesh (its flow keeps the
    A_V-norm). On a mesh with boundary J grad g has flux through the boundary, and the
    skew-symmetry (hence norm conservation) fails at boundary vertices, unless g is
    constant along each boundary loop (v tangent to the boundary, no flux): then it holds
    exactly. D^V_v itself is assembled the same way, with one-sided averages at the
    boundary (``docs/boundary.md``).
    """
    v = as_face_field(mesh, v, "v", tangent)
    indptr, indices, _ = mesh.vertex_pattern
    data = _D_V_scatter(mesh) @ directional_derivatives(mesh, v).ravel()
    n = mesh.n_vertices
    return sp.csr_array((data, indices, indptr), shape=(n, n))


def _D_V_scatter(mesh: TriMesh) -> sp.csr_array:
    """Sparse (nnz, 3m) map from ⟨v, ∇φ_b⟩ per face corner to the data of D^V_v.

    Entry (slots[t, a, b], 3t + b) is A_F(t) / (3 A_V(F[t, a])), the weight of I_V^F
    (eq. 36); cached per mesh so a new field costs one sparse product.
    """

    def build():
        _, indices, slots = mesh.vertex_pattern
        m = mesh.n_faces
        w = mesh.face_areas[:, None] / (3.0 * mesh.vertex_areas[mesh.faces])  # (m, 3a)
        vals = np.broadcast_to(w[:, :, None], (m, 3, 3))
        cols = np.broadcast_to((3 * np.arange(m))[:, None, None] + np.arange(3), (m, 3, 3))
        P = sp.coo_array((vals.ravel(), (slots.ravel(), cols.ravel())), (indices.size, 3 * m))
        return readonly_csr(P.tocsr())

    return mesh.cached("D_V_scatter", build)


@takes_mesh
def Dbar_F(mesh: TriMesh, f: npt.ArrayLike) -> sp.csr_array:
    """D̄^F_f = [grad f]•ᵀ: sparse (m, 3m), the dual operator (eq. 37).

    Linear in the field: ``D̄^F_f v = D^F_v f``; also linear over PC functions (eq. 39).
    """
    return field_inner(mesh, gradient(mesh, f))


@takes_mesh
def Dbar_V(mesh: TriMesh, f: npt.ArrayLike) -> sp.csr_array:
    """D̄^V_f = I_V^F D̄^F_f: sparse (n, 3m), the dual of D^V (eq. 38): D̄^V_f v = D^V_v f."""
    return (face_to_vertex(mesh) @ Dbar_F(mesh, f)).tocsr()


@takes_mesh
def extract_field(mesh: TriMesh, D: Any) -> np.ndarray:
    """Recover a field from its operator by applying it to the coordinates (Lemma 9, eq. 40).

    Parameters
    ----------
    D : sparse or dense, (m, n) or (n, n)
        A functional vector field operator: D^F_v gives back v (m, 3) exactly for a
        tangent v; D^V_v, D^V_{[v,w]} or D^F_{[v,w]} give a vertex field (n, 3)
        (§3.6, §4.3.3).

    Returns
    -------
    ndarray, float64 (rows of D, 3)

    Raises
    ------
    FieldShapeError
        D does not have one column per vertex.

    Notes
    -----
    D is applied to the coordinates minus their mean, which is the same for any
    operator that annihilates constants (every derivation does: D 1 = 0), and keeps the
    result accurate on meshes far from the origin: with X ~ 1e6 and D ~ 1/h, ``D @ X``
    cancels ~|X|/h before rounding, losing ``1e6 · eps`` relative to the result.
    """
    if not sp.issparse(D):
        D = np.asarray(D)
    if D.ndim != 2 or D.shape[1] != mesh.n_vertices:
        raise FieldShapeError(
            f"D must have {mesh.n_vertices} columns (one per vertex) to act on the "
            f"coordinates; got shape {D.shape}."
        )
    return np.asarray(D @ centered_vertices(mesh))
