"""Point-to-point maps from functional maps and back, and ZoomOut refinement.

A vertex map p2p_21 (n_2,) sends vertex j of mesh 2 to vertex p2p_21[j] of mesh 1; its
functional map is C_12 = Φ_2ᵀ[A_V2] Φ_1[p2p_21] (:func:`fvf.functional_map_from_bases`).
Going back, a delta at vertex x of mesh 1 has coefficients Φ_1(x) (a row of Φ_1), which
C_12 carries to C_12 Φ_1(x)ᵀ on mesh 2; each vertex y of mesh 2 is matched to the x whose
carried embedding is nearest to Φ_2(y) (Ovsjanikov et al. 2012, §6.1). ZoomOut (Melzi et
al. 2019) alternates this conversion with the projection, one frequency more each time:
C_k -> p2p -> C_{k+step}, which removes the high-frequency noise of the map while raising
its resolution.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.linalg import solve_triangular
from scipy.spatial import cKDTree

from ..errors import BasisSizeError, ParameterError
from ..numerics.progress import ProgressCallback
from .basis import SpectralBasis
from .fmaps import functional_map_from_bases, split_sizes

__all__ = [
    "p2p_from_functional_map",
    "functional_map_from_p2p",
    "nearest_rows",
    "farthest_point_samples",
    "zoomout",
]


#: Up to this embedding dimension :func:`nearest_rows` uses a k-d tree; above, a blocked
#: exhaustive search by matrix products (k-d trees degrade to exhaustive search with
#: a large overhead in high dimension).
KDTREE_MAX_DIM = 12

#: Bytes of float32 distances the exhaustive search of :func:`nearest_rows` holds at a
#: time (one tile of queries by points); its working memory is a small multiple of this,
#: independent of the number of points and queries.
TILE_BYTES = 32 * 2**20

#: Fewest points in one tile (the queries per tile shrink to fit :data:`TILE_BYTES`).
TILE_MIN_POINTS = 256


def nearest_rows(
    points: np.ndarray,
    queries: np.ndarray,
    *,
    method: str = "auto",
    block: int = 1024,
    progress: ProgressCallback | None = None,
) -> np.ndarray:
    """For each row of ``queries`` (q, d), the index of the nearest row of ``points`` (n, d).

    Parameters
    ----------
    points : float64 (n, d)
    queries : float64 (q, d)
    method : {"auto", "kdtree", "brute"}
        ``"kdtree"``: :class:`scipy.spatial.cKDTree`; ``"brute"``: ‖p‖² − 2 q·p by matrix
        products over blocks of ``block`` queries, then the arg-min; ``"auto"``: the k-d
        tree for d <= :data:`KDTREE_MAX_DIM`, else brute. Both are exact Euclidean nearest
        neighbours (ties may break differently). The brute search holds O(:data:`TILE_BYTES`)
        of distances at a time, whatever n and q.
    block : int
        Queries per tile of the brute search (at most :data:`TILE_BYTES` /
        (4 :data:`TILE_MIN_POINTS`)).
    progress : callable, optional
        Called as ``progress("nearest", done, q)`` after each block of the brute search.

    Returns
    -------
    int64 (q,)
    """
    points = np.ascontiguousarray(points, dtype=float)
    queries = np.ascontiguousarray(queries, dtype=float)
    if method == "auto":
        method = "kdtree" if points.shape[1] <= KDTREE_MAX_DIM else "brute"
    if method == "kdtree":
        _, idx = cKDTree(points).query(queries, k=1)
        return np.asarray(idx, dtype=np.int64)
    if method != "brute":
        raise ParameterError(f"method must be 'auto', 'kdtree' or 'brute'; got {method!r}")
    return _nearest_brute(points, queries, block, progress)


def _nearest_brute(
    points: np.ndarray,
    queries: np.ndarray,
    block: int,
    progress: ProgressCallback | None = None,
) -> np.ndarray:
    """Exact nearest rows by matrix products: single precision to screen, double to decide.

    The squared distance ‖p‖² − 2 q·p is computed in float32 (twice the speed of
    float64) for every pair; its error is at most e = (2γ_d + 6u)‖q‖ max‖p‖ + 3u max‖p‖²
    (u = 2⁻²⁴, γ_d = d u / (1 − d u): the rounding of the inputs, of a length-d dot product
    and of the sum), so the true nearest row lies within 2e of the float32 minimum. The
    rows within 4e of it are compared again in float64, and the smallest (the first of
    exact ties) wins: the same answer as a float64 search.

    The distances are formed in tiles of ``block`` queries by at most
    :data:`TILE_BYTES` / (4 ``block``) points, keeping the running float32 minimum of each
    query and the rows within 4e of it: the working memory is O(:data:`TILE_BYTES`)
    besides the float32 copy of ``points``, whatever n and q. ``progress`` is called as
    ``progress("nearest", done, q)`` after each block of queries.
    """
    u = 2.0**-24
    dim = points.shape[1]
    gamma = dim * u / (1.0 - dim * u)
    sq = np.einsum("ij,ij->i", points, points)
    p_max = float(np.sqrt(sq.max()))
    P32, sq32 = points.astype(np.float32), sq.astype(np.float32)
    P32 *= -2.0  # exact: the products below are −2 q·p as rounded before
    q = queries.shape[0]
    block = max(1, min(int(block), TILE_BYTES // (4 * TILE_MIN_POINTS)))
    cols = max(TILE_MIN_POINTS, TILE_BYTES // (4 * block))
    out = np.empty(q, dtype=np.int64)
    for s in range(0, q, block):
        Qb = queries[s : s + block]
        q_norm = np.sqrt(np.einsum("ij,ij->i", Qb, Qb))
        slack = 4.0 * ((2 * gamma + 6 * u) * q_norm * p_max + 3 * u * p_max**2)
        r, c = _screen(Qb.astype(np.float32), P32, sq32, slack, cols)
        exact = sq[c] - 2.0 * np.einsum("ij,ij->i", Qb[r], points[c])
        order = np.lexsort((c, exact, r))  # by row, then distance, then index
        first = np.ones(order.size, dtype=bool)
        first[1:] = r[order][1:] != r[order][:-1]
        out[s + r[order][first]] = c[order][first]
        if progress is not None:
            progress("nearest", min(s + block, q), q)
    return out


def _screen(
    Q32: np.ndarray, P32: np.ndarray, sq32: np.ndarray, slack: np.ndarray, cols: int
) -> tuple[np.ndarray, np.ndarray]:
    """(query row, point) pairs whose float32 squared distance ‖p‖² − 2 q·p lies within
    ``slack`` (float64 (b,)) of the query's float32 minimum over all points, by tiles of
    ``cols`` points (``P32`` holds −2 p): int64 (c,), int64 (c,)."""
    best = np.full(Q32.shape[0], np.inf, dtype=np.float32)
    rows, found, values = [], [], []
    for t in range(0, P32.shape[0], cols):
        d = Q32 @ P32[t : t + cols].T  # (b, cols)
        d += sq32[None, t : t + cols]
        np.minimum(best, d.min(axis=1), out=best)
        near = np.flatnonzero(d <= (best + slack).astype(np.float32)[:, None])
        r, c = np.divmod(near, d.shape[1])  # 16x faster than a 2-d nonzero
        rows.append(r)
        found.append(c + t)
        values.append(d.ravel()[near])
    r, c, v = np.concatenate(rows), np.concatenate(found), np.concatenate(values)
    keep = v <= (best + slack).astype(np.float32)[r]  # against the minimum over all points
    return r[keep].astype(np.int64), c[keep].astype(np.int64)


def _check_sizes(C_12: npt.ArrayLike, basis_1: SpectralBasis, basis_2: SpectralBasis) -> np.ndarray:
    C = np.asarray(C_12, dtype=float)
    if C.ndim != 2:
        raise BasisSizeError(f"C_12 must be a (k_2, k_1) matrix; got shape {C.shape}")
    k2, k1 = C.shape
    if k1 > basis_1.k or k2 > basis_2.k or min(k1, k2) < 1:
        raise BasisSizeError(
            f"C_12 is ({k2}, {k1}) but basis_1 has {basis_1.k} and basis_2 has "
            f"{basis_2.k} eigenpairs; C_12 must be at most ({basis_2.k}, {basis_1.k}). "
            "Fix: build the bases with more eigenpairs."
        )
    if not np.isfinite(C).all():
        raise BasisSizeError("C_12 has NaN or inf entries")
    return C


def p2p_from_functional_map(
    C_12: npt.ArrayLike,
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    *,
    adjoint: bool = False,
    progress: ProgressCallback | None = None,
) -> np.ndarray:
    """The vertex map p2p_21 (mesh 2 -> mesh 1) of a functional map C_12.

    Parameters
    ----------
    C_12 : array_like (k_2, k_1)
        Coefficients on mesh 1 -> coefficients on mesh 2.
    basis_1, basis_2 : SpectralBasis
        At least k_1 and k_2 eigenpairs; only the first k_1 and k_2 are used.
    adjoint : bool
        False: match Φ_2(y) to the carried deltas Φ_1(x) C_12ᵀ (Ovsjanikov et al. 2012).
        True: match Φ_2(y) C_12 to Φ_1(x), the pull-back of deltas on mesh 2 by the
        adjoint (exact for an orthonormal C, more robust when C is far from it).
    progress : callable, optional
        Called as ``progress("nearest", done, n_2)`` during the search
        (:func:`nearest_rows`).

    Returns
    -------
    p2p_21 : int64 (n_2,)
        For each vertex of mesh 2, a vertex of mesh 1. For the other direction, pass
        C_21 (e.g. C_12ᵀ for an orthonormal map) with the bases swapped.

    Raises
    ------
    BasisSizeError
        C_12 larger than the bases, or non-finite.
    """
    C = _check_sizes(C_12, basis_1, basis_2)
    k2, k1 = C.shape
    phi1, phi2 = basis_1.eigenvectors[:, :k1], basis_2.eigenvectors[:, :k2]
    if adjoint:
        return nearest_rows(phi1, phi2 @ C, progress=progress)
    return nearest_rows(phi1 @ C.T, phi2, progress=progress)


def functional_map_from_p2p(
    p2p_21: npt.ArrayLike,
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    k: int | tuple[int, int] | None = None,
) -> np.ndarray:
    """C_12 = Φ_2ᵀ[A_V2] Φ_1[p2p_21] of a vertex map, truncated to (k_2, k_1).

    Parameters
    ----------
    p2p_21 : array_like of int (n_2,)
    basis_1, basis_2 : SpectralBasis
    k : int or (k_1, k_2), optional
        Default: every eigenpair of each basis.

    Returns
    -------
    float64 (k_2, k_1)
    """
    k1, k2 = split_sizes(k)
    b1 = basis_1 if k1 is None else basis_1.truncate(_k_in(k1, basis_1, "basis_1"))
    b2 = basis_2 if k2 is None else basis_2.truncate(_k_in(k2, basis_2, "basis_2"))
    return functional_map_from_bases(b1, b2, p2p_21)


def _k_in(k: int, basis: SpectralBasis, name: str) -> int:
    k = int(k)
    if not 1 <= k <= basis.k:
        raise BasisSizeError(
            f"{name} has {basis.k} eigenpairs; k = {k} were asked for. Fix: build the "
            f"SpectralBasis with at least {k} eigenpairs."
        )
    return k


def farthest_point_samples(points: npt.ArrayLike, count: int, start: int = 0) -> np.ndarray:
    """Farthest-point sampling in Euclidean space: int64 (count,) row indices.

    Greedy: each new sample is the point farthest from those chosen (Gonzalez 1985), so the
    samples cover the shape evenly. Costs count passes over the points.

    Parameters
    ----------
    points : float64 (n, d)
    count : int
        1 <= count; capped at n.
    start : int
        The first sample.
    """
    X = np.asarray(points, dtype=float)
    count = min(int(count), X.shape[0])
    if count < 1:
        raise ParameterError(f"count must be >= 1; got {count}")
    chosen = np.empty(count, dtype=np.int64)
    chosen[0] = start
    diff = X - X[start]
    dist = np.einsum("ij,ij->i", diff, diff)  # squared distances: the same arg-max
    for i in range(1, count):  # a loop over samples, each a vectorized pass
        chosen[i] = int(dist.argmax())
        np.subtract(X, X[chosen[i]], out=diff)
        np.minimum(dist, np.einsum("ij,ij->i", diff, diff), out=dist)
    return chosen


def _zoomout_sizes(C: np.ndarray, k_final: int, step: int) -> list[tuple[int, int]]:
    """The (k_1, k_2) sizes ZoomOut passes through after the start, ending at k_final."""
    k2, k1 = C.shape
    sizes = []
    while max(k1, k2) < k_final or k1 != k2:
        k1, k2 = min(k1 + step, k_final), min(k2 + step, k_final)
        sizes.append((k1, k2))
    return sizes


def zoomout(
    C_12: npt.ArrayLike,
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    k_final: int | None = None,
    *,
    step: int = 1,
    samples: int | tuple[np.ndarray, np.ndarray] | None = None,
    adjoint: bool = False,
    progress: ProgressCallback | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Refine a functional map by ZoomOut (Melzi et al. 2019).

    Starting from C_12 (k_2, k_1), repeat: p2p_21 = :func:`p2p_from_functional_map` (C);
    C = the functional map of p2p_21 with ``step`` more eigenpairs on each side, until the
    size reaches ``k_final``; the returned vertex map is converted from the final C.

    Parameters
    ----------
    C_12 : array_like (k_2, k_1)
    basis_1, basis_2 : SpectralBasis
        With at least ``k_final`` eigenpairs each.
    k_final : int, optional
        Final size (k_final, k_final); default the smaller basis size.
    step : int
        Eigenpairs added per iteration (>= 1).
    samples : int or (int64 (s_1,), int64 (s_2,)), optional
        Iterate on vertex samples only (Melzi et al. 2019, §5): the count of
        :func:`farthest_point_samples` per mesh, or the sample indices. Each iteration
        then matches samples of mesh 2 to samples of mesh 1 and fits C by least squares
        Φ_2[s_2] C ≈ Φ_1[p] (needs more samples than k_final); the final vertex map is
        computed on all vertices. None: every vertex, C by projection
        (:func:`functional_map_from_p2p`).
    adjoint : bool
        Conversion variant, see :func:`p2p_from_functional_map`.
    progress : callable, optional
        Called as ``progress("nearest", done, n_2)`` during the final conversion on all
        vertices (the longest step on a large mesh: O(n_1 n_2 k_final) operations).

    Returns
    -------
    C_12 : float64 (k_final, k_final)
    p2p_21 : int64 (n_2,)

    Raises
    ------
    BasisSizeError
        k_final larger than a basis or smaller than C_12, or fewer samples than k_final.
    ParameterError
        step < 1.
    """
    C = _check_sizes(C_12, basis_1, basis_2)
    k_final = min(basis_1.k, basis_2.k) if k_final is None else int(k_final)
    if k_final > min(basis_1.k, basis_2.k) or k_final < max(C.shape):
        raise BasisSizeError(
            f"k_final = {k_final} must lie between the size of C_12 {C.shape} and the "
            f"smaller basis ({min(basis_1.k, basis_2.k)} eigenpairs)."
        )
    if int(step) < 1:
        raise ParameterError(f"step must be >= 1; got {step}")
    sizes = _zoomout_sizes(C, k_final, int(step))
    if samples is None:
        for k1, k2 in sizes:
            p2p = p2p_from_functional_map(C, basis_1, basis_2, adjoint=adjoint)
            C = functional_map_from_p2p(p2p, basis_1, basis_2, (k1, k2))
    else:
        C = _zoomout_on_samples(C, basis_1, basis_2, sizes, samples, adjoint)
    return C, p2p_from_functional_map(C, basis_1, basis_2, adjoint=adjoint, progress=progress)


