"""Map-consistent (e.g. symmetric) vector-field design in a reduced basis.

A field v is consistent with a map φ iff ⟨v, ∇(f∘φ)⟩ = ⟨v, ∇f⟩∘φ for all f, i.e. its
operator commutes with the functional map: D_v C = C D_v (Azencot et al. 2017; the
chapter's Fig. 1, §1). This needs no differential of the map. In the reduced basis,
v = Σ a_j ψ_j over smooth orthonormal fields ψ_j, and the design minimizes

    E(a) = aᵀ S a / s + μ ‖Σ_j a_j (D̂_j C − C D̂_j)‖_F² / q,   aᵀ a = 1,

with S the connection-Laplacian smoothness of the fields (Knöppel et al. 2013) and s, q
the mean diagonals of the two forms (so μ is dimensionless).

N-direction fields (``n = N ≥ 2``). An N-field is not a vector field, so it has no
operator D_v; its consistency with φ is the same statement for the map's action on its
power representation z (:mod:`fvf.design.nfields`): φ_* z = z. The map acts face by face
through its differential, recovered from the functional map: the vertex map
i ↦ φ(i) = argmin_j ‖(Φ C)_i − Φ_j‖ (nearest neighbour in the spectral embedding, the
usual conversion of a functional map to a pointwise one), the face t' whose vertices are
φ(t)'s (faces whose image is not a face are left out), and the closest rotation or
reflection R_t to the linear map between the two triangles (polar decomposition). On
powers it acts as z ↦ e^{iNα_t} z for a rotation by α_t and z ↦ e^{iNα_t} z̄ for a
reflection (orientation-reversing maps, e.g. a mirror symmetry). The design minimises

    E(z) = z* L_N z / s + μ Σ_t A_t |z_{t'} − R_t·z_t|² / q,   ‖z‖_{A_F} = 1,

the smallest eigenpair of a real (2m, 2m) pencil (the reflection is only real-linear).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..errors import FieldShapeError, ParameterError
from ..mesh.inputs import as_direction_count
from ..mesh.nfield import NField
from ..mesh.trimesh import TriMesh
from ..numerics.eigen import smallest_eigenpairs
from ..spectral.basis import SpectralBasis
from .connection import complex_to_real, connection_laplacian, real_connection_laplacian
from .killing import orthonormal_fields, smooth_field_space
from .nfields import from_power

__all__ = ["map_consistent_field", "consistency_residual", "power_pushforward"]


def consistency_residual(basis: SpectralBasis, C: np.ndarray, v: npt.ArrayLike) -> float:
    """‖D̂_v C − C D̂_v‖_F / (‖D̂_v‖_F ‖C‖_2): 0 for a field consistent with the map."""
    D = basis.reduced_D(v)
    return float(np.linalg.norm(D @ C - C @ D) / (np.linalg.norm(D) * np.linalg.norm(C, 2)))


def map_consistent_field(
    basis: SpectralBasis,
    C: npt.ArrayLike,
    *,
    weight: float = 10.0,
    fields: np.ndarray | None = None,
    n: int = 1,
) -> tuple[np.ndarray, float]:
    """The smoothest unit field whose operator commutes with a self-map's functional map.

    For ``n ≥ 2`` the smoothest N-direction field invariant under the map's action on
    power fields (module docstring; :func:`power_pushforward`).

    Parameters
    ----------
    basis : SpectralBasis
        k eigenpairs of the mesh.
    C : array_like (k, k)
        Functional map of a self-map (e.g. a symmetry), from
        :func:`fvf.functional_map_from_bases` with ``basis`` on both sides.
    weight : float
        μ: the weight of consistency against smoothness (dimensionless).
    fields : float64 (p, m, 3), optional
        The field space (default :func:`fvf.design.killing.smooth_field_space`); n = 1
        only.
    n : int
        Symmetry order N ≥ 1 (1: vector fields, the operator-commutation design above).

    Returns
    -------
    v : float64 (m, 3)
        Unit L2 norm (eq. 26); sign: largest-magnitude component positive. For a map that
        every field commutes with (``C = I``) the consistency term vanishes and ``v`` is
        the smoothest field of the space. For n ≥ 2 one representative per face
        (:func:`fvf.design.nfields.from_power`) with Σ A_F |v|² = 1.
    residual : float
        n = 1: :func:`consistency_residual` of v. n ≥ 2: ‖z_{t'} − R_t z_t‖ / ‖z‖ (A_F
        norms over the matched faces).

    Raises
    ------
    FieldShapeError
        C not (k, k).
    DirectionCountError
        n not an integer ≥ 1.
    ParameterError
        ``fields`` with n ≥ 2, or no face of the mesh maps onto a face.
    """
    mesh = basis.mesh
    C = np.asarray(C, dtype=float)
    if C.shape != (basis.k, basis.k):
        raise FieldShapeError(f"C must be ({basis.k}, {basis.k}); got {C.shape}")
    n = as_direction_count(n)
    if n != 1:
        if fields is not None:
            raise ParameterError("fields= applies to n = 1 only.")
        return _consistent_nfield(basis, C, weight, n)
    psi = smooth_field_space(basis) if fields is None else orthonormal_fields(mesh, fields)
    Z = np.stack([mesh.to_complex(p) for p in psi])  # (r, m)
    S = np.real(Z.conj() @ (connection_laplacian(mesh) @ Z.T))  # (r, r)
    S = 0.5 * (S + S.T)
    D = basis.reduced_D_many(psi)  # (r, k, k)
    K = (D @ C - C @ D).reshape(len(psi), -1)
    Q = K @ K.T
    q = float(np.mean(np.diag(Q)))
    # a map that commutes with every field (the identity, C = I) constrains nothing:
    # then the consistency term is zero and the result is the smoothest unit field
    E = S / np.mean(np.diag(S)) + (weight * Q / q if q > 0 else 0.0)
    _, a = sla.eigh(E, subset_by_index=[0, 0])
    v = np.einsum("r,rtc->tc", a[:, 0], psi)
    flat = v.ravel()
    v *= np.sign(flat[np.abs(flat).argmax()])
    return NField(v, 1), consistency_residual(basis, C, v)


# ---------------------------------------------------------------------------- N-fields
def _vertex_map(basis: SpectralBasis, C: np.ndarray) -> np.ndarray:
    """φ(i): nearest row of Φ to (Φ C)_i (functional map → pointwise map), int64 (n,)."""
    Phi = basis.eigenvectors
    return cKDTree(Phi).query(Phi @ C)[1].astype(np.int64)  # Φ C ≈ Φ[φ] row by row


def power_pushforward(
    mesh: TriMesh, vertex_map: npt.ArrayLike, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The action of a vertex self-map on N-field powers, face by face.

    Parameters
    ----------
    mesh : TriMesh
    vertex_map : array_like of int, (n_vertices,)
        φ(i) for every vertex.
    n : int
        Symmetry order N.

    Returns
    -------
    source, target : int64 (k,)
        Faces t and t' = φ(t) (only faces whose image vertices form a face of the mesh).
    rotation : complex128 (k,)
        e^{iNα_t}: φ_* z at t' is ``rotation * z_t`` (or its conjugate, see ``reflect``),
        z in the frames of ``mesh.face_bases``.
    reflect : bool (k,)
        True where φ reverses the orientation of t.
    """
    n = as_direction_count(n)
    p = np.asarray(vertex_map, dtype=np.int64)
    F = mesh.faces
    img = p[F]  # (m, 3)
    nv = mesh.n_vertices
    key_sorted = np.sort(F, axis=1)
    keys = (key_sorted[:, 0] * nv + key_sorted[:, 1]) * nv + key_sorted[:, 2]
    order = np.argsort(keys)
    img_sorted = np.sort(img, axis=1)
    want = (img_sorted[:, 0] * nv + img_sorted[:, 1]) * nv + img_sorted[:, 2]
    pos = np.minimum(np.searchsorted(keys, want, sorter=order), len(keys) - 1)
    target = order[pos]
    ok = keys[target] == want
    src, tgt = np.flatnonzero(ok), target[ok]
    X, B = mesh.vertices, mesh.face_bases

    def local_edges(tri: np.ndarray, frame: np.ndarray) -> np.ndarray:  # (k, 2, 2)
        P = X[tri]
        E = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)  # (k, 3, 2)
        return np.einsum("kij,kjl->kil", frame, E)

    Es = local_edges(F[src], B[src])
    Et = local_edges(img[src], B[tgt])  # images of t's vertices, in t''s frame
    A = Et @ np.linalg.inv(Es)  # differential, (k, 2, 2)
    reflect = np.linalg.det(A) < 0
    rot = (A[:, 0, 0] + A[:, 1, 1]) + 1j * (A[:, 1, 0] - A[:, 0, 1])
    ref = (A[:, 0, 0] - A[:, 1, 1]) + 1j * (A[:, 1, 0] + A[:, 0, 1])
    c = np.where(reflect, ref, rot)
    c = c / np.abs(c)
    return src, tgt, c**n, reflect


