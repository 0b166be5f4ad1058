"""Functional maps between meshes (or a mesh and itself) in Laplace–Beltrami bases.

A vertex-to-vertex map π: M_2 → M_1, given as ``p2p_21`` (n_2,) with
``p2p_21[j]`` the vertex of mesh 1 that vertex j of mesh 2 maps to, pulls functions back:
f ↦ f ∘ π. In the bases Φ_1 (n_1, k_1) and Φ_2 (n_2, k_2) this is the functional map
C_12 = Φ_2ᵀ [A_V2] Π_21 Φ_1 (k_2, k_1), mapping coefficients on mesh 1 to mesh 2
(Ovsjanikov et al. 2012; the direction convention of pyFM). A field v on a mesh with a
self-map is consistent with it iff D_v C = C D_v (Azencot et al. 2017; the chapter's Fig. 1).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..errors import FieldShapeError, format_indices
from ..mesh.convert import MeshLike, as_mesh
from .basis import SpectralBasis

__all__ = ["functional_map", "functional_map_from_bases", "map_quality", "check_p2p"]


def split_sizes(k: int | tuple[int, int] | None) -> tuple[int | None, int | None]:
    """(k_1, k_2) of a functional-map size given once for both bases or as a pair."""
    if isinstance(k, tuple | list | np.ndarray):
        k1, k2 = k
        return k1, k2
    return k, k


def check_p2p(p2p_21: npt.ArrayLike, n_1: int, n_2: int, name: str = "p2p_21") -> np.ndarray:
    """Validate a vertex map from mesh 2 to mesh 1: int64 (n_2,) with values in [0, n_1);
    ``name`` is the argument's name in the error."""
    p = np.asarray(p2p_21)
    if p.shape != (n_2,) or not np.issubdtype(p.dtype, np.integer):
        raise FieldShapeError(
            f"{name} must be an integer array of shape ({n_2},) (one vertex of mesh 1 per "
            f"vertex of mesh 2); got {p.dtype} {p.shape}."
        )
    bad = np.flatnonzero((p < 0) | (p >= n_1))
    if bad.size:
        raise FieldShapeError(
            f"{name} entries at {format_indices(bad)} are outside [0, {n_1}) (mesh 1 has "
            f"{n_1} vertices)."
        )
    return p.astype(np.int64)


def functional_map_from_bases(
    basis_1: SpectralBasis, basis_2: SpectralBasis, p2p_21: npt.ArrayLike
) -> np.ndarray:
    """C_12 = Φ_2ᵀ [A_V2] Φ_1[p2p_21]: float64 (k_2, k_1), coefficients on 1 -> on 2."""
    p = check_p2p(p2p_21, basis_1.mesh.n_vertices, basis_2.mesh.n_vertices)
    return basis_2.project(basis_1.eigenvectors[p])


def functional_map(mesh_1: MeshLike, mesh_2: MeshLike, p2p_21: npt.ArrayLike, k: int) -> np.ndarray:
    """The k x k functional map C_12 of a vertex map p2p_21 (mesh 2 -> mesh 1).

    One-off form of :func:`functional_map_from_bases` (computes both bases).

    Returns
    -------
    float64 (k, k)
    """
    same = mesh_2 is mesh_1
    mesh_1 = as_mesh(mesh_1)
    mesh_2 = mesh_1 if same else as_mesh(mesh_2)
    b1 = SpectralBasis(mesh_1, k)
    b2 = b1 if mesh_2 is mesh_1 else SpectralBasis(mesh_2, k)
    return functional_map_from_bases(b1, b2, p2p_21)


def map_quality(C_12: np.ndarray, eigenvalues_1: np.ndarray, eigenvalues_2: np.ndarray) -> dict:
    """Standard quality measures of a functional map (0 is ideal for the first three).

    Returns
    -------
    dict
        ``orthogonality``: ‖CᵀC − I‖_F / √k (area preservation);
        ``laplacian_commutativity``: ‖C Λ_1 − Λ_2 C‖_F / (‖C‖_F λ_max) (isometry);
        ``off_diagonality``: energy of C outside a band |i − j| ≤ 2, relative to ‖C‖_F²;
        ``diagonal``: the diagonal of C (±1 for a self-symmetry's eigenfunctions).

    Raises
    ------
    FieldShapeError
        C_12 not of shape (k_2, k_1) for k_1, k_2 eigenvalues, or non-finite values.
    """
    C = np.asarray(C_12, dtype=float)
    l1, l2 = np.asarray(eigenvalues_1, dtype=float), np.asarray(eigenvalues_2, dtype=float)
    if C.ndim != 2 or l1.ndim != 1 or l2.ndim != 1 or C.shape != (l2.size, l1.size):
        raise FieldShapeError(
            f"C_12 must have shape (len(eigenvalues_2), len(eigenvalues_1)) = "
            f"({l2.size}, {l1.size}); got {C.shape}"
        )
    if not (np.isfinite(C).all() and np.isfinite(l1).all() and np.isfinite(l2).all()):
        raise FieldShapeError("C_12 and the eigenvalues must be finite")
    k2, k1 = C.shape
    k = min(k1, k2)
    I = np.eye(k1)
    band = np.abs(np.subtract.outer(np.arange(k2), np.arange(k1))) <= 2
    lam = max(abs(l1[-1]), abs(l2[-1]), 1e-300)
    return {
        "orthogonality": float(np.linalg.norm(C.T @ C - I) / np.sqrt(k)),
        "laplacian_commutativity": float(
            np.linalg.norm(C * l1[None, :] - l2[:, None] * C) / (np.linalg.norm(C) * lam)
        ),
        "off_diagonality": float((C[~band] ** 2).sum() / max((C**2).sum(), 1e-300)),
        "diagonal": np.diag(C)[:k].copy(),
    }
