r"""Cross fields as the parameterization sees them: one angle per face, four directions.

A cross field (4-direction field) is stored as one representative tangent vector per face,
u (m, 3); the other three directions are J u, −u, −J u. In the complex frame of a face
(``mesh.face_bases``) the representative has angle φ_t and the cross is the power
z_t = e^{4iφ_t} (the power representation of Palacios & Zhang 2007, Knöppel et al. 2013).

:func:`cross_field_angles` turns a user field into those angles. :func:`default_cross_field`
is the field the parameterization uses when none is given: the minimizer of

.. math::

    E(z) = \sum_{e=(s,t)} w_e |z_s - r_{st}^4 z_t|^2 + \lambda \sum_t A_t |z_t - q_t|^2,

with the Levi-Civita transport r_st and weights of :func:`fvf.design.connection_pairs`
and q_t the fourth power of the principal-curvature frame of face t, weighted by the
curvature anisotropy |κ₁ − κ₂| (``align="curvature"``), or the smoothest unit cross field
(``align="smooth"``: the smallest eigenvector of the same energy without the data term).
It is a small, self-contained stand-in for the cross-field designer of ``fvf.design``.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..design.connection import complex_to_real, connection_pairs, real_to_complex
from ..errors import ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.trimesh import TriMesh
from ..numerics.eigen import SPDFactor, factor_spd

__all__ = ["cross_field_angles", "default_cross_field", "face_shape_operators"]

Alignment = Literal["curvature", "smooth"]
ALIGNMENTS = ("curvature", "smooth")
#: Weight of the curvature data term relative to the smoothness term, per unit of
#: (mean edge length)²: λ = CURVATURE_WEIGHT / h̄².
CURVATURE_WEIGHT = 0.1
#: Relative anisotropy |κ₁ − κ₂| / (|κ₁| + |κ₂|) from which the curvature target gets full
#: weight; below it the target blends into the smoothest field.
ANISOTROPY_FULL = 0.25


@takes_mesh
def cross_field_angles(mesh: TriMesh, field: npt.ArrayLike) -> np.ndarray:
    """Angle φ_t of a per-face representative vector in the face frame, float64 (m,).

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3)
        One tangent vector per face (any of the four directions of the cross). Checked by
        :func:`fvf.as_face_field`; zero vectors raise :class:`fvf.FieldValueError`.
    """
    u = as_face_field(mesh, field, "field")
    z = mesh.to_complex(u)
    zero = np.abs(z) <= 1e-12 * max(float(np.abs(z).max(initial=0.0)), 1e-300)
    if zero.any():
        from ..errors import FieldValueError, format_indices

        raise FieldValueError(
            f"the cross field is zero on faces {format_indices(np.flatnonzero(zero))}; "
            "a parameterization needs a direction on every face (design a field without "
            "zeros, e.g. fvf.seamless_parameterization(mesh) with the default field)"
        )
    return np.angle(z)


def _connection4(mesh: TriMesh) -> sp.csr_array:
    """Hermitian (m, m) matrix of Σ_e w_e |z_s − r_st⁴ z_t|² (the n = 4 connection energy)."""
    pairs, r, w = connection_pairs(mesh, "knoppel")
    s, t = pairs[:, 0], pairs[:, 1]
    r4 = r**4
    m = mesh.n_faces
    rows = np.concatenate([s, t, s, t])
    cols = np.concatenate([s, t, t, s])
    vals = np.concatenate([w, w, -w * r4, -w * np.conj(r4)]).astype(np.complex128)
    return sp.csr_array(sp.coo_array((vals, (rows, cols)), shape=(m, m)))


def face_shape_operators(mesh: TriMesh) -> np.ndarray:
    """Per-face shape operator in the face frame, float64 (m, 2, 2), symmetric.

    Least-squares fit of S e_i ≈ Δn_i over the three edges e_i of each face, Δn_i the
    difference of the area-weighted vertex normals at the edge's ends (Rusinkiewicz 2004,
    "Estimating curvatures and their derivatives on triangle meshes"), all in the face's
    basis ``mesh.face_bases``.
    """
    F = mesh.faces
    N = np.zeros((mesh.n_vertices, 3))
    fn = mesh.face_normals * mesh.face_areas[:, None]
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    B = mesh.face_bases  # (m, 2, 3)
    e = mesh.face_edge_vectors  # (m, 3, 3): edge opposite corner i, x_{i+2} - x_{i+1}
    dn = N[F[:, [2, 0, 1]]] - N[F[:, [1, 2, 0]]]
    ex, ey = np.einsum("mij,mkj->mik", e, B).transpose(2, 0, 1)  # (m, 3) each
    nx, ny = np.einsum("mij,mkj->mik", dn, B).transpose(2, 0, 1)
    # unknowns (a, b, c) of S = [[a, b], [b, c]]: rows a ex + b ey = nx, b ex + c ey = ny
    M = np.zeros((mesh.n_faces, 6, 3))
    M[:, :3, 0], M[:, :3, 1] = ex, ey
    M[:, 3:, 1], M[:, 3:, 2] = ex, ey
    rhs = np.concatenate([nx, ny], axis=1)
    MtM = np.einsum("mki,mkj->mij", M, M)
    Mtb = np.einsum("mki,mk->mi", M, rhs)
    ridge = 1e-12 * np.trace(MtM, axis1=1, axis2=2)[:, None, None] * np.eye(3)
    abc = np.linalg.solve(MtM + ridge, Mtb[..., None])[..., 0]
    S = np.empty((mesh.n_faces, 2, 2))
    S[:, 0, 0], S[:, 0, 1], S[:, 1, 0], S[:, 1, 1] = abc[:, 0], abc[:, 1], abc[:, 1], abc[:, 2]
    return S


def _curvature_target(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Unit targets q_t = e^{4iθ_t} (θ_t a principal direction) and weights a_t².

    a_t = |κ₁ − κ₂| / (|κ₁| + |κ₂|) ∈ [0, 1] is the relative anisotropy of face t; the
    weight is min(1, a_t / ANISOTROPY_FULL)².
    """
    S = face_shape_operators(mesh)
    z2 = (S[:, 0, 0] - S[:, 1, 1]) + 2j * S[:, 0, 1]  # |κ1 − κ2| e^{2iθ}
    mag = np.abs(z2)
    size = np.abs(np.linalg.eigvalsh(S)).sum(axis=1)
    floor = 1e-12 * max(float(size.max(initial=0.0)), 1e-300)
    aniso = mag / np.maximum(size, floor)
    return z2**2 / np.maximum(mag, floor) ** 2, np.clip(aniso / ANISOTROPY_FULL, 0.0, 1.0) ** 2


