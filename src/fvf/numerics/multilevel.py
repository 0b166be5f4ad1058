"""Multilevel eigensolver for large face-field pencils (ACAP fields at a million faces).

The direct path of :func:`fvf.acap_fields` factors E_B − σ[A_F]
(:func:`fvf.numerics.eigen.factor_spd`);
the factor of the ACAP energy grows about 4.5x per 4x faces (10.5 GB at 375k faces), so
above a few hundred thousand faces it does not fit in memory. This module computes the
same eigenpairs of a sparse symmetric positive semidefinite pencil W x = λ [M] x in
memory linear in the size: a smoothed-aggregation multigrid hierarchy (built here,
numpy/scipy only) preconditions a block LOBPCG iteration.

Hierarchy (:class:`AggregationHierarchy`)
-----------------------------------------
The unknowns come in *nodes* of ``b`` dofs (the two tangent coordinates of one face).

1. Aggregation. Node positions (face centroids) are hashed into cubes of side s; the
   nodes of one cube are split into the connected components of the node graph (face
   adjacency on the finest level, the coarse matrix's block pattern below), and each
   component is an aggregate. s is tuned (up to three tries) so that an aggregate holds
   about :data:`COARSEN_RATIO` nodes. Nodes left alone join their strongest neighbour's
   aggregate.
2. Tentative prolongator. A near-kernel N (nodes, b, r) is given per node: on the finest
   level the local coordinates of the three constant ambient directions e_x, e_y, e_z
   (r = 3), i.e. the locally parallel fields that the connection energy barely sees.
   Per aggregate, the [M]-weighted Gram matrix of N (r x r) is diagonalised and its b
   leading eigenvectors give b coarse dofs whose fine images are [M]-orthonormal; the
   coarse near-kernel is what they represent of N (b x r per aggregate).
3. Smoother. Block Jacobi whose blocks are the b x b diagonal blocks of A, except that
   two nodes coupled more strongly than :data:`STRONG` (relative block norm) and each
   other's strongest neighbour are relaxed together (a 2b x 2b block). This matters on
   meshes made of near-right triangle pairs (triangulated quads, e.g. spot): the
   circumcentric weight across a quad's diagonal is ~1000x the others, and with b x b
   blocks the multigrid-preconditioned CG needed ~140 iterations instead of ~35–45.
   Chebyshev acceleration of degree :data:`CHEB_DEGREE` on
   [ρ/:data:`CHEB_RATIO`, 1.1 ρ], ρ ≈ ρ(D⁻¹A) by a seeded power iteration.
4. Smoothed prolongator P = (I − ω D⁻¹ A) P_tent, ω = 4 / (3 ρ); A_c = Pᵀ A P.
5. Cycle. A symmetric V-cycle (the same Chebyshev polynomial before and after the
   coarse correction; a dense Cholesky solve on the coarsest level, at most
   :data:`COARSE_MAX` dofs), run in single precision: it is symmetric positive definite,
   as LOBPCG requires, and a preconditioner needs no more accuracy.

Eigensolver (:func:`multilevel_eigenpairs`)
-------------------------------------------
The pencil is carried to the symmetric standard form Â = [M]^-½ W [M]^-½, where the
Euclidean residual of a unit vector is exactly the measure of
:func:`fvf.numerics.eigen.eigen_residuals` times (|λ| + ν). The start block is the smallest
eigenvectors of the coarsest Galerkin pencil (A_L, Pᵀ[M]P), prolongated; then block
LOBPCG (:func:`lobpcg_smallest`, an explicitly orthonormal basis [X, W, P]) runs on
k + :func:`_extra` vectors with the V-cycle of W as preconditioner until each of the k
wanted pairs has a residual below both ``tol`` · (|λ| + ν) (the measure of
:func:`fvf.smallest_eigenpairs`) and ``rtol`` · λ_k. The second bound is what makes the
eigenvectors accurate: ν is an upper bound of the largest eigenvalue, 10⁶–10⁸ times λ_k
on fine or irregular meshes, and on ``camelhead.off`` (λ = 10⁻³) pairs meeting only
``tol`` were 0.1 away (sine of the subspace angle) from the direct solution. The
returned pairs are Rayleigh quotients with the sign convention of
:func:`fvf.smallest_eigenpairs`; both bounds are checked on the final vectors.

Convergence degrades with the anisotropy of W: for the ACAP energy, ‖ad_v w‖² controls
derivatives along v only, so small λ/|v|² makes it nearly one-dimensional, which the
isotropic aggregates and point smoother do not capture (see :func:`fvf.acap_fields`).

Only vectorised numpy and scipy.sparse are used (no Python loop over nodes).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..errors import SpectralInputError, SpectralSolveError
from .eigenpairs import normalized_eigenpairs, spectral_norm_bound

__all__ = [
    "AggregationHierarchy",
    "multilevel_eigenpairs",
    "face_field_eigenpairs",
    "lobpcg_smallest",
    "RTOL",
    "STRONG",
    "COARSEN_RATIO",
    "COARSE_MAX",
    "CHEB_DEGREE",
    "CHEB_RATIO",
]

#: Node pairs coupled more strongly than this (‖A_ij‖ / sqrt(‖A_ii‖ ‖A_jj‖), Frobenius
#: norms of the b x b blocks) may be relaxed together by the smoother.
STRONG = 0.3
#: Default bound of the residual relative to the k-th eigenvalue (multilevel_eigenpairs).
RTOL = 1e-3
#: Target number of nodes per aggregate.
COARSEN_RATIO = 8.0
#: The coarsest level is solved densely once it has at most this many dofs.
COARSE_MAX = 3000
#: Degree of the Chebyshev smoother (matrix products per smoothing step).
CHEB_DEGREE = 2
#: The Chebyshev smoother damps the eigenvalues of D⁻¹A in [ρ / CHEB_RATIO, 1.1 ρ].
CHEB_RATIO = 8.0


# ------------------------------------------------------------------------------- blocks
def _strongest_pairs(S: sp.coo_array, N: int) -> np.ndarray:
    """Mutually strongest neighbours of a strength graph: pairs (q, 2), q ≤ N/2."""
    if S.nnz == 0:
        return np.zeros((0, 2), np.int64)
    order = np.lexsort((-S.data, S.row))
    r, c = S.row[order], S.col[order]
    first = np.unique(r, return_index=True)[1]
    best = np.full(N, -1, np.int64)
    best[r[first]] = c[first]
    i = np.flatnonzero(best >= 0)
    j = best[i]
    mutual = (best[j] == i) & (i < j)
    return np.stack([i[mutual], j[mutual]], 1)


def _pair_smoother(A: sp.csr_array, b: int, pairs: np.ndarray) -> sp.csr_array:
    """Block-Jacobi inverse whose blocks are the 2b x 2b couplings of ``pairs`` (else b x b).

    Nodes of a strongly coupled pair (two faces whose coupling dominates their
    diagonal blocks, e.g. across the diagonal of a quad with circumcentric weights) are
    relaxed together; a b x b block Jacobi cannot reduce their joint error.
    """
    n = A.shape[0]
    N = n // b
    paired = np.zeros(N, bool)
    paired[pairs.ravel()] = True
    single = np.flatnonzero(~paired)
    # super-nodes: pairs, then singles padded with themselves (their copy is masked)
    sn = np.concatenate([pairs, np.stack([single, single], 1)])
    idx = (sn[:, :, None] * b + np.arange(b)).reshape(-1, 2 * b)  # (S, 2b) dofs
    S = sn.shape[0]
    C = sp.csr_array(A)
    C.sort_indices()
    keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(C.indptr)) * n + C.indices
    rr = np.repeat(idx[:, :, None], 2 * b, 2)
    cc = np.repeat(idx[:, None, :], 2 * b, 1)
    q = (rr * n + cc).ravel()
    pos = np.minimum(np.searchsorted(keys, q), keys.size - 1)
    D = np.where(keys[pos] == q, C.data[pos], 0.0).reshape(S, 2 * b, 2 * b)
    ns = single.size
    if ns:  # a single's padding copy: identity, uncoupled
        Ds = D[S - ns :]
        Ds[:, b:, :] = 0.0
        Ds[:, :, b:] = 0.0
        Ds[:, b:, b:] = np.eye(b)
    Dinv = np.linalg.inv(D)
    keep = np.ones((S, 2 * b), bool)
    keep[S - ns :, b:] = False
    k3 = keep[:, :, None] & keep[:, None, :]
    return sp.csr_array(
        (
            Dinv[k3],
            (np.repeat(idx[:, :, None], 2 * b, 2)[k3], np.repeat(idx[:, None, :], 2 * b, 1)[k3]),
        ),
        shape=(n, n),
    )


def _power_rho(
    A: sp.csr_array, Dinv: sp.csr_array, rng: np.random.Generator, iters: int = 12
) -> float:
    """An estimate of the spectral radius of Dinv A (power iteration, seeded)."""
    x = rng.standard_normal(A.shape[0])
    x /= np.linalg.norm(x)
    rho = 0.0
    for _ in range(iters):
        y = Dinv @ (A @ x)
        rho = float(np.linalg.norm(y))
        if rho == 0:
            return 1.0
        x = y / rho
    return rho


# --------------------------------------------------------------------------- aggregation
def _voxel_aggregates(pos: np.ndarray, G: sp.csr_array, s: float) -> tuple[np.ndarray, int]:
    """Connected components of G inside cubes of side s: (aggregate id (N,), count)."""
    key = np.floor((pos - pos.min(0)) / s).astype(np.int64)
    _, cell = np.unique(key, axis=0, return_inverse=True)
    cell = cell.ravel()
    Gc = sp.coo_array(G)
    keep = cell[Gc.row] == cell[Gc.col]
    N = pos.shape[0]
    H = sp.csr_array((np.ones(int(keep.sum())), (Gc.row[keep], Gc.col[keep])), shape=(N, N))
    n_agg, agg = csgraph.connected_components(H, directed=False)
    return agg.astype(np.int64), int(n_agg)


def _merge_singletons(agg: np.ndarray, G: sp.csr_array) -> tuple[np.ndarray, int]:
    """Nodes alone in their aggregate join the aggregate of their strongest neighbour."""
    size = np.bincount(agg)
    alone = size[agg] == 1
    if alone.any():
        Gc = sp.coo_array(G)
        sel = alone[Gc.row] & ~alone[Gc.col] & (Gc.row != Gc.col)
        r, c, w = Gc.row[sel], Gc.col[sel], np.abs(Gc.data[sel])
        order = np.lexsort((-w, r))  # per row, strongest first
        r, c = r[order], c[order]
        first = np.unique(r, return_index=True)[1]
        agg = agg.copy()
        agg[r[first]] = agg[c[first]]
    _, agg = np.unique(agg, return_inverse=True)
    agg = agg.ravel().astype(np.int64)
    return agg, int(agg.max()) + 1


def _strong_edges(A: sp.csr_array, b: int, theta: float) -> sp.coo_array:
    """Node pairs whose coupling block is strong: ‖A_ij‖_F ≥ θ sqrt(‖A_ii‖_F ‖A_jj‖_F)."""
    C = sp.coo_array(A)
    N = A.shape[0] // b
    B2 = sp.coo_array((C.data**2, (C.row // b, C.col // b)), shape=(N, N)).tocsr()
    B2.sum_duplicates()
    B2 = sp.coo_array(B2)
    f = np.sqrt(B2.data)
    d = np.zeros(N)
    on = B2.row == B2.col
    d[B2.row[on]] = f[on]
    sel = ~on & (f >= theta * np.sqrt(d[B2.row] * d[B2.col]))
    return sp.coo_array((f[sel], (B2.row[sel], B2.col[sel])), shape=(N, N))


def _aggregate(
    pos: np.ndarray, G: sp.csr_array, area: float, ratio: float
) -> tuple[np.ndarray, int]:
    """Aggregates of about ``ratio`` nodes (voxel hashing + components, s tuned twice)."""
    N = pos.shape[0]
    h = np.sqrt(area / N)  # node spacing
    s = np.sqrt(ratio) * h
    for _ in range(3):
        agg, n_agg = _voxel_aggregates(pos, G, s)
        got = N / n_agg
        if abs(np.log(got / ratio)) < 0.2:
            break
        s *= np.sqrt(ratio / got)
    return _merge_singletons(agg, G)


def _tentative(
    agg: np.ndarray, n_agg: int, Nn: np.ndarray, mass: np.ndarray, b: int
) -> tuple[Any, np.ndarray]:
    """Tentative prolongator (Nb, n_agg b) and the coarse near-kernel (n_agg, b, r)."""
    N, _, r = Nn.shape
    Wn = Nn * mass.reshape(N, b)[:, :, None]
    G = np.einsum("nir,nis->nrs", Nn, Wn).reshape(N, r * r)
    Ga = np.stack([np.bincount(agg, G[:, j], minlength=n_agg) for j in range(r * r)], 1)
    Ga = Ga.reshape(n_agg, r, r)
    w, U = np.linalg.eigh(0.5 * (Ga + Ga.transpose(0, 2, 1)))
    w, U = w[:, r - b :], U[:, :, r - b :]  # b leading
    w = np.maximum(w, 1e-300)
    Ub = U / np.sqrt(w)[:, None, :]  # (n_agg, r, b)
    Pi = np.einsum("nir,nrc->nic", Nn, Ub[agg])  # (N, b, b)
    rows = np.repeat(np.arange(N * b), b)
    cols = (agg[:, None, None] * b + np.arange(b)[None, None, :]).repeat(b, 1).ravel()
    P = sp.csr_array((Pi.ravel(), (rows, cols)), shape=(N * b, n_agg * b))
    Nc = np.sqrt(w)[:, :, None] * U.transpose(0, 2, 1)  # (n_agg, b, r)
    return P, Nc


def _node_graph(A: sp.csr_array, b: int) -> sp.csr_array:
    """The node graph of a matrix with b x b blocks (pattern of the block sums of |A|)."""
    C = sp.coo_array(A)
    N = A.shape[0] // b
    G = sp.csr_array((np.abs(C.data), (C.row // b, C.col // b)), shape=(N, N))
    G.sum_duplicates()
    return G


# ------------------------------------------------------------------------------- levels
def _single(A: sp.csr_array) -> sp.csr_array:
    """A float32 copy of a CSR matrix that shares its index arrays."""
    A = sp.csr_array(A)
    return sp.csr_array((A.data.astype(np.float32), A.indices, A.indptr), shape=A.shape)


class _Level:
    """One level of the cycle, in single precision (a preconditioner needs no more)."""

    __slots__ = ("A", "P", "R", "Dinv", "lmax", "lmin")

    def __init__(self, A, P, Dinv, rho):
        self.A = _single(A)
        self.P = _single(P) if P is not None else None
        self.R = _single(sp.csr_array(P.T)) if P is not None else None
        self.Dinv = _single(Dinv) if Dinv is not None else None
        self.lmax = 1.1 * rho
        self.lmin = rho / CHEB_RATIO


class AggregationHierarchy:
    """Smoothed-aggregation multigrid for a sparse SPD matrix with b dofs per node.

    Parameters
    ----------
    A : sparse (N b, N b)
        Symmetric positive definite, dofs node-major (node i owns rows i b .. i b + b − 1).
    near_kernel : ndarray float64 (N, b, r), r ≥ b
        Per node, the local coordinates of r fields that A (nearly) annihilates locally.
    mass : ndarray float64 (N b,)
        Positive lumped mass of the dofs (weights the tentative prolongator).
    positions : ndarray float64 (N, 3)
        A position per node (for the voxel aggregation).
    graph : sparse (N, N), optional
        Node adjacency of the finest level (default: the block pattern of A).
    area : float, optional
        Total measure of the domain (node spacing estimate; default sum(mass) / b).
    seed : int
        Seed of the power iterations.
    ratio : float
        Target nodes per aggregate.
    coarse_max : int
        Stop coarsening at this many dofs (dense Cholesky on the last level).
    max_levels : int
        At most this many levels.

    Attributes
    ----------
    levels : list
        Per level (float32): A, P, R = Pᵀ, the block-Jacobi inverse, the Chebyshev interval.
    sizes : list of int
        Dofs per level.
    coarse_matrix : scipy.sparse.csr_array
        The coarsest Galerkin matrix in float64.
    timings : list of float
        Setup seconds per coarsening step.

    Raises
    ------
    SpectralInputError
        A and near_kernel do not match, or r < b.
    """

    def __init__(
        self,
        A: sp.sparray | sp.spmatrix,
        near_kernel: np.ndarray,
        mass: np.ndarray,
        positions: np.ndarray,
        *,
        graph: sp.sparray | sp.spmatrix | None = None,
        area: float | None = None,
        seed: int = 0,
        ratio: float = COARSEN_RATIO,
        coarse_max: int = COARSE_MAX,
        max_levels: int = 12,
    ) -> None:
        A = sp.csr_array(A, dtype=np.float64)
        Nn = np.asarray(near_kernel, dtype=np.float64)
        N, b, r = Nn.shape
        if A.shape != (N * b, N * b) or r < b:
            raise SpectralInputError(
                f"AggregationHierarchy: A {A.shape} does not match near_kernel {Nn.shape}"
            )
        mass = np.asarray(mass, dtype=np.float64)
        pos = np.asarray(positions, dtype=np.float64)
        area = float(mass.sum() / b) if area is None else float(area)
        G = _node_graph(A, b) if graph is None else sp.csr_array(graph)
        rng = np.random.default_rng(seed)
        self.b = b
        self.levels: list[_Level] = []
        self.timings: list[float] = []
        node_area = mass.reshape(N, b)[:, 0].copy()
        while True:
            t0 = time.perf_counter()
            n = A.shape[0]
            if n <= coarse_max or len(self.levels) + 1 >= max_levels:
                break
            pairs = _strongest_pairs(_strong_edges(A, b, STRONG), n // b)
            Dinv = _pair_smoother(A, b, pairs)
            rho = _power_rho(A, Dinv, rng)
            agg, n_agg = _aggregate(pos, G, area, ratio)
            if n_agg * b >= 0.8 * n:  # aggregation stalled
                break
            P0, Nc = _tentative(agg, n_agg, Nn, mass, b)
            omega = 4.0 / (3.0 * rho)
            P = (P0 - omega * (Dinv @ (A @ P0))).tocsr()
            del P0
            self.levels.append(_Level(A, P, Dinv, rho))
            Ac = (sp.csr_array(P.T) @ (A @ P)).tocsr()
            A = sp.csr_array(0.5 * (Ac + Ac.T))
            del Ac, P, Dinv
            # coarse node data
            w = np.bincount(agg, node_area, minlength=n_agg)
            pos = np.stack([np.bincount(agg, node_area * pos[:, j]) for j in range(3)], 1)
            pos /= w[:, None]
            node_area = w
            Nn = Nc
            mass = np.ones(n_agg * b)  # the tentative coarse basis is [M]-orthonormal
            G = _node_graph(A, b)
            self.timings.append(time.perf_counter() - t0)
        self.levels.append(_Level(A, None, None, 1.0))
        self.coarse_matrix = A  # float64
        Ad = _sym(A.toarray())
        # a relative 1e-10 shift keeps a semidefinite A (a kernel of W) factorable
        Ad[np.diag_indices_from(Ad)] += 1e-10 * max(float(np.abs(np.diag(Ad)).mean()), 1e-300)
        self._coarse = sla.cho_factor(Ad, lower=True)
        self.sizes = [lev.A.shape[0] for lev in self.levels]

    @property
    def operator_complexity(self) -> float:
        """Σ nnz(A_l) / nnz(A_0)."""
        return sum(lev.A.nnz for lev in self.levels) / self.levels[0].A.nnz

    def prolongate(self, Xc: np.ndarray, to_level: int = 0) -> np.ndarray:
        """Carry coarsest-level vectors (n_L, p) to level ``to_level``."""
        X = Xc
        for lev in reversed(self.levels[to_level:-1]):
            X = lev.P @ X
        return X

    def _smooth(self, lev: _Level, B: np.ndarray, X: np.ndarray | None) -> np.ndarray:
        """Chebyshev iteration (block Jacobi) for A X = B from X (None: zero)."""
        A, Dinv = lev.A, lev.Dinv
        theta = 0.5 * (lev.lmax + lev.lmin)
        delta = 0.5 * (lev.lmax - lev.lmin)
        sigma = theta / delta
        rho = 1.0 / sigma
        R = B.copy() if X is None else B - A @ X
        X = np.zeros_like(B) if X is None else X.copy()
        D = (Dinv @ R) / theta
        for it in range(CHEB_DEGREE):
            X += D
            if it == CHEB_DEGREE - 1:
                break
            R -= A @ D
            rho_new = 1.0 / (2.0 * sigma - rho)
            D = (rho_new * rho) * D + (2.0 * rho_new / delta) * (Dinv @ R)
            rho = rho_new
        return X

    def vcycle(self, B: np.ndarray, level: int = 0) -> np.ndarray:
        """One symmetric V-cycle for A_level X = B; B (n,) or (n, p); float32 result."""
        B = np.asarray(B, dtype=np.float32)
        lev = self.levels[level]
        if lev.P is None:
            return sla.cho_solve(self._coarse, B.astype(np.float64)).astype(np.float32)
        X = self._smooth(lev, B, None)
        Rc = lev.R @ (B - lev.A @ X)
        X += lev.P @ self.vcycle(Rc, level + 1)
        return self._smooth(lev, B, X)


# ----------------------------------------------------------------------------- LOBPCG
def _extra(k: int) -> int:
    """Extra vectors of the LOBPCG block beyond the k wanted."""
    return int(max(2, min(k // 2, 16)))


def _orthonormalize(
    Z: np.ndarray, AZ: np.ndarray | None = None, drop: float = 1e-10
) -> tuple[np.ndarray, np.ndarray | None]:
    """Orthonormal columns spanning Z (eigen-decomposed Gram; near-dependent ones dropped).

    Returns (Q, AQ) with AQ the same combination of AZ (None if AZ is None).
    """
    for _ in range(2):
        G = Z.T @ Z
        w, U = np.linalg.eigh(0.5 * (G + G.T))
        keep = w > drop * max(float(w[-1]), np.finfo(float).tiny)
        C = U[:, keep] / np.sqrt(w[keep])
        Z = Z @ C
        AZ = None if AZ is None else AZ @ C
    return Z, AZ


def lobpcg_smallest(
    apply_A: Callable[[np.ndarray], np.ndarray],
    apply_T: Callable[[np.ndarray], np.ndarray],
    X: np.ndarray,
    k: int,
    tol_abs: float,
    maxiter: int,
    refresh: int = 20,
    tol_rel: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Block LOBPCG for the k smallest eigenpairs of a symmetric operator (standard form).

    Parameters
    ----------
    apply_A, apply_T : callable
        (n, q) -> (n, q): the operator and the (symmetric positive definite) preconditioner.
    X : ndarray float64 (n, p), p ≥ k
        Start block (p − k extra vectors speed up convergence of the k wanted).
    k : int
        Number of wanted pairs; only their residuals decide convergence.
    tol_abs : float
        Target Euclidean residual ‖A x − θ x‖ of each wanted unit vector.
    tol_rel : float
        If > 0, the residuals must also be at most ``tol_rel`` |θ_k| (θ_k the largest
        wanted Ritz value).
    maxiter : int
    refresh : int
        A X is recomputed exactly every ``refresh`` iterations (no drift).

    Returns
    -------
    theta : ndarray (p,), X : ndarray (n, p), res : ndarray (p,), iterations : int
        Ritz values ascending, orthonormal Ritz vectors, their residual norms.

    Notes
    -----
    The basis [X, W, P] (W = T R of the unconverged columns, P the previous direction)
    is kept orthonormal explicitly, so every Rayleigh–Ritz step is a standard symmetric
    eigenproblem of size ≤ 3p (Knyazev 2001; Hetmaniuk & Lehoucq 2006 for the basis).
    """
    X, _ = _orthonormalize(X)
    p = X.shape[1]
    AX = apply_A(X)
    theta, C = np.linalg.eigh(_sym(X.T @ AX))
    X, AX = X @ C, AX @ C
    P = AP = None
    it = 0
    while True:
        R = AX - X * theta
        res = np.linalg.norm(R, axis=0)
        thr = tol_abs if tol_rel <= 0 else min(tol_abs, tol_rel * abs(theta[k - 1]))
        if np.all(res[:k] <= thr) or it >= maxiter:
            return theta, X, res, it
        it += 1
        act = res > thr
        W = apply_T(R[:, act])
        for _ in range(2):
            W -= X @ (X.T @ W)
            if P is not None:
                W -= P @ (P.T @ W)
        W, _ = _orthonormalize(W)
        AW = apply_A(W)
        Zs = [X, W] if P is None else [X, W, P]
        AZs = [AX, AW] if P is None else [AX, AW, AP]
        sizes = [z.shape[1] for z in Zs]
        off = np.concatenate([[0], np.cumsum(sizes)])
        G = np.zeros((off[-1], off[-1]))
        for a in range(len(Zs)):  # upper blocks of the Gram matrix (≤ 6 products)
            for c in range(a, len(Zs)):
                G[off[a] : off[a + 1], off[c] : off[c + 1]] = Zs[a].T @ AZs[c]
        G = np.triu(G) + np.triu(G, 1).T
        theta, C = np.linalg.eigh(G)
        theta, C = theta[:p], C[:, :p]
        Cs = [C[off[a] : off[a + 1]] for a in range(len(Zs))]
        Pn = sum(Zs[a] @ Cs[a] for a in range(1, len(Zs)))
        APn = sum(AZs[a] @ Cs[a] for a in range(1, len(Zs)))
        X = X @ Cs[0] + Pn
        AX = AX @ Cs[0] + APn
        P, AP = Pn, APn
        del Zs, AZs, R, W, AW, Pn, APn
        B = X.T @ P  # P ⟂ X, then orthonormal
        P -= X @ B
        AP -= AX @ B
        P, AP = _orthonormalize(P, AP)
        if P.shape[1] == 0:
            P = AP = None
        if it % refresh == 0:
            X, _ = _orthonormalize(X)
            AX = apply_A(X)
            theta, C = np.linalg.eigh(_sym(X.T @ AX))
            X, AX = X @ C, AX @ C
            if P is not None:
                AP = apply_A(P)


