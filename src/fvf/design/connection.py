r"""Face connection Laplacians: the discrete Levi-Civita connection on piecewise-constant fields.

A tangent per-face field u (m, 3) is written in the complex coordinates of
``mesh.face_bases``, ``z = mesh.to_complex(u)`` (m,), so that multiplying by ``1j`` is the
rotation J. This module assembles the smoothness energy of a field,

.. math::

    E(z) = \sum_{(s,t)} w_{st} \, |z_s - r_{st} z_t|^2 = z^* L z ,

where the sum runs over coupled pairs of faces, r_st (|r_st| = 1) is the parallel transport
of t's frame into s's frame and w_st > 0 a weight. L is the (m, m) complex Hermitian
positive semidefinite **connection Laplacian**; with the face-area mass [A_F] its low
eigenpairs approximate those of the Bochner (rough) Laplacian ∇*∇ on tangent fields, and
E(z) approximates the Dirichlet energy ∫|∇u|² dA of the covariant derivative.

Two couplings (``kind``)
------------------------
``"knoppel"``
    The n = 1 smoothness energy of Knöppel, Crane, Pinkall & Schröder (2013, "Globally
    optimal direction fields"), on faces: one term per interior edge e between faces s and
    t. The transport is the discrete Levi-Civita connection: unfold t about the shared
    edge into s's plane, i.e. r_st = exp(i(θ_s(e) − θ_t(e))) where θ_f(e) is the angle of
    the edge vector (from ``edges[e, 0]`` to ``edges[e, 1]``) in face f's complex frame.
    Intrinsic: the transport and the weights depend on edge lengths only.
``"singer_wu"``
    A vector-diffusion-maps coupling (Singer & Wu 2012, "Vector diffusion maps and the
    connection Laplacian") over the 1-ring of faces: one term per pair of faces sharing at
    least one vertex (about 12 per face on a regular mesh). The transport of two faces
    sharing only a vertex is Singer–Wu's alignment: the rotation of SO(2) closest
    (orthogonal Procrustes) to the 2 × 2 matrix M_ij = b_s,i · b_t,j of frame inner
    products, r = α/|α| with α = (M_00 + M_11 + i(M_10 − M_01))/2; a pair folded onto
    itself (|α| < 1e-3, e.g. across a sharp crease) is left uncoupled. Faces sharing an
    edge use the unfolding transport of ``"knoppel"`` (which is what Procrustes gives for
    them unless they are folded over). Extrinsic: vertex-only pairs use the embedding.

Weights
-------
For a smooth field, z_s − r_st z_t ≈ ∇_{d_st} u, the covariant derivative along the
displacement d_st between the points where z_s and z_t are sampled, so the energy is
consistent with ∫|∇u|² when the weights reproduce the second moments,
Σ w_st d_st d_stᵀ ≈ area · I locally, *and* the first moments cancel at every face,
Σ_t' w_tt' d_tt' ≈ 0 (otherwise the discrete minimisers add grid-scale oscillations and
the spectrum converges to wrong values: measured with moment-matched centroid weights,
λ_1 → 0.984 instead of 1 on icospheres and 0.24 instead of 0.51 on a torus).

``"knoppel"`` uses the diagonal Hodge star on dual edges of discrete exterior calculus,
the dual of the cotangent weights of Knöppel et al.:

.. math::

    w_e = \frac{|e|}{\max(|\ell^*_e|, \tau \delta_e)}, \qquad
    \ell^*_e = \tfrac12 |e| (\cot\alpha_s + \cot\alpha_t), \qquad
    \delta_e = \frac{2 (A_s + A_t)}{3 |e|},

with α_s, α_t the angles opposite e, ℓ*_e the signed distance between the two
circumcentres, δ_e the distance between the centroids measured across the edge and
τ = :data:`DUAL_FLOOR` = 1e-3. The dual edge is orthogonal to e, so both moment
conditions hold exactly on a Delaunay mesh when z_t is read as the field at the
**circumcentre** of t (:func:`sample_points`): the energy of a linear field on a flat
Delaunay mesh is exact and the spectrum converges at second order (icosphere). The guard
keeps every weight positive and finite, so L is PSD on every mesh: a cocircular pair (a
quad of a grid or of a torus of revolution, ℓ* = 0) is coupled 1000 times more strongly
than usual — it behaves as one quadrilateral cell, which is again a consistent orthogonal
scheme (torus spectrum within 1.5e-4 of the separated-variables reference) — and a
non-Delaunay edge (ℓ* < 0) uses |ℓ*|, which is *not* consistent: on meshes with a fixed
fraction of non-Delaunay edges (the jittered spheres of the tests) the energies and
eigenvalues keep an O(1) bias of a few percent (measured in ``tests/design/test_connection.py``).
On an equilateral mesh w_e = √3.

``"singer_wu"`` has about 12 couplings per face, enough freedom to match moments face by
face. Every face t gets a share a_tj ≥ 0 of each of its couplings j, d_tj being the tangent
projection of c_j − c_t (centroids) in t's frame:

* a_tj = k_tj (λ0 + Re(conj(λ1) û_tj²)), û = d/|d|, with the Gaussian kernel
  k_tj = exp(−|d_tj|²/ε_t), ε_t the mean |d|² over t's ring, and (λ0, λ1) solving the
  3 × 3 moment system Σ_j a_tj d_tj d_tjᵀ = A_F(t) I;
* where that system is singular or a share falls below 1% of the trace-only share
  2 A_F(t) k_tj / Σ_j k_tj |d_tj|², the shares are blended towards the trace-only ones
  just enough to stay above it;
* w_st = a_ts + a_st.

The 1-ring is nearly symmetric, so first moments nearly cancel: the energy of a smooth
field sampled at the centroids converges at second order on regular, jittered and torus
meshes, and the spectrum to within a few tenths of a percent (measured in the tests).

Real form and restriction
-------------------------
:func:`real_connection_laplacian` is the (2m, 2m) real symmetric form in face-major local
coordinates ``[a0_0, a1_0, a0_1, a1_1, …]`` (``mesh.to_local(u).ravel()``), and
:func:`tangent_basis_matrix` the (3m, 2m) orthonormal basis B with
``u.ravel() = B @ mesh.to_local(u).ravel()``, so any energy E on flattened (3m,) fields
restricts to tangent fields as E_B = Bᵀ E B (the chapter's §4.4.2 notation).
"""

