"""Killing fields: the fields whose operators most nearly commute with the Laplacian.

A field is Killing iff its flow is an isometry iff D_v commutes with L (Azencot et al.
2013). In the reduced basis L̂ = diag(λ), so [D̂_v, L̂]_ij = (λ_j − λ_i) D̂_v,ij, and the
commutator energy is a quadratic form in the coefficients of v over a space of smooth
fields. Its smallest generalized eigenvectors (against the fields' L2 Gram matrix) are
the most nearly Killing fields: the three rotations on a sphere, the one rotation about the
axis on a surface of revolution.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ..calculus import rotate
from ..errors import FieldShapeError, ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.trimesh import TriMesh
from ..spectral.basis import SpectralBasis, gradient_field_basis
from .connection import smoothest_fields

__all__ = ["killing_fields", "commutator_energy", "orthonormal_fields", "smooth_field_space"]


@takes_mesh
def orthonormal_fields(mesh: TriMesh, fields: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """An L2-orthonormal basis (⟨u, v⟩ = Σ A_F u·v, eq. 26) of the span of some fields.

    Parameters
    ----------
    fields : float64 (p, m, 3)

    Returns
    -------
    float64 (r, m, 3), r <= p: zero fields and near-dependent directions (Gram
    eigenvalues below ``rtol`` times the largest, after each field is scaled to unit
    norm, so fields of very different magnitudes are all kept) are dropped.
    """
    a = mesh.face_areas
    norms = np.sqrt(np.einsum("t,ptc,ptc->p", a, fields, fields, optimize=True))
    fields = fields[norms > 0] / norms[norms > 0, None, None]
    G = np.einsum("t,ptc,qtc->pq", a, fields, fields, optimize=True)
    s, U = np.linalg.eigh(G)
    keep = s > rtol * s.max()
    W = U[:, keep] / np.sqrt(s[keep])  # (p, r)
    return np.einsum("pr,ptc->rtc", W, fields, optimize=True)


def smooth_field_space(
    basis: SpectralBasis, n_functions: int | None = None, n_smooth: int = 12
) -> np.ndarray:
    """Orthonormal smooth tangent fields: grad φ_i, J grad φ_i and connection eigenfields.

    The gradient and rotated-gradient fields of the first ``n_functions`` non-constant
    eigenfunctions span smooth exact and co-exact fields; the ``n_smooth`` smoothest
    eigenfields of the connection Laplacian (and their J-rotations) add the harmonic
    fields a surface of genus > 0 needs (a torus's rotation is not J grad of a function).

    Returns
    -------
    float64 (r, m, 3), L2-orthonormal.
    """
    mesh = basis.mesh
    q = min(basis.k - 1, 15) if n_functions is None else int(n_functions)
    parts = [gradient_field_basis(basis, q)]
    if n_smooth > 0:
        _, smooth = smoothest_fields(mesh, n_smooth)
        parts.append(smooth)
        parts.append(np.stack([rotate(mesh, s) for s in smooth]))
    return orthonormal_fields(mesh, np.concatenate(parts))


def commutator_energy(basis: SpectralBasis, v: np.ndarray) -> float:
    """|M|² ‖D̂_v L̂ − L̂ D̂_v‖_F² / (λ_max² ‖v‖²): scale-free, 0 for a Killing field.

    ‖v‖² = Σ A_F |v|² (eq. 26), so ‖v‖² / |M| is the mean squared speed and the energy
    is |M| ‖[D̂_v, L̂]‖² / (λ_max² · mean |v|²): invariant under X -> s X and v -> c v
    (``tests/test_covariance.py``).

    Parameters
    ----------
    basis : SpectralBasis
    v : array_like (m, 3)
        Tangent field per face (a normal component is projected away with a warning).

    Raises
    ------
    FieldShapeError
        Wrong shape, non-finite values, or v = 0 (the scale-free energy is then 0/0).
    """
    v = as_face_field(basis.mesh, v, "v")
    if not np.any(v):
        raise FieldShapeError(
            "v is zero, so its scale-free commutator energy (divided by ‖v‖²) is undefined. "
            "Fix: pass a non-zero field."
        )
    D = basis.reduced_D(v, tangent="ignore")
    lam = basis.eigenvalues
    C = D * (lam[None, :] - lam[:, None])
    norm2 = float(np.einsum("t,tc,tc->", basis.mesh.face_areas, v, v))
    return float(basis.mesh.total_area**2 * (C**2).sum() / (lam[-1] ** 2 * norm2))


@takes_mesh
def killing_fields(
    mesh: TriMesh,
    count: int,
    *,
    k: int = 40,
    basis: SpectralBasis | None = None,
    fields: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` most nearly Killing fields of a mesh.

    Minimizes the commutator energy of :func:`commutator_energy` over a space of smooth
    tangent fields (default :func:`smooth_field_space`), as a generalized symmetric
    eigenproblem Q a = e G a with G the fields' L2 Gram matrix.

    Parameters
    ----------
    mesh : TriMesh
    count : int
    k : int
        Size of the Laplace–Beltrami basis in which D_v and L are reduced.
    basis : SpectralBasis, optional
        Reuse an existing basis (then ``k`` is ignored).
    fields : float64 (p, m, 3), optional
        The field space; it is L2-orthonormalized first.

    Returns
    -------
    energies : float64 (count,)
        Ascending, scale-free (see :func:`commutator_energy`).
    fields : float64 (count, m, 3)
        Unit L2 norm; each field's sign makes its largest-magnitude component positive.
    """
    basis = SpectralBasis(mesh, k) if basis is None else basis
    psi = smooth_field_space(basis) if fields is None else orthonormal_fields(mesh, fields)
    if not 1 <= count <= len(psi):
        raise ParameterError(f"count must be in [1, {len(psi)}] (the field space's dimension)")
    lam = basis.eigenvalues
    K = basis.reduced_D_many(psi) * (lam[None, None, :] - lam[None, :, None])  # (r, k, k)
    K = K.reshape(len(psi), -1)
    Q = K @ K.T * mesh.total_area**2 / lam[-1] ** 2  # orthonormal fields: G = I
    energies, coef = sla.eigh(Q, subset_by_index=[0, count - 1])
    out = np.einsum("rj,rtc->jtc", coef, psi, optimize=True)
    flat = out.reshape(count, -1)
    signs = np.sign(flat[np.arange(count), np.abs(flat).argmax(axis=1)])
    return np.maximum(energies, 0.0), out * signs[:, None, None]