def _consistent_nfield(
    basis: SpectralBasis, C: np.ndarray, weight: float, n: int
) -> tuple[np.ndarray, float]:
    mesh = basis.mesh
    m = mesh.n_faces
    src, tgt, rot, reflect = power_pushforward(mesh, _vertex_map(basis, C), n)
    if src.size == 0:
        raise ParameterError(
            "no face maps onto a face under the map recovered from C, so the N-field "
            "consistency cannot be measured. Fix: a more accurate functional map (larger k), "
            "or n=1 (operator commutation)."
        )
    # D z = z_{t'} − R_t z_t as a real (2k, 2m) operator on interleaved (Re, Im)
    k = src.size
    conj = sp.diags_array(np.tile([1.0, -1.0], m))
    rows = np.arange(k)
    Rc = complex_to_real(sp.coo_array((np.where(reflect, rot, 0), (rows, src)), (k, m)))
    Rn = complex_to_real(sp.coo_array((np.where(reflect, 0, rot), (rows, src)), (k, m)))
    S = complex_to_real(sp.coo_array((np.ones(k), (np.arange(k), tgt)), shape=(k, m)))
    D = (S - Rn - Rc @ conj).tocsr()
    A2 = np.repeat(mesh.face_areas[src], 2)
    Q = (D.T @ sp.diags_array(A2) @ D).tocsr()
    L = (
        real_connection_laplacian(mesh)
        if n == 1
        else complex_to_real(connection_laplacian(mesh, n=n))
    )
    s = float(np.mean(L.diagonal())) or 1.0
    q = float(np.mean(Q.diagonal())) or 1.0
    E = sp.csr_array(L / s + weight * Q / q)
    E = (0.5 * (E + E.T)).tocsr()
    _, X = smallest_eigenpairs(E, np.repeat(mesh.face_areas, 2), 1)
    z = X[0::2, 0] + 1j * X[1::2, 0]
    resid = np.sqrt(A2 @ (D @ X[:, 0]) ** 2) / np.sqrt(np.repeat(mesh.face_areas, 2) @ X[:, 0] ** 2)
    return from_power(mesh, z, n), float(resid)