from __future__ import annotations

import warnings
from typing import Any, Literal, cast

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..calculus import face_rows_csr
from ..errors import (
    FieldShapeError,
    FvfError,
    ParameterError,
    SpectralFallbackWarning,
    SpectralSolveError,
)
from ..mesh.convert import takes_mesh
from ..mesh.geometry import centered_vertices, cross_rows, readonly, readonly_csr
from ..mesh.inputs import as_direction_count, as_face_field
from ..mesh.nfield import NField
from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import Backend
from ..numerics.inverse_iteration import inverse_iteration
from ..numerics.progress import ProgressCallback, make_progress, raised_by_callback

__all__ = [
    "ConnectionKind",
    "KINDS",
    "connection_pairs",
    "connection_laplacian",
    "real_connection_laplacian",
    "connection_mass",
    "connection_energy",
    "sample_points",
    "tangent_basis_matrix",
    "restrict_to_tangent",
    "smoothest_fields",
    "complex_to_real",
    "real_to_complex",
]

ConnectionKind = Literal["knoppel", "singer_wu"]
#: The couplings accepted by ``kind``.
KINDS: tuple[str, ...] = ("knoppel", "singer_wu")

#: Lower bound on each moment-matched share, relative to the trace-only share.
MIN_SHARE = 0.01
#: τ: the circumcentric dual length is floored at τ times the centroid distance δ_e.
DUAL_FLOOR = 1e-3
#: A moment matrix with det / (tr/3)^3 below this counts as singular.
_SINGULAR_RTOL = 1e-9
#: Vertex-only 1-ring pairs whose frame alignment |α| is below this are not coupled.
_FOLDED_ALIGNMENT = 1e-3
#: Meshes with at most this many faces use a dense eigensolver in smoothest_fields.
_DENSE_FACES = 600
EigenSolver = Literal["auto", "dense", "arpack", "lobpcg"]
#: Accepted values of ``solver`` in :func:`smoothest_fields`.
EIGEN_SOLVERS: tuple[str, ...] = ("auto", "dense", "arpack", "lobpcg")
#: ``solver="auto"`` uses LOBPCG preconditioned by one Cholesky factorization from this
#: many faces on (ARPACK shift-invert with SuperLU below).
LOBPCG_MIN_FACES = 20_000


def check_kind(kind: str) -> ConnectionKind:
    """``kind`` if it is one of :data:`KINDS`, else :class:`fvf.FvfError`."""
    if kind not in KINDS:
        raise FvfError(f"kind must be one of {KINDS}; got {kind!r}.")
    return cast(ConnectionKind, kind)