def _zoomout_on_samples(
    C: np.ndarray,
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    sizes: list[tuple[int, int]],
    samples: int | tuple[np.ndarray, np.ndarray],
    adjoint: bool,
) -> np.ndarray:
    """ZoomOut iterations restricted to vertex samples, C fitted by least squares."""
    if isinstance(samples, tuple | list | np.ndarray):
        s1, s2 = (np.asarray(s, dtype=np.int64) for s in samples)
    else:
        s1 = farthest_point_samples(basis_1.mesh.vertices, int(samples))
        s2 = farthest_point_samples(basis_2.mesh.vertices, int(samples))
    k_final = sizes[-1][0] if sizes else C.shape[1]
    if min(s1.size, s2.size) <= k_final:
        raise BasisSizeError(
            f"ZoomOut on samples needs more samples than k_final = {k_final}; got "
            f"{s1.size} and {s2.size}. Fix: more samples, or samples=None."
        )
    P1, P2 = basis_1.eigenvectors[s1], basis_2.eigenvectors[s2]
    # Least squares with the leading k2 columns of P2 for every k2 from one QR: the
    # leading columns of P2 = Q R are Q[:, :k2] R[:k2, :k2].
    Q, R = np.linalg.qr(P2[:, : max((k2 for _, k2 in sizes), default=1)])
    r = np.abs(np.diag(R))
    well_posed = r.min() > 1e-10 * r.max()
    for k1, k2 in sizes:
        kc2, kc1 = C.shape
        if adjoint:
            p = nearest_rows(P1[:, :kc1], P2[:, :kc2] @ C)
        else:
            p = nearest_rows(P1[:, :kc1] @ C.T, P2[:, :kc2])
        if well_posed:
            C = solve_triangular(R[:k2, :k2], Q[:, :k2].T @ P1[p, :k1])
        else:  # samples that do not determine C: the minimum-norm solution
            C = np.linalg.lstsq(P2[:, :k2], P1[p, :k1], rcond=None)[0]
    return C