def _sym(G: np.ndarray) -> np.ndarray:
    return 0.5 * (G + G.T)


def _check_pencil(
    W: Any, mass: npt.ArrayLike, k: Any, tol: Any, rtol: Any
) -> tuple[sp.csr_array, np.ndarray, int]:
    """(W as float64 CSR, mass as float64, k as int) for :func:`multilevel_eigenpairs`, or
    :class:`~fvf.errors.SpectralInputError`."""
    W = sp.csr_array(W, dtype=np.float64)
    m = np.asarray(mass, dtype=np.float64)
    n = W.shape[0]
    if W.shape != (n, n) or m.shape != (n,) or not np.all(m > 0):
        raise SpectralInputError(
            f"multilevel_eigenpairs needs a square W and a positive mass ({n},); "
            f"got W {W.shape}, mass {m.shape}"
        )
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
        raise SpectralInputError(f"k must be a positive integer; got {k!r}")
    k = int(k)
    if 4 * (k + _extra(k)) > n:
        raise SpectralInputError(f"k = {k} is too large for n = {n} (multilevel path)")
    if not (isinstance(tol, float | int) and np.isfinite(tol) and 0 < tol < 1):
        raise SpectralInputError(f"tol must be a number in (0, 1); got {tol!r}")
    if not (isinstance(rtol, float | int) and np.isfinite(rtol) and 0 <= rtol < 1):
        raise SpectralInputError(f"rtol must be a number in [0, 1); got {rtol!r}")
    return W, m, k