def _frame_coords(mesh: TriMesh, faces: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Complex coordinates of ambient vectors ``vec`` (k, 3) in the frames of ``faces`` (k,)."""
    B = mesh.face_bases[faces]  # (k, 2, 3)
    return np.einsum("kj,kj->k", B[:, 0], vec) + 1j * np.einsum("kj,kj->k", B[:, 1], vec)


def _unit(z: np.ndarray) -> np.ndarray:
    a = np.abs(z)
    return z / np.where(a > 0, a, 1.0)


# ---------------------------------------------------------------------------- couplings
def _corner_cotangents(mesh: TriMesh) -> np.ndarray:
    """cot of the interior angle at each corner, float64 (m, 3).

    At corner i the two edges leaving it are e_{i+2} = x_{i+1} − x_i and
    −e_{i+1} = x_{i+2} − x_i, and |e_{i+1} × e_{i+2}| = 2 A_F.
    """
    e = mesh.face_edge_vectors
    dots = -np.einsum("tij,tij->ti", e[:, [1, 2, 0]], e[:, [2, 0, 1]])
    return dots / (2.0 * mesh.face_areas)[:, None]


def _knoppel_pairs(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One pair per interior edge: unfolding transport and guarded circumcentric weights."""
    corners = mesh.edge_corners  # corner 3t + a opposite each edge, per side
    interior = np.flatnonzero((corners >= 0).all(axis=1))
    cs, ct = corners[interior, 0], corners[interior, 1]
    s, t = cs // 3, ct // 3
    X, E = mesh.vertices, mesh.edges[interior]
    ev = X[E[:, 1]] - X[E[:, 0]]
    es, et = _frame_coords(mesh, s, ev), _frame_coords(mesh, t, ev)
    r = _unit(es) * np.conj(_unit(et))  # exp(i(θ_s − θ_t))
    length = np.linalg.norm(ev, axis=1)
    cot = _corner_cotangents(mesh).ravel()
    dual = 0.5 * length * (cot[cs] + cot[ct])  # signed circumcentre distance ℓ*_e
    A = mesh.face_areas
    centroid_gap = 2.0 * (A[s] + A[t]) / (3.0 * length)  # δ_e
    w = length / np.maximum(np.abs(dual), DUAL_FLOOR * centroid_gap)
    return np.stack([s, t], axis=1), r, w


def _singer_wu_geometry(mesh: TriMesh) -> tuple[np.ndarray, ...]:
    """1-ring face pairs, transports, Gaussian kernels and displacements."""
    m, n = mesh.n_faces, mesh.n_vertices
    inc = sp.csr_array(
        (np.ones(3 * m), mesh.faces.ravel(), np.arange(0, 3 * m + 1, 3)), shape=(m, n)
    )
    share = sp.triu(inc @ inc.T, k=1).tocoo()
    s, t = share.row.astype(np.int64), share.col.astype(np.int64)
    n_shared = share.data.astype(np.int64)
    order = np.lexsort((t, s))
    s, t, n_shared = s[order], t[order], n_shared[order]
    # vertex-only neighbours: closest rotation to the frame inner products (Procrustes)
    Bf = mesh.face_bases
    M = np.einsum("kid,kjd->kij", Bf[s], Bf[t])  # M[i, j] = b_s,i . b_t,j: t -> s coords
    alpha = 0.5 * ((M[:, 0, 0] + M[:, 1, 1]) + 1j * (M[:, 1, 0] - M[:, 0, 1]))
    r = _unit(alpha)
    # edge neighbours: the unfolding transport (equal to Procrustes unless folded over)
    kp, kr, _ = _knoppel_pairs(mesh)
    lo, hi = np.minimum(kp[:, 0], kp[:, 1]), np.maximum(kp[:, 0], kp[:, 1])
    key = lo * m + hi
    korder = np.argsort(key)
    edge = n_shared == 2
    pos = korder[np.searchsorted(key, s[edge] * m + t[edge], sorter=korder)]
    r[edge] = np.where(kp[pos, 0] == s[edge], kr[pos], np.conj(kr[pos]))
    # drop vertex neighbours folded onto each other (no meaningful alignment)
    keep = edge | (np.abs(alpha) > _FOLDED_ALIGNMENT)
    s, t, r = s[keep], t[keep], r[keep]
    # centroids of the centred coordinates: their differences do not depend on where the
    # mesh sits (absolute centroids far from the origin carry ulp(|X|) errors)
    C = centered_vertices(mesh)[mesh.faces].mean(axis=1)
    d_s = _frame_coords(mesh, s, C[t] - C[s])
    d_t = _frame_coords(mesh, t, C[s] - C[t])
    # Gaussian kernel, bandwidth = mean squared distance over each face's ring
    P = s.size
    faces = np.concatenate([s, t])
    d2 = np.concatenate([np.abs(d_s) ** 2, np.abs(d_t) ** 2])
    cnt = np.bincount(faces, minlength=m)
    eps = np.bincount(faces, weights=d2, minlength=m) / np.maximum(cnt, 1)
    kern = np.exp(-d2 / np.maximum(eps[faces], 1e-300))
    return np.stack([s, t], axis=1), r, kern[:P], kern[P:], d_s, d_t


def _moment_shares(mesh: TriMesh, faces: np.ndarray, kern: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Per-face moment-matched shares a (k,) for couplings (faces[j], kern[j], d[j]).

    Solves Σ_j a_j d_j d_jᵀ = A_F I per face with a_j = k_j (λ0 + Re(conj(λ1) û_j²)),
    blending towards the trace-only shares where needed to keep a_j ≥ MIN_SHARE times them.
    """
    m = mesh.n_faces
    A = mesh.face_areas
    d2 = np.abs(d) ** 2
    u2 = _unit(d) ** 2
    psi = np.stack([np.ones_like(d2), u2.real, u2.imag], axis=1)  # (k, 3)
    kd = kern * d2
    # trace-only shares: a = 2 A k / Σ k |d|²
    tr = np.bincount(faces, weights=kd, minlength=m)
    trace_share = 2.0 * A[faces] * kern / np.where(tr[faces] > 0, tr[faces], 1.0)
    # moment matrices M_t = Σ k |d|² ψ ψᵀ (symmetric 3 x 3)
    Mt = np.empty((m, 3, 3))
    for i in range(3):  # six distinct entries, each a bincount over all couplings
        for j in range(i, 3):
            Mt[:, i, j] = Mt[:, j, i] = np.bincount(
                faces, weights=kd * psi[:, i] * psi[:, j], minlength=m
            )
    trace = np.trace(Mt, axis1=1, axis2=2)
    det = np.linalg.det(Mt)
    good = det > _SINGULAR_RTOL * (trace / 3.0) ** 3
    lam = np.zeros((m, 3))
    if good.any():
        rhs = np.zeros((int(good.sum()), 3, 1))
        rhs[:, 0, 0] = 2.0 * A[good]
        lam[good] = np.linalg.solve(Mt[good], rhs)[:, :, 0]
    moment_share = kern * np.einsum("kj,kj->k", psi, lam[faces])
    use = good[faces]
    moment_share = np.where(use, moment_share, trace_share)
    # blend a = (1 - τ) moment + τ trace with the least τ keeping a ≥ MIN_SHARE · trace
    low = moment_share < MIN_SHARE * trace_share
    tau_j = np.zeros_like(moment_share)
    gap = trace_share - moment_share
    tau_j[low] = (MIN_SHARE * trace_share[low] - moment_share[low]) / gap[low]
    tau = np.zeros(m)
    np.maximum.at(tau, faces, tau_j)
    tau = np.clip(tau, 0.0, 1.0)[faces]
    return (1.0 - tau) * moment_share + tau * trace_share


def _build_pairs(mesh: TriMesh, kind: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if kind == "knoppel":
        pairs, r, w = _knoppel_pairs(mesh)
    else:
        pairs, r, k_s, k_t, d_s, d_t = _singer_wu_geometry(mesh)
        P = pairs.shape[0]
        faces = np.concatenate([pairs[:, 0], pairs[:, 1]])
        shares = _moment_shares(mesh, faces, np.concatenate([k_s, k_t]), np.concatenate([d_s, d_t]))
        w = shares[:P] + shares[P:]
    return readonly(pairs), readonly(r), readonly(w)


@takes_mesh
def connection_pairs(
    mesh: TriMesh, kind: ConnectionKind = "knoppel"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The coupled face pairs, their transports and weights: E(z) = Σ_p w_p |z_s − r_p z_t|².

    Parameters
    ----------
    mesh : TriMesh
    kind : {"knoppel", "singer_wu"}
        Edge-adjacent pairs with unfolding transport, or 1-ring pairs (faces sharing a
        vertex) with Procrustes transport (see the module docstring).

    Returns
    -------
    pairs : int64 (P, 2)
        ``(s, t)`` with s < t for ``"singer_wu"``; for ``"knoppel"`` one pair per interior
        edge e, ``(s, t) = mesh.edge_faces[e]``, in edge order.
    transport : complex128 (P,)
        r_st, unit modulus: maps complex coordinates in t's frame to s's frame.
    weights : float64 (P,)
        w_st > 0: guarded circumcentric weights (``"knoppel"``) or moment-matched 1-ring
        weights (``"singer_wu"``); see the module docstring.

    Notes
    -----
    Cached on the mesh; the arrays are read-only.
    """
    kind = check_kind(kind)
    return mesh.cached(f"connection_pairs:{kind}", lambda: _build_pairs(mesh, kind))


@takes_mesh
def connection_laplacian(
    mesh: TriMesh,
    kind: ConnectionKind = "knoppel",
    n: int = 1,
    *,
    curvature_smoothing: float | None = None,
    log_scale: npt.ArrayLike | None = None,
) -> sp.csr_array:
    """The face connection Laplacian L: complex Hermitian PSD, sparse (m, m).

    .. math::

        z^* L z = E(z) = \\sum_{(s,t)} w_{st} |z_s - r_{st}^{\\,n} z_t|^2 ,

    i.e. ``L[s, s] += w``, ``L[t, t] += w``, ``L[s, t] = −w r_st^n``,
    ``L[t, s] = −w conj(r_st^n)``, acting on ``z = mesh.to_complex(u)`` (m,) complex128
    for n = 1, and on the power representation ``z = fvf.design.nfields.to_power(mesh, u,
    n)`` of an N-direction field for n = N (the N-fold connection of Knöppel et al. 2013:
    the transport angle is multiplied by N).

    Parameters
    ----------
    mesh : TriMesh
    kind : {"knoppel", "singer_wu"}
        See the module docstring (Knöppel et al. 2013 edge coupling; Singer & Wu 2012 1-ring
        coupling).
    n : int
        Symmetry order N >= 1 of the fields it acts on (default 1: vector fields).
    curvature_smoothing : float, optional
        A length ℓ > 0: turn each transport by the angle of
        :func:`fvf.design.holonomy.holonomy_rotations`, r_e ↦ r_e e^{i x_e}, so that the
        connection's holonomy around each vertex is the angle defect smoothed over ℓ
        instead of the angle defect (``"knoppel"`` only; closed meshes). Fields smooth for
        it have their cones where the smoothed curvature gathers a 1/N turn, not on every
        vertex with a large angle defect (:mod:`fvf.design.holonomy`).
    log_scale : array_like, float (n,), optional
        With ``curvature_smoothing``: a conformal scale s per vertex; the holonomy is then
        that of the metric e^{2s} g (:func:`fvf.design.holonomy.holonomy_rotations`), whose
        smooth fields carry the cones that quads of size h e^{-s} need.

    Returns
    -------
    scipy.sparse.csr_array, complex128 (m, m)
        Integrated (weak) form: pair it with :func:`connection_mass` ([A_F]) for
        eigenproblems, ``L z = λ [A_F] z``. Cached; read-only buffers.

    Notes
    -----
    Invariant under a global phase, E(e^{iα} z) = E(z). A parallel field (z_s = r_st z_t
    on every pair) has zero energy; on a flat mesh the constant fields are parallel.

    Examples
    --------
    >>> import fvf
    >>> from fvf.design.connection import connection_laplacian
    >>> L = connection_laplacian(fvf.icosphere(2))
    >>> L.shape, bool(abs(L - L.conj().T).max() == 0)
    ((320, 320), True)
    """
    kind = check_kind(kind)
    n = as_direction_count(n)
    scale = None
    if curvature_smoothing is not None:
        from .holonomy import as_log_scale, smoothing_length

        curvature_smoothing = smoothing_length(curvature_smoothing)
        scale = as_log_scale(mesh, log_scale)
        if kind != "knoppel":
            raise ParameterError(
                f"curvature_smoothing turns the edge transports of kind='knoppel'; got {kind!r}"
            )
    elif log_scale is not None:
        raise ParameterError("log_scale scales the holonomy of curvature_smoothing: pass both")

    def build():
        pairs, r, w = connection_pairs(mesh, kind)
        if curvature_smoothing is not None:
            from .holonomy import holonomy_rotations

            r = r * np.exp(1j * holonomy_rotations(mesh, curvature_smoothing, scale))
        if n != 1:
            r = r**n
        m = mesh.n_faces
        s, t = pairs[:, 0], pairs[:, 1]
        diag = np.bincount(s, weights=w, minlength=m) + np.bincount(t, weights=w, minlength=m)
        rows = np.concatenate([np.arange(m), s, t])
        cols = np.concatenate([np.arange(m), t, s])
        data = np.concatenate([diag.astype(complex), -w * r, -w * np.conj(r)])
        L = sp.coo_array((data, (rows, cols)), shape=(m, m)).tocsr()
        L.sort_indices()
        return readonly_csr(L)

    variant = kind if n == 1 else f"{kind}:{n}"
    if curvature_smoothing is not None:
        from .holonomy import log_scale_key

        variant += f":holonomy smoothed over {curvature_smoothing!r}{log_scale_key(scale)}"
    return mesh.cached(f"connection_laplacian:{variant}", build)


@takes_mesh
def sample_points(mesh: TriMesh, kind: ConnectionKind = "knoppel") -> np.ndarray:
    """Where the coefficient z_t of each face is read as a sample of a smooth field, (m, 3).

    The circumcentre of each face for ``"knoppel"`` (the dual vertex of the circumcentric
    dual edges; outside the face when it is obtuse), the centroid for ``"singer_wu"``. The
    discrete energy of a smooth field u converges to ∫|∇u|² when u is sampled there (and
    projected to the face plane); the eigenvalues do not depend on this choice.
    """
    kind = check_kind(kind)
    if kind == "singer_wu":
        return mesh.face_centroids

    def build():
        P = mesh.vertices[mesh.faces]
        a, b = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
        n = cross_rows(a, b)
        num = cross_rows(n, a) * np.einsum("ij,ij->i", b, b)[:, None]
        num += cross_rows(b, n) * np.einsum("ij,ij->i", a, a)[:, None]
        return readonly(P[:, 0] + num / (2.0 * np.einsum("ij,ij->i", n, n))[:, None])

    return mesh.cached("circumcenters", build)


def complex_to_real(A: sp.sparray) -> sp.csr_array:
    """Real (2k, 2l) form of a complex sparse (k, l) matrix on face-major ``[Re, Im]`` pairs.

    Entry x + iy becomes the block ``[[x, −y], [y, x]]``, so that
    ``complex_to_real(A) @ vec(z) = vec(A @ z)`` with ``vec(z) = [Re z0, Im z0, Re z1, …]``
    (see :func:`real_to_complex`). A Hermitian A gives a symmetric real form with the same
    quadratic form.
    """
    C = sp.coo_array(A)
    r, c, x, y = C.row, C.col, C.data.real, C.data.imag
    rows = np.concatenate([2 * r, 2 * r, 2 * r + 1, 2 * r + 1])
    cols = np.concatenate([2 * c, 2 * c + 1, 2 * c, 2 * c + 1])
    data = np.concatenate([x, -y, y, x])
    k, l_ = C.shape
    R = sp.coo_array((data, (rows, cols)), shape=(2 * k, 2 * l_)).tocsr()
    R.sort_indices()
    return R


def real_to_complex(a: npt.ArrayLike) -> np.ndarray:
    """Face-major real pairs (2m,) or (m, 2) (``mesh.to_local(u)``) to complex (m,)."""
    a = np.asarray(a, dtype=float).reshape(-1, 2)
    return a[:, 0] + 1j * a[:, 1]


@takes_mesh
def real_connection_laplacian(mesh: TriMesh, kind: ConnectionKind = "knoppel") -> sp.csr_array:
    """The real symmetric PSD form of :func:`connection_laplacian`, sparse float64 (2m, 2m).

    Acts on face-major local coordinates ``a = mesh.to_local(u).ravel()``
    (``[a0_0, a1_0, a0_1, a1_1, …]``); aᵀ L_ℝ a = z^* L z for z = a0 + i a1.
    """
    kind = check_kind(kind)
    return mesh.cached(
        f"real_connection_laplacian:{kind}",
        lambda: readonly_csr(complex_to_real(connection_laplacian(mesh, kind))),
    )


@takes_mesh
def connection_mass(mesh: TriMesh, real: bool = False) -> sp.csr_array:
    """[A_F]: the face-area mass of the connection Laplacian, diagonal sparse float64.

    Parameters
    ----------
    real : bool
        False: (m, m), for the complex form; True: (2m, 2m), each area repeated for the two
        local coordinates (the real form).

    Notes
    -----
    ∫|u|² dA = z^* [A_F] z = aᵀ [A_F]_ℝ a for a piecewise-constant field.
    """
    k = 2 if real else 1
    return mesh.cached(
        f"connection_mass:{k}",
        lambda: readonly_csr(sp.diags_array(np.repeat(mesh.face_areas, k))),
    )


@takes_mesh
def connection_energy(mesh: TriMesh, u: npt.ArrayLike, kind: ConnectionKind = "knoppel") -> float:
    """E(u) = z^* L z for a per-face field u (m, 3) (normal components projected away).

    Returns
    -------
    float
        The discrete Dirichlet energy ≈ ∫|∇u|² dA of the field.
    """
    u = as_face_field(mesh, u, "u")
    z = mesh.to_complex(u)
    return float(np.real(np.vdot(z, connection_laplacian(mesh, kind) @ z)))


# ---------------------------------------------------------------------------- tangent basis
@takes_mesh
def tangent_basis_matrix(mesh: TriMesh) -> sp.csr_array:
    """B: the orthonormal per-face tangent basis as a sparse float64 (3m, 2m) matrix.

    Column 2t is b1 of face t and column 2t + 1 is b2 (``mesh.face_bases``), on the rows
    3t..3t+2 of the face-major flattened field, so ``B @ mesh.to_local(u).ravel()`` is
    ``u.ravel()`` for a tangent u, ``Bᵀ u.ravel()`` its local coordinates and BᵀB = I.
    """

    def build():
        m = mesh.n_faces
        vals = mesh.face_bases.transpose(0, 2, 1).reshape(3 * m, 2)  # row (t, k): b1_k, b2_k
        cols = np.repeat(2 * np.arange(m)[:, None] + np.arange(2), 3, axis=0)
        return readonly_csr(face_rows_csr(vals, cols, 2 * m))

    return mesh.cached("tangent_basis_matrix", build)


@takes_mesh
def restrict_to_tangent(mesh: TriMesh, E: Any) -> Any:
    """E_B = Bᵀ E B: an energy on flattened fields (3m, 3m) restricted to tangent fields.

    Parameters
    ----------
    mesh : TriMesh
    E : sparse array or ndarray, (3m, 3m)
        Acting on face-major flattened fields ``u.ravel()`` (``docs/conventions.md``).

    Returns
    -------
    scipy.sparse.csr_array or ndarray, (2m, 2m)
        Sparse when E is; acts on ``mesh.to_local(u).ravel()``, with
        ``aᵀ E_B a = (B a)ᵀ E (B a)`` (§4.4.2).

    Raises
    ------
    FieldShapeError
        If E is not (3m, 3m).
    """
    m = mesh.n_faces
    if getattr(E, "ndim", None) != 2 or E.shape != (3 * m, 3 * m):
        raise FieldShapeError(
            f"E must be a ({3 * m}, {3 * m}) operator on face-major flattened fields; got "
            f"shape {getattr(E, 'shape', None)}."
        )
    B = tangent_basis_matrix(mesh)
    if sp.issparse(E):
        return sp.csr_array(B.T @ sp.csr_array(E) @ B)
    E = np.asarray(E)
    return np.asarray(B.T @ (B.T @ E.T).T)


# ---------------------------------------------------------------------------- eigenfields
def _fix_phase(Z: np.ndarray) -> np.ndarray:
    """Rotate each column so its first coefficient of (nearly) largest modulus is real > 0."""
    a = np.abs(Z)
    idx = np.argmax(a >= (1.0 - 1e-6) * a.max(axis=0), axis=0)
    c = Z[idx, np.arange(Z.shape[1])]
    return Z * (np.abs(c) / np.where(c != 0, c, 1.0))[None, :]


def _complex_ritz(
    L: sp.csr_array, area: np.ndarray, Z: np.ndarray, count: int
) -> tuple[np.ndarray, np.ndarray]:
    """Rayleigh–Ritz in the complex span of Z (m, k): lowest ``count`` pairs, A-orthonormal."""
    sq = np.sqrt(area)[:, None]
    U, sv, _ = np.linalg.svd(sq * Z, full_matrices=False)
    U = U[:, sv > 1e-8 * sv[0]]
    Q = U / sq  # A-orthonormal complex basis of span_C(Z)
    H = Q.conj().T @ (L @ Q)
    lam, Y = np.linalg.eigh(0.5 * (H + H.conj().T))
    return lam[:count], Q @ Y[:, :count]


@takes_mesh
def smoothest_fields(
    mesh: TriMesh,
    count: int,
    kind: ConnectionKind = "knoppel",
    *,
    n: int = 1,
    solver: EigenSolver = "auto",
    backend: Backend = "auto",
    progress: bool | ProgressCallback | None = None,
    curvature_smoothing: float | None = None,
    log_scale: npt.ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` smoothest fields: lowest eigenfields of L_n z = λ [A_F] z.

    For n = 1 these are vector fields; for n = N ≥ 2 they are N-direction fields (lines,
    crosses, …), computed in the power representation z = w^N with the N-fold connection
    Laplacian L_N (Knöppel, Crane, Pinkall & Schröder 2013, "Globally optimal direction
    fields": the transport angle multiplied by N; :func:`connection_laplacian` with
    ``n``) and returned as one representative vector per face
    (:func:`fvf.design.nfields.from_power`).

    Parameters
    ----------
    mesh : TriMesh
    count : int
        Number of complex eigenfields, 1 ≤ count ≤ m. Each complex eigenvalue is a real
        two-dimensional eigenspace {z, iz} (a field and its rotation by J).
    kind : {"knoppel", "singer_wu"}
    n : int
        Symmetry order N ≥ 1 (keyword): 1 vector, 2 line, 4 cross, 6 fields.
    solver : {"auto", "dense", "arpack", "lobpcg"}
        ``"dense"``: Hermitian dense solver. ``"arpack"``: ARPACK shift-invert with
        SuperLU (``scipy.sparse.linalg.eigs``). ``"lobpcg"``: LOBPCG preconditioned by one
        sparse Cholesky factorization, i.e. accelerated inverse iteration
        (:func:`fvf.numerics.inverse_iteration.inverse_iteration`). ``"auto"``: dense up to
        600 faces, ARPACK below :data:`LOBPCG_MIN_FACES` (20k) faces, LOBPCG above
        (falling back to ARPACK with a :class:`fvf.SpectralFallbackWarning` if it does not
        converge).
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        Factorization of the LOBPCG preconditioner (:mod:`fvf.numerics.cholesky`; the fast
        ones need the ``[fast]`` extra).
    progress : None, bool or callable
        ``True`` for a tqdm bar, or a callback ``(stage, done, total)``
        (:mod:`fvf.numerics.progress`).
    curvature_smoothing : float, optional
        A length ℓ > 0 (mesh units): use the connection whose holonomy is the angle defect
        smoothed over ℓ (:mod:`fvf.design.holonomy`), so that vertices with a large angle
        defect (spikes, pinches, valence-4 vertices of remeshed scans) do not each force
        a cone. Closed meshes, ``kind="knoppel"``. Default: the Levi-Civita connection.
    log_scale : array_like, float (n,), optional
        With ``curvature_smoothing``: the conformal scale of :func:`connection_laplacian`.

    Returns
    -------
    energies : float64 (count,)
        Ascending eigenvalues λ_k = E_n(z_k) (≈ ∫|∇ z_k|²) with ∫|z_k|² = 1.
    fields : NField, float64 (count, m, 3)
        For n = 1 the eigenfields as ambient per-face vectors, unit L2 norm
        (Σ_t A_F(t) |u_k(t)|² = 1), mutually orthogonal in the complex sense
        (Σ A_F z̄_j z_k = 0), phase fixed so that the first coefficient of (within 1e-6)
        largest modulus is real positive. For n ≥ 2 one representative vector per face of
        each N-field, of length |z_k(t)| (so again Σ A_F |u_k|² = 1; normalise per face
        for unit crosses); the other directions are its rotations by 2πj/N about the face
        normal.

    Raises
    ------
    FvfError
        count outside [1, m].
    DirectionCountError
        n not an integer ≥ 1.

    Notes
    -----
    LOBPCG factors L_n + τ[A_F] once (τ = 1e-8 max L_tt/A_t makes it definite on meshes
    with a parallel field) and iterates on a block of count vectors, on the standard form
    [A_F]^(-1/2) L_n [A_F]^(-1/2), until every residual is below 1e-6 (mass rescaled to
    mean 1), then a Rayleigh–Ritz step in their span. ARPACK runs in complex arithmetic
    in shift-invert mode (σ just below 0) for count + 2 vectors, then the same
    Rayleigh–Ritz step. Within a degenerate eigenspace (e.g. the sphere's λ = 1 for n = 1,
    complex multiplicity 3; λ = 4 for n = 4, multiplicity 9) the basis returned is
    arbitrary.

    On shapes whose curvature varies strongly, the smoothest N-fields for N ≥ 2 localise:
    the N-fold transport acts like a magnetic field N·K, and the lowest eigenfields
    concentrate where |K| is small, with magnitudes that can fall to round-off level
    elsewhere (where their directions are noise and :func:`fvf.singularities` reports
    zero vectors). Constraints or ``align=`` in :func:`fvf.design_field` avoid this.
    Measured speed: ``docs/nfields.md``.
    """
    kind = check_kind(kind)
    n = as_direction_count(n)
    if solver not in EIGEN_SOLVERS:
        raise FvfError(f"solver must be one of {EIGEN_SOLVERS}; got {solver!r}.")
    report = make_progress(progress)
    m = mesh.n_faces
    count = int(count)
    if not 1 <= count <= m:
        raise FvfError(f"count must be in [1, {m}] (the number of faces); got {count}.")
    report("assemble", 0, 1)
    L = connection_laplacian(
        mesh, kind, n, curvature_smoothing=curvature_smoothing, log_scale=log_scale
    )
    report("assemble", 1, 1)
    area = mesh.face_areas
    auto = solver == "auto"
    if auto:
        solver = "arpack" if m < LOBPCG_MIN_FACES else "lobpcg"
        solver = "dense" if m <= _DENSE_FACES else solver
    if solver != "dense" and 5 * (count + 3) >= m:
        solver = "dense"
    if solver == "lobpcg":
        try:
            lam, Z = inverse_iteration(L, area, count, backend=backend, progress=report)
            lam, Z = _complex_ritz(L, area, Z, count)
        except SpectralSolveError as exc:
            if not auto or raised_by_callback(exc):
                raise
            warnings.warn(
                f"smoothest_fields: {exc} Using ARPACK instead.",
                SpectralFallbackWarning,
                stacklevel=2,
            )
            solver = "arpack"
    if solver == "dense":
        lam, Z = sla.eigh(
            L.toarray(), np.diag(area.astype(complex)), subset_by_index=[0, count - 1]
        )
    elif solver == "arpack":
        M = sp.diags_array(area.astype(complex))
        # just below 0 (L = 0 on a mesh with no interior side: below 0 all the same)
        sigma = -1e-8 * max(float(np.max(L.diagonal().real / area)), 1.0 / float(area.max()))
        v0 = np.ones(m, dtype=complex)  # deterministic start vector
        k = count + 2  # a little slack for clusters cut at count
        try:
            _, Z = spla.eigs(L, k=k, M=M, sigma=sigma, which="LM", v0=v0)
        except (RuntimeError, spla.ArpackError) as exc:  # ARPACK, SuperLU: never raw
            raise SpectralSolveError(
                f"smoothest_fields: ARPACK failed on {m} faces ({exc}). Fix: check the "
                "mesh (fvf info FILE); a triangle soup needs welding first (fvf.repair_mesh)"
            ) from exc
        lam, Z = _complex_ritz(L, area, Z, count)
    Z = _fix_phase(Z)
    if n != 1:
        mag = np.abs(Z)
        Z = mag * np.exp(1j * np.angle(Z) / n)
    fields = np.einsum("tij,kti->ktj", mesh.face_bases, np.stack([Z.T.real, Z.T.imag], -1))
    return np.asarray(lam, dtype=float), NField(fields, n)