@takes_mesh
def default_cross_field(
    mesh: TriMesh, align: Alignment = "curvature", length_scale: float | None = None
) -> np.ndarray:
    """A cross field for the parameterization: representative vector per face, float64 (m, 3).

    Parameters
    ----------
    mesh : TriMesh
    align : {"curvature", "smooth"}
        ``"curvature"``: smooth and aligned with the principal curvature directions where
        the surface is anisotropic (the energy of the module docstring);
        ``"smooth"``: the smoothest unit cross field (smallest eigenvector).
    length_scale : float, optional
        Length below which curvature directions are smoothed out: λ = CURVATURE_WEIGHT /
        length_scale² (default: the mean edge length). A parameterization passes its
        target edge length, so that the field has no detail smaller than a quad.

    Returns
    -------
    u : float64 (m, 3)
        Unit tangent vector per face; the cross is {u, J u, −u, −J u}.
    """
    if align not in ALIGNMENTS:
        raise ParameterError(f"align must be one of {ALIGNMENTS}; got {align!r}")
    L = _connection4(mesh)
    A = mesh.face_areas
    ell = mesh.mean_edge_length if length_scale is None else float(length_scale)
    lam = CURVATURE_WEIGHT / ell**2
    if align == "smooth":
        z = _smallest_eigenvector(L, A)
    else:
        # one factorization of L + λ[A] serves the smoothest field (shifted inverse
        # iteration) and the curvature-aligned solve
        fac = factor_spd(complex_to_real(L + sp.diags_array(lam * A)))
        z = _smallest_eigenvector(L, A, fac=fac)
        q, w = _curvature_target(mesh)
        target = w * q + (1.0 - w) * z / np.maximum(np.abs(z), 1e-300)
        rhs = lam * A * target
        zc = real_to_complex(fac.solve(np.stack([rhs.real, rhs.imag], axis=1).ravel()))
        if np.all(np.isfinite(zc)) and np.abs(zc).max() > 0:
            z = zc
    phi = np.angle(z) / 4.0
    return mesh.from_complex(np.exp(1j * phi))


def _smallest_eigenvector(
    L: sp.csr_array, A: np.ndarray, iterations: int = 8, fac: SPDFactor | None = None
) -> np.ndarray:
    """Inverse iteration for the smallest eigenvector of L z = λ [A] z (seeded start).

    ``fac``: a factorization of the real form of L + σ[A] (σ ≥ 0) to iterate with;
    default σ = 10⁻⁸ max|diag L| / mean A.
    """
    m = L.shape[0]
    if fac is None:
        shift = 1e-8 * float(abs(L.diagonal()).max()) / float(A.mean())
        fac = factor_spd(complex_to_real(L + shift * sp.diags_array(A)))
    rng = np.random.default_rng(0)
    z = rng.standard_normal(m) + 1j * rng.standard_normal(m)
    for _ in range(iterations):
        w = A * z
        z = real_to_complex(fac.solve(np.stack([w.real, w.imag], axis=1).ravel()))
        z /= np.sqrt(np.sum(A * np.abs(z) ** 2))
    return z
