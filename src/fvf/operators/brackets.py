"""Lie brackets as operator commutators, B(v, w), and ad_v (chapter §3.6, §4.3–4.4).

Two discrete brackets of tangent fields v, w:

- the vertex bracket D^V_{[v,w]} = D^V_v D^V_w − D^V_w D^V_v (eq. 46), 2-ring sparse, and
- the mixed bracket D^F_{[v,w]} = D̃^F_v D^F_w − D̃^F_w D^F_v (eq. 54), 1-ring sparse
  (Lemma 16), assembled here from Lemma 14 (eq. 55) face by face.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..calculus import (
    block_diagonal,
    div,
    face_to_vertex,
    hat_gradients,
    stiffness,
    vertex_to_face,
)
from ..errors import FieldValueError, ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.geometry import centered_vertices
from ..mesh.inputs import TangentPolicy, as_face_field, as_vertex_function, unit_scale
from ..mesh.trimesh import TriMesh
from .directional import D_V, directional_derivatives
from .divergence import dtilde_entries

__all__ = [
    "bracket_V",
    "bracket_F",
    "B",
    "ad",
    "commutator_field",
    "bracket_norm",
    "dirichlet_ratio",
    "bracket_smoothness",
]


@takes_mesh
def bracket_V(
    mesh: TriMesh, v: npt.ArrayLike, w: npt.ArrayLike, tangent: TangentPolicy = "project"
) -> sp.csr_array:
    """D^V_{[v,w]} = D^V_v D^V_w − D^V_w D^V_v: sparse (n, n), the vertex Lie bracket (eq. 46).

    Its sparsity is the 2-ring, so it is not itself a functional vector field (§3.6);
    ``extract_field(mesh, bracket_V(...))`` gives a vertex field (n, 3).
    """
    Dv, Dw = D_V(mesh, v, tangent), D_V(mesh, w, tangent)
    return (Dv @ Dw - Dw @ Dv).tocsr()


@takes_mesh
def bracket_F(
    mesh: TriMesh, v: npt.ArrayLike, w: npt.ArrayLike, tangent: TangentPolicy = "project"
) -> sp.csr_array:
    """D^F_{[v,w]} = D̃^F_v D^F_w − D̃^F_w D^F_v: sparse (n, n), the mixed Lie bracket (eq. 54).

    Assembled through Lemma 14 (eq. 55),
    D^F_{[v,w]} = div B(v,w) grad − [div v] D^V_w + [div w] D^V_v, one 3 x 3 block per
    face on the 1-ring pattern (Lemma 16).

    Notes
    -----
    Lemma 14 is an algebraic identity and holds on meshes with boundary too. Theorem 1
    (eq. 60) uses div J grad h = 0, which holds at interior vertices only: on a mesh with
    boundary it fails at boundary vertices.
    """
    v = as_face_field(mesh, v, "v", tangent)
    w = as_face_field(mesh, w, "w", tangent)
    D = div(mesh)
    divv, divw = D @ v.ravel(), D @ w.ravel()  # (n,)
    dv, dw = directional_derivatives(mesh, v), directional_derivatives(mesh, w)  # (m, 3)
    F = mesh.faces
    scale = (mesh.face_areas[:, None] / mesh.vertex_areas[F])[:, :, None]  # (m, 3a, 1)
    local = scale * (
        -(dv[:, :, None] * dw[:, None, :] - dw[:, :, None] * dv[:, None, :])  # div B grad
        - divv[F][:, :, None] * dw[:, None, :] / 3.0  # −[div v] D^V_w
        + divw[F][:, :, None] * dv[:, None, :] / 3.0  # +[div w] D^V_v
    )  # (m, 3a, 3b): entry (F[t, a], F[t, b])
    return mesh.assemble_vertex_operator(local)


@takes_mesh
def B(
    mesh: TriMesh, v: npt.ArrayLike, w: npt.ArrayLike, tangent: TangentPolicy = "project"
) -> sp.csr_array:
    """B(v, w) = [v]•[w]•ᵀ − [w]•[v]•ᵀ: sparse (3m, 3m), block diagonal (eq. 55).

    Each face block is v wᵀ − w vᵀ; for tangent fields it equals ⟨v, N × w⟩ [N]×, i.e.
    B(v, w) = [[v]•ᵀ J w] J (Lemma 15, eq. 57).
    """
    v = as_face_field(mesh, v, "v", tangent)
    w = as_face_field(mesh, w, "w", tangent)
    blocks = v[:, :, None] * w[:, None, :] - w[:, :, None] * v[:, None, :]
    return block_diagonal(blocks)


@takes_mesh
def ad(mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project") -> sp.csr_array:
    """ad_v: sparse (3n, 3m), w ↦ D^F_{[v,w]} X (eqs. 62–63), in fvf's layout.

    Maps a face-major flattened field ``w.ravel()`` (3m,) to the vertex-major flattened
    vertex field ``u.ravel()`` (3n,), where u = D^F_{[v,w]} X (n, 3) for tangent w.
    Returned as a block sparse array (``scipy.sparse.bsr_array``, 3 x 3 blocks at
    (vertex i, face t) for i ∈ t), 27 values per face corner.
    Lemma 17 (eq. 63), written per entry:
    ad_v[3i+k, 3t+l] = D̃^F_v(i, t) δ_kl − D̃^F_{v_k}(i, 3t+l), with v_k the k-th
    coordinate of v as a PC function. The chapter's eq. (63) is the same operator in
    coordinate-major blocks.
    """
    v = as_face_field(mesh, v, "v", tangent)
    F = mesh.faces
    m, n = mesh.n_faces, mesh.n_vertices
    c = dtilde_entries(mesh, v)  # (m, 3): D̃^F_v(F[t, a], t)
    Iv = face_to_vertex(mesh) @ v  # (n, 3): I_V^F v_k
    g = hat_gradients(mesh) * (mesh.face_areas[:, None] / mesh.vertex_areas[F])[:, :, None]
    diff = v[:, None, :] - Iv[F]  # (m, 3a, 3k): v_k(t) − (I_V^F v_k)(i)
    blocks = c[:, :, None, None] * np.eye(3) + diff[:, :, :, None] * g[:, :, None, :]
    # One 3 x 3 block per (vertex F[t, a], face t), gathered by vertex into BSR.
    order = np.argsort(F.ravel(), kind="stable")
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(F.ravel(), minlength=n), out=indptr[1:])
    faces_of = np.repeat(np.arange(m), 3)[order]
    return sp.bsr_array((blocks.reshape(-1, 3, 3)[order], faces_of, indptr), shape=(3 * n, 3 * m))


@takes_mesh
def commutator_field(
    mesh: TriMesh, v: npt.ArrayLike, w: npt.ArrayLike, tangent: TangentPolicy = "project"
) -> np.ndarray:
    """u = D^F_{[v,w]} X: the commutator as a vertex field, float64 (n, 3) (§4.3.3, Fig. 9).

    Approximately (not exactly) tangent to the surface. Computed scale-free: the bracket
    is bilinear, [a v, b w] = ab [v, w], so v and w are scaled to unit size first (by
    powers of two, exactly) and the result scaled back; fields of magnitude 1e-200 or
    1e200 give the right answer whenever it fits in float64.

    Raises
    ------
    FieldValueError
        The commutator's magnitude is beyond float64 (e.g. two fields of size 1e200).
    """
    unit, scale = _unit_commutator(mesh, v, w, tangent)
    return _scaled_back(unit, scale, "commutator field")


def _unit_commutator(
    mesh: TriMesh, v: npt.ArrayLike, w: npt.ArrayLike, tangent: TangentPolicy
) -> tuple[np.ndarray, float]:
    """(D^F_{[v̂,ŵ]} X, s) with v̂ = v/s_v, ŵ = w/s_w of unit size and s = s_v s_w."""
    v = as_face_field(mesh, v, "v", tangent)
    w = as_face_field(mesh, w, "w", tangent)
    sv, sw = unit_scale(v), unit_scale(w)
    unit = bracket_F(mesh, v / sv, w / sw, "ignore") @ centered_vertices(mesh)  # D X (D 1 = 0)
    return unit, sv * sw


def _scaled_back(unit: np.ndarray, scale: float, what: str) -> np.ndarray:
    with np.errstate(over="ignore"):
        out = unit * scale
    if not np.isfinite(out).all():
        big = float(np.abs(unit).max())
        raise FieldValueError(
            f"the {what} has magnitude ~{big:.3g} x {scale:.3g}, beyond float64. Fix: scale "
            "v and w down (the bracket is bilinear: [a v, b w] = ab [v, w])."
        )
    return out


@takes_mesh
def bracket_norm(
    mesh: TriMesh,
    v: npt.ArrayLike,
    w: npt.ArrayLike,
    where: str = "vertex",
    tangent: TangentPolicy = "project",
) -> np.ndarray:
    """Pointwise norm of the commutator field |D^F_{[v,w]} X| (Figs. 9–10).

    Parameters
    ----------
    where : {"vertex", "face"}
        Per vertex (n,), or averaged to faces with I_F^V (m,).
    tangent : {"project", "raise", "ignore"}
        Normal-component policy for v and w (:func:`fvf.as_face_field`).

    Returns
    -------
    float64 (n,) or (m,)
        Computed scale-free, as :func:`commutator_field`.

    Raises
    ------
    FieldValueError
        The norms are beyond float64.
    """
    if where not in ("vertex", "face"):
        raise ParameterError(f"where must be 'vertex' or 'face'; got {where!r}")
    unit, scale = _unit_commutator(mesh, v, w, tangent)
    if where == "face":
        unit = vertex_to_face(mesh) @ unit
    return _scaled_back(np.linalg.norm(unit, axis=1), scale, "commutator's norm")


@takes_mesh
def dirichlet_ratio(mesh: TriMesh, g: np.ndarray) -> np.ndarray:
    """‖∇g‖² / ‖g‖² = gᵀWg / gᵀ[A_V]g per column: a scale-free roughness of PL functions.

    Parameters
    ----------
    g : float64 (n,) or (n, c)

    Returns
    -------
    float or float64 (c,)
        0 for a zero column (a zero function is perfectly smooth).

    Raises
    ------
    FieldShapeError
        Wrong shape or dtype, or non-finite values.
    """
    g = as_vertex_function(mesh, g, "g", columns=True)
    s = np.abs(g).max(axis=0)  # scale each column: squares of 1e150 would overflow
    g = g / np.where(s > 0, s, 1.0)
    W = stiffness(mesh)
    a = mesh.vertex_areas
    num = np.einsum("i...,i...->...", g, W @ g)
    den = np.einsum("i,i...->...", a, g * g)
    return num / np.where(den > 0, den, 1.0)


@takes_mesh
def bracket_smoothness(
    mesh: TriMesh, v: npt.ArrayLike, w: npt.ArrayLike, functions: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Roughness of both brackets applied to functions, e.g. LB eigenfunctions (Fig. 7).

    Parameters
    ----------
    functions : float64 (n, c)

    Returns
    -------
    vertex, mixed : float64 (c,)
        :func:`dirichlet_ratio` of D^V_{[v,w]} φ and of D^F_{[v,w]} φ for each column.
        The chapter's claim is that the mixed bracket's output is the smoother one.
    """
    functions = as_vertex_function(mesh, functions, "functions", columns=True)
    gV = bracket_V(mesh, v, w) @ functions
    gF = bracket_F(mesh, v, w) @ functions
    return dirichlet_ratio(mesh, gV), dirichlet_ratio(mesh, gF)
