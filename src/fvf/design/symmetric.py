"""Map-consistent (e.g. symmetric) vector-field design in a reduced basis.

A field v is consistent with a map φ iff ⟨v, ∇(f∘φ)⟩ = ⟨v, ∇f⟩∘φ for all f, i.e. its
operator commutes with the functional map: D_v C = C D_v (Azencot et al. 2017; the
chapter's Fig. 1, §1). This needs no differential of the map. In the reduced basis,
v = Σ a_j ψ_j over smooth orthonormal fields ψ_j, and the design minimizes

    E(a) = aᵀ S a / s + μ ‖Σ_j a_j (D̂_j C − C D̂_j)‖_F² / q,   aᵀ a = 1,

with S the connection-Laplacian smoothness of the fields (Knöppel et al. 2013) and s, q
the mean diagonals of the two forms (so μ is dimensionless).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from ..errors import FieldShapeError
from ..spectral.basis import SpectralBasis
from .connection import connection_laplacian
from .killing import orthonormal_fields, smooth_field_space

__all__ = ["map_consistent_field", "consistency_residual"]


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
) -> tuple[np.ndarray, float]:
    """The smoothest unit field whose operator commutes with a self-map's functional map.

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
        The field space (default :func:`fvf.design.killing.smooth_field_space`).

    Returns
    -------
    v : float64 (m, 3)
        Unit L2 norm (eq. 26); sign: largest-magnitude component positive. For a map that
        every field commutes with (``C = I``) the consistency term vanishes and ``v`` is
        the smoothest field of the space.
    residual : float
        :func:`consistency_residual` of v.
    """
    mesh = basis.mesh
    C = np.asarray(C, dtype=float)
    if C.shape != (basis.k, basis.k):
        raise FieldShapeError(f"C must be ({basis.k}, {basis.k}); got {C.shape}")
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
    return v, consistency_residual(basis, C, v)
