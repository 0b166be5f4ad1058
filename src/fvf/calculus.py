"""Discrete calculus on a triangle mesh (chapter §3.1, eqs. 26–31).

Piecewise-linear (PL) functions live on vertices, shape (n,); piecewise-constant (PC)
functions on faces, shape (m,); PC vector fields are (m, 3) arrays, flattened face-major
(entry ``3t + k`` is component k of face t). Every operator here depends on the mesh
only, is assembled once from per-face formulas (no Python loop over faces) and cached on
the :class:`~fvf.TriMesh`; the returned sparse arrays share read-only buffers.

A function named for an operator returns its matrix (:func:`grad`, :func:`div`,
:func:`rotation`, :func:`vertex_to_face`, :func:`face_to_vertex`); applying it to an
array has a name of its own, for the result or the action (:func:`gradient`,
:func:`divergence`, :func:`rotate`, :func:`vertex_to_face_values`,
:func:`face_to_vertex_values`), and returns the matrix times the array
(``docs/conventions.md``, "Names").
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from .errors import FieldShapeError, ParameterError
from .mesh.convert import takes_mesh
from .mesh.geometry import (
    cross_rows,
    edge_components,
    readonly,
    readonly_csr,
    sorted_corners,
)
from .mesh.inputs import (
    as_face_field,
    as_face_function,
    as_vertex_function,
    check_finite,
    real_array,
)
from .mesh.trimesh import TriMesh

__all__ = [
    "face_areas",
    "vertex_areas",
    "hat_gradients",
    "vertex_mass",
    "face_mass",
    "rotation",
    "rotate",
    "diag",
    "field_product",
    "field_inner",
    "face_to_vertex",
    "vertex_to_face",
    "grad",
    "div",
    "stiffness",
    "laplacian",
    "gradient",
    "divergence",
    "poisson_bracket",
    "vertex_to_face_values",
    "face_to_vertex_values",
]

#: Names of ``__all__`` that the flat namespace ``fvf`` leaves out (reach them as
#: ``fvf.calculus.name``; ``fvf.diag`` and the others still resolve, with a
#: DeprecationWarning); every other name here is also ``fvf.name``.
NOT_FLAT: frozenset[str] = frozenset(
    {
        "diag",
        "field_inner",
        "field_product",
        "hat_gradients",
    }
)


def face_rows_csr(values: np.ndarray, columns: np.ndarray, n_cols: int) -> sp.csr_array:
    """CSR array whose row r holds ``values[r]`` at ``columns[r]`` (same count per row).

    Parameters
    ----------
    values : float64 (r, c)
    columns : int64 (r, c)
        Distinct, ascending within each row.
    n_cols : int
    """
    r, c = values.shape
    indptr = np.arange(0, r * c + 1, c, dtype=np.int64)
    return sp.csr_array(
        (values.ravel(), columns.ravel().astype(np.int64, copy=False), indptr), shape=(r, n_cols)
    )


def block_diagonal(blocks: np.ndarray) -> sp.csr_array:
    """3m x 3m block-diagonal CSR array from per-face blocks.

    Parameters
    ----------
    blocks : float64 (m, 3, 3)
        ``blocks[t]`` acts on the three components of face t.
    """
    m = blocks.shape[0]
    cols = np.repeat(3 * np.arange(m)[:, None] + np.arange(3), 3, axis=0)  # (3m, 3)
    return face_rows_csr(blocks.reshape(3 * m, 3), cols, 3 * m)


# ---------------------------------------------------------------------------- per-face
@takes_mesh
def face_areas(mesh: TriMesh) -> np.ndarray:
    """A_F: the area of each face, float64 (m,) (§3.1)."""
    return mesh.face_areas


@takes_mesh
def vertex_areas(mesh: TriMesh) -> np.ndarray:
    """A_V: barycentric vertex areas, a third of the adjacent face areas, float64 (n,) (§3.1)."""
    return mesh.vertex_areas


@takes_mesh
def hat_gradients(mesh: TriMesh) -> np.ndarray:
    """Gradient of each hat function on each face (eq. 27), float64 (m, 3, 3).

    ``hat_gradients(mesh)[t, i] = J_t e_{t,i} / (2 A_F(t))``: the constant gradient, on
    face t, of the PL function that is 1 at corner i and 0 at the other vertices.
    """

    def build():
        g = np.empty((mesh.n_faces, 3, 3))  # [t, i, k]
        _rotated_edges(mesh, mesh.faces, 1.0 / (2.0 * mesh.face_areas), g.transpose(2, 0, 1))
        return readonly(g)

    return mesh.cached("hat_gradients", build)


def _rotated_edges(mesh: TriMesh, corners: np.ndarray, scale: np.ndarray, out: np.ndarray) -> None:
    """Write ``out[k, t, j]`` = scale_t (N_t × e_j)_k, e_j the edge opposite corner j.

    ``out`` is a (3, m, 3) float64 view (any strides) of the caller's array.

    With ``corners = faces`` and ``scale = 1 / (2 A_F)`` this is component k of the hat
    gradient of corner j (eq. 27). ``corners`` may list each face's vertices in another
    order: e_j is then the edge from corner j+1 to j+2 of that order, which reverses the
    face's edges for an odd permutation (flip the sign of ``scale`` there).
    """
    e = edge_components(mesh.vertex_columns, corners)  # (3 coordinates, m, 3 corners)
    N = mesh.face_normals
    first, second = np.empty(e.shape[1:]), np.empty(e.shape[1:])  # contiguous (m, 3)
    for k in range(3):
        a, b = (k + 1) % 3, (k + 2) % 3  # (N x e)_k = N_a e_b - N_b e_a
        np.multiply(e[b], (N[:, a] * scale)[:, None], out=first)
        np.multiply(e[a], (N[:, b] * scale)[:, None], out=second)
        np.subtract(first, second, out=out[k])  # the one strided write


# ---------------------------------------------------------------------------- mass, J, [.]
@takes_mesh
def vertex_mass(mesh: TriMesh) -> sp.csr_array:
    """[A_V]: the diagonal n x n matrix of barycentric vertex areas (inner product 26)."""
    return mesh.cached("vertex_mass", lambda: readonly_csr(sp.diags_array(mesh.vertex_areas)))


@takes_mesh
def face_mass(mesh: TriMesh, components: int = 3) -> sp.csr_array:
    """[A_F]: diagonal face-area matrix, m x m (``components=1``) or 3m x 3m (default).

    The 3m x 3m form repeats each face area over the three components of a face-major
    flattened field, the inner product ⟨u, v⟩ = uᵀ[A_F]v of eq. (26).
    """
    if components not in (1, 3):
        raise ParameterError(f"components must be 1 or 3; got {components}")
    return mesh.cached(
        f"face_mass:{components}",
        lambda: readonly_csr(sp.diags_array(np.repeat(mesh.face_areas, components))),
    )


@takes_mesh
def rotation(mesh: TriMesh) -> sp.csr_array:
    """J: rotation by +π/2 in each face plane, J_t u = N_t × u, sparse (3m, 3m).

    Block diagonal with the cross-product matrices of the face normals (§3.1).
    """

    def build():
        N = mesh.face_normals
        z = np.zeros(mesh.n_faces)
        blocks = np.stack(
            [
                np.stack([z, -N[:, 2], N[:, 1]], axis=1),
                np.stack([N[:, 2], z, -N[:, 0]], axis=1),
                np.stack([-N[:, 1], N[:, 0], z], axis=1),
            ],
            axis=1,
        )  # (m, 3, 3): blocks[t] @ u = N_t x u
        return readonly_csr(block_diagonal(blocks))

    return mesh.cached("rotation", build)


@takes_mesh
def rotate(mesh: TriMesh, u: npt.ArrayLike) -> np.ndarray:
    """Apply J to a per-face field: ``N × u`` per face, (m, 3) -> (m, 3)."""
    return cross_rows(mesh.face_normals, as_face_field(mesh, u, tangent="ignore"))


def diag(values: npt.ArrayLike, repeat: int = 1) -> sp.csr_array:
    """[f]: the diagonal matrix of a vector, each entry repeated ``repeat`` times.

    ``diag(f_faces, 3)`` is the 3m x 3m matrix that scales each face's three components
    by its value (§3.1).

    Raises
    ------
    FieldShapeError
        ``values`` not a 1-D real array, or non-finite.
    """
    a = real_array(values, "values")
    if a.ndim != 1:
        raise FieldShapeError(f"values must be 1-D; got shape {a.shape}")
    check_finite(a, "values", "entries")
    return sp.csr_array(sp.diags_array(np.repeat(a, repeat)))


@takes_mesh
def field_product(mesh: TriMesh, u: npt.ArrayLike) -> sp.csr_array:
    """[u]•: sparse (3m, m), mapping a PC function 𝐟 to the field 𝐟(t) u(t) (§3.1).

    Parameters
    ----------
    u : array_like, (m, 3)
        Per-face vectors (used as given: no tangent projection).
    """
    u = as_face_field(mesh, u, tangent="ignore")
    m = mesh.n_faces
    return face_rows_csr(u.reshape(-1, 1), np.repeat(np.arange(m), 3)[:, None], m)


@takes_mesh
def field_inner(mesh: TriMesh, u: npt.ArrayLike) -> sp.csr_array:
    """[u]•ᵀ: sparse (m, 3m), mapping a field w to the PC function ⟨u(t), w(t)⟩ (§3.1)."""
    u = as_face_field(mesh, u, tangent="ignore")
    m = mesh.n_faces
    return face_rows_csr(u, np.arange(3 * m).reshape(m, 3), 3 * m)


# ---------------------------------------------------------------------------- interpolation
@takes_mesh
def face_to_vertex(mesh: TriMesh) -> sp.csr_array:
    """I_V^F: sparse (n, m), I_V^F(i, t) = A_F(t) / (3 A_V(i)) for i ∈ t (§3.1).

    The area-weighted average of the face values around each vertex.
    """

    def build():
        order, Fs = sorted_corners(mesh)
        w = (mesh.face_areas[:, None] / 3.0) / mesh.vertex_areas[Fs]  # (m, 3)
        IT = face_rows_csr(w, Fs, mesh.n_vertices)  # (m, n) = (I_V^F)^T
        return readonly_csr(IT.T.tocsr())

    return mesh.cached("face_to_vertex", build)


@takes_mesh
def vertex_to_face(mesh: TriMesh) -> sp.csr_array:
    """I_F^V = [A_F]⁻¹ (I_V^F)ᵀ [A_V]: sparse (m, n), the mean of a face's three vertex values.

    The adjoint of :func:`face_to_vertex`: ⟨𝐟, I_F^V g⟩ = ⟨I_V^F 𝐟, g⟩ in the inner
    products of eq. (26).
    """

    def build():
        _, Fs = sorted_corners(mesh)
        return readonly_csr(face_rows_csr(np.full(Fs.shape, 1.0 / 3.0), Fs, mesh.n_vertices))

    return mesh.cached("vertex_to_face", build)


# ---------------------------------------------------------------------------- grad, div, L
@takes_mesh
def grad(mesh: TriMesh) -> sp.csr_array:
    """grad: sparse (3m, n), the PC gradient of a PL function (eqs. 27–28).

    Row ``3t + k`` is component k of the gradient on face t (face-major), with three
    entries per row; ``(grad @ f).reshape(m, 3)`` is tangent to each face.
    """

    def build():
        order, Fs = sorted_corners(mesh)
        # Sorting a face's corners is a rotation (even) or a reflection (odd) of the face.
        odd = order[:, 1] != (order[:, 0] + 1) % 3
        scale = np.where(odd, -0.5, 0.5) / mesh.face_areas
        vals = np.empty((mesh.n_faces, 3, 3))  # [t, k, j]: row (t, k), column j
        _rotated_edges(mesh, Fs, scale, vals.transpose(1, 0, 2))
        m, n = mesh.n_faces, mesh.n_vertices
        # int32 indices when they fit, as for the 1-ring pattern (scipy keeps int64 here)
        index = np.int32 if max(9 * m, n) <= np.iinfo(np.int32).max else np.int64
        cols = np.empty((m, 3, 3), dtype=index)
        cols[:] = Fs[:, None, :]
        indptr = np.arange(0, 9 * m + 1, 3, dtype=index)
        return readonly_csr(
            sp.csr_array((vals.reshape(-1), cols.reshape(-1), indptr), shape=(3 * m, n))
        )

    return mesh.cached("grad", build)


@takes_mesh
def div(mesh: TriMesh) -> sp.csr_array:
    """div = −[A_V]⁻¹ gradᵀ [A_F]: sparse (n, 3m), the weak divergence (eq. 29).

    With it, integration by parts holds exactly (Lemma 7, eq. 31):
    ⟨v, grad f⟩ + ⟨div v, f⟩ = 0. On a mesh with boundary the same identity holds (the
    boundary term is absorbed: div is the negative adjoint of grad).
    """

    def build():
        G = grad(mesh)
        rows = np.repeat(np.arange(G.shape[0]), 3)  # field index 3t + k of each entry
        data = -G.data * mesh.face_areas[rows // 3] / mesh.vertex_areas[G.indices]
        GT = sp.csc_array((data, G.indices, G.indptr), shape=(mesh.n_vertices, G.shape[0]))
        return readonly_csr(GT.tocsr())

    return mesh.cached("div", build)


def _cotangent_weights(mesh: TriMesh) -> np.ndarray:
    """W_ij = −(cot α_ij + cot β_ij) / 2 for each edge, float64 (E,) (eq. 30).

    Per face, A_F ⟨∇φ_a, ∇φ_b⟩ = ⟨e_a, e_b⟩ / (4 A_F) (J preserves inner products, eq.
    27), and e_a + e_b + e_c = 0 gives ⟨e_a, e_b⟩ = (|e_c|² − |e_a|² − |e_b|²) / 2: the
    face's contribution to the edge opposite corner c, from squared edge lengths only.
    """
    sq = mesh.face_edge_lengths_sq  # (m, 3): |e_c|² opposite corner c
    w = 2.0 * sq  # |e_c|² − |e_a|² − |e_b|² = 2 |e_c|² − (|e_a|² + |e_b|² + |e_c|²)
    w -= (sq[:, 0] + sq[:, 1] + sq[:, 2])[:, None]
    w *= (0.125 / mesh.face_areas)[:, None]
    corners = mesh.edge_corners  # (E, 2): the corner opposite each edge on each side
    per_side = w.reshape(-1).take(corners)
    if mesh.boundary_edges.size:
        per_side[corners < 0] = 0.0
    return per_side[:, 0] + per_side[:, 1]


@takes_mesh
def stiffness(mesh: TriMesh) -> sp.csr_array:
    """W = gradᵀ [A_F] grad: the symmetric positive semidefinite cotangent matrix (n, n).

    ``laplacian(mesh) = [A_V]⁻¹ W``; use W with :func:`vertex_mass` for symmetric
    eigenproblems. Off the diagonal, W_ij = −(cot α_ij + cot β_ij) / 2 (the angles
    opposite edge ij); each diagonal entry is minus the rest of its row, so constants are
    in the kernel up to the rounding of one sum.
    """

    def build():
        w = _cotangent_weights(mesh)
        E, n = mesh.edges, mesh.n_vertices
        diagonal = np.bincount(E[:, 0], w, minlength=n)
        diagonal += np.bincount(E[:, 1], w, minlength=n)
        return readonly_csr(mesh.assemble_edge_operator(w, -diagonal))

    return mesh.cached("stiffness", build)


@takes_mesh
def laplacian(mesh: TriMesh) -> sp.csr_array:
    """L = −div grad = [A_V]⁻¹ gradᵀ [A_F] grad: sparse (n, n), pointwise (§3.1).

    Positive semidefinite in the A_V inner product, constants in its kernel, with the
    1-ring sparsity of the cotangent Laplacian (divided by barycentric vertex areas).
    """

    def build():
        W = stiffness(mesh)  # L = [A_V]⁻¹ W: scale each row of the shared pattern
        rows = np.repeat(np.arange(mesh.n_vertices), np.diff(W.indptr))
        return readonly_csr(
            sp.csr_array((W.data / mesh.vertex_areas[rows], W.indices, W.indptr), W.shape)
        )

    return mesh.cached("laplacian", build)


# ---------------------------------------------------------------------------- applied forms
@takes_mesh
def gradient(mesh: TriMesh, f: npt.ArrayLike) -> np.ndarray:
    """grad f as a per-face field: PL function (n,) -> tangent field (m, 3) (eq. 28)."""
    return (grad(mesh) @ as_vertex_function(mesh, f)).reshape(-1, 3)


@takes_mesh
def divergence(mesh: TriMesh, u: npt.ArrayLike) -> np.ndarray:
    """div u as a PL function: per-face field (m, 3) -> (n,) (eq. 29)."""
    return div(mesh) @ as_face_field(mesh, u, tangent="ignore").ravel()


@takes_mesh
def poisson_bracket(mesh: TriMesh, f: npt.ArrayLike, g: npt.ArrayLike) -> np.ndarray:
    """{f, g} = [J grad f]•ᵀ grad g: PC function (m,) (Theorem 1, eq. 60).

    Per face, ⟨N × ∇f, ∇g⟩; antisymmetric in (f, g).
    """
    gf, gg = gradient(mesh, f), gradient(mesh, g)
    return np.einsum("ij,ij->i", cross_rows(mesh.face_normals, gf), gg)


@takes_mesh
def vertex_to_face_values(mesh: TriMesh, f: npt.ArrayLike) -> np.ndarray:
    """I_F^V f: the mean of each face's vertex values, (n,) -> (m,)."""
    return vertex_to_face(mesh) @ as_vertex_function(mesh, f)


@takes_mesh
def face_to_vertex_values(mesh: TriMesh, f_faces: npt.ArrayLike) -> np.ndarray:
    """I_V^F 𝐟: area-weighted average of the faces around each vertex, (m,) -> (n,)."""
    return face_to_vertex(mesh) @ as_face_function(mesh, f_faces)