def _start_block(H: AggregationHierarchy, m: np.ndarray, p: int, seed: int) -> np.ndarray:
    """The start block (n, p): the smallest eigenvectors of the coarsest Galerkin pencil
    (A_L, Pᵀ[M]P), prolongated; random columns where the coarsest level is too small."""
    n = m.size
    if len(H.levels) == 1:
        return np.random.default_rng(seed).standard_normal((n, p))
    Ml = sp.diags_array(m).tocsr()
    for lev in H.levels[:-1]:
        Ml = (lev.R @ (Ml @ lev.P)).tocsr()
    Mc = Ml.toarray()
    del Ml
    Ac = H.coarse_matrix.toarray()
    q = min(p, Ac.shape[0] - 1)
    _, Yc = sla.eigh(_sym(Ac), _sym(Mc), subset_by_index=[0, q - 1])
    X0 = H.prolongate(Yc)
    if q < p:
        X0 = np.hstack([X0, np.random.default_rng(seed).standard_normal((n, p - q))])
    return X0


def multilevel_eigenpairs(
    W: sp.sparray | sp.spmatrix,
    mass: npt.ArrayLike,
    k: int,
    *,
    near_kernel: np.ndarray,
    positions: np.ndarray,
    graph: sp.sparray | sp.spmatrix | None = None,
    tol: float = 1e-8,
    rtol: float = RTOL,
    seed: int = 0,
    maxiter: int = 300,
    info: dict | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The k smallest eigenpairs of W x = λ [M] x by multigrid-preconditioned LOBPCG.

    Parameters
    ----------
    W : sparse (N b, N b)
        Symmetric positive semidefinite, node-major with b dofs per node.
    mass : array_like float64 (N b,)
        Positive lumped mass.
    k : int
        Number of eigenpairs, 1 ≤ k and k + extra < N b / 4.
    near_kernel : ndarray float64 (N, b, r)
        Per-node local coordinates of r locally near-kernel fields (r ≥ b); see
        :class:`AggregationHierarchy`.
    positions : ndarray float64 (N, 3)
        Node positions for the aggregation.
    graph : sparse (N, N), optional
        Finest-level node adjacency.
    tol : float
        Bound on every pair's relative residual (:func:`fvf.numerics.eigen.eigen_residuals`).
    rtol : float
        Also bound every pair's residual ‖W x − λ[M]x‖_{M⁻¹} (x [M]-normalized) by
        ``rtol`` · λ_k, λ_k the largest of the k eigenvalues; 0 disables it. The
        ``tol`` measure is relative to ν ≥ λ_max, which on fine or irregular meshes is
        10⁶–10⁸ times λ_k, so ``tol`` alone does not pin down the eigenvectors: the
        sine of the angle to the exact eigenspace is about residual / gap. With the
        default (:data:`RTOL`) the ACAP eigenvalues agreed with the direct solver to
        ~1e-9 relative and the subspaces to a sine of ~1e-5 (see
        :func:`fvf.acap_fields`); each factor 10 smaller costs ~10–20 % more iterations.
    seed : int
        Seeds the power iterations and the random columns of the start block.
    maxiter : int
        Maximum LOBPCG iterations.
    info : dict, optional
        Filled with diagnostics: level sizes, timings, iterations, residuals.

    Returns
    -------
    evals : ndarray float64 (k,)
        Ascending.
    evecs : ndarray float64 (N b, k)
        [M]-orthonormal; each with its entry of largest magnitude positive.

    Raises
    ------
    SpectralInputError
        Bad shapes, k or tol.
    SpectralSolveError
        The iteration did not reach ``tol`` and ``rtol`` within ``maxiter`` iterations
        (or produced non-finite vectors).
    """
    W, m, k = _check_pencil(W, mass, k, tol, rtol)
    p = k + _extra(k)
    info = {} if info is None else info
    t0 = time.perf_counter()
    H = AggregationHierarchy(W, near_kernel, m, positions, graph=graph, seed=seed)
    info["levels"] = H.sizes
    info["operator_complexity"] = H.operator_complexity
    info["setup_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    X0 = _start_block(H, m, p, seed)
    info["start_s"] = time.perf_counter() - t0

    sq = np.sqrt(m)
    isq = 1.0 / sq
    nu = spectral_norm_bound(W, m)

    def apply_hat(Y):
        Y = np.asarray(Y)
        return sq.reshape((-1,) + (1,) * (Y.ndim - 1)) ** -1 * (
            W @ (isq.reshape((-1,) + (1,) * (Y.ndim - 1)) * Y)
        )

    def apply_prec(Y):
        Y = np.asarray(Y)
        s = sq.reshape((-1,) + (1,) * (Y.ndim - 1))
        return s * H.vcycle(s * Y)

    Y0 = X0 * sq[:, None]
    t0 = time.perf_counter()
    _, Y, _, iters = lobpcg_smallest(
        apply_hat, apply_prec, Y0, k, 0.1 * tol * nu, maxiter, tol_rel=0.5 * rtol
    )
    info["lobpcg_s"] = time.perf_counter() - t0
    info["iterations"] = iters
    X = Y * isq[:, None]
    lam_all, X_all, res_all = normalized_eigenpairs(W, m, X)
    lam, X, res = lam_all[:k], X_all[:, :k], res_all[:k]
    info["residuals"] = res
    # residual relative to λ_k: ‖r‖_{M⁻¹} / ‖x‖_M = res (|λ| + ν); x is M-normalized
    spec = res * (np.abs(lam) + nu) / max(abs(float(lam[-1])), np.finfo(float).tiny)
    info["spectral_residuals"] = spec
    if not np.all(res <= tol) or (rtol > 0 and not np.all(spec <= rtol)):
        raise SpectralSolveError(
            f"multilevel_eigenpairs: LOBPCG did not converge in {maxiter} iterations "
            f"(worst relative residual {res.max():.3g}, tol {tol:.3g}; worst residual / "
            f"lambda_k {spec.max():.3g}, rtol {rtol:.3g})"
        )
    return lam, X


def face_field_eigenpairs(
    mesh: Any,
    W: sp.sparray | sp.spmatrix,
    k: int,
    *,
    tol: float = 1e-8,
    rtol: float = RTOL,
    seed: int = 0,
    maxiter: int = 300,
    info: dict | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`multilevel_eigenpairs` for a pencil on face-major local tangent coordinates.

    Parameters
    ----------
    mesh : TriMesh
        m faces.
    W : sparse (2m, 2m)
        Symmetric positive semidefinite energy on ``mesh.to_local(u).ravel()`` (for
        instance :func:`fvf.acap_energy_matrix`); the mass is ``repeat(face_areas, 2)``.
    k, tol, rtol, seed, maxiter, info
        As in :func:`multilevel_eigenpairs`.

    Returns
    -------
    evals : ndarray float64 (k,)
    evecs : ndarray float64 (2m, k)
        ``repeat(face_areas, 2)``-orthonormal local coordinates.

    Notes
    -----
    Nodes are faces (b = 2), positions their centroids, the finest graph the face
    adjacency across edges, and the near-kernel the local coordinates of e_x, e_y, e_z
    (``mesh.face_bases``, (m, 2, 3)).
    """
    m = mesh.n_faces
    adj = mesh.face_adjacency
    rows = np.repeat(np.arange(m), 3)
    cols = adj.ravel()
    ok = cols >= 0
    G = sp.csr_array((np.ones(int(ok.sum())), (rows[ok], cols[ok])), shape=(m, m))
    return multilevel_eigenpairs(
        W,
        np.repeat(mesh.face_areas, 2),
        k,
        near_kernel=np.asarray(mesh.face_bases),
        positions=np.asarray(mesh.face_centroids),
        graph=G,
        tol=tol,
        rtol=rtol,
        seed=seed,
        maxiter=maxiter,
        info=info,
    )
