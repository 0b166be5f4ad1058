"""Spectral point descriptors: heat and wave kernel signatures, plain and landmark-based.

Both are functions of the Laplace–Beltrami eigenpairs (λ_i, φ_i) of a
:class:`~fvf.SpectralBasis`, hence invariant under isometries, and both are the diagonal
(or, with landmarks, a column) of a spectral kernel K(x, y) = Σ_i g(λ_i) φ_i(x) φ_i(y):

- heat kernel signature (Sun et al. 2009): g_t(λ) = exp(−λt), one descriptor per time t;
- wave kernel signature (Aubry et al. 2011): g_e(λ) = exp(−(e − log λ)² / 2σ²) / Σ_i g_e(λ_i),
  one per log-energy e, a band-pass filter that localizes better than the heat's low-pass.

With landmarks ℓ_1 … ℓ_q, the column K(·, ℓ_j) of each kernel is a descriptor
(Ovsjanikov et al. 2012, §6): corresponding landmarks on two shapes give corresponding
functions, which breaks intrinsic symmetries that the diagonal cannot see.

Eigenvalues are those of :class:`~fvf.SpectralBasis` (of L = −div grad, ascending, λ_0 ≈ 0);
eigenvectors are A_V-orthonormal. Times and energies are in the units of the mesh: scale a
mesh to unit area (as :func:`fvf.match` does) to compare descriptors across shapes of
different sizes.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..errors import CorrespondenceError, LandmarkError, ParameterError, format_indices
from .basis import SpectralBasis
from .fmaps import check_p2p

__all__ = [
    "heat_kernel_signature",
    "wave_kernel_signature",
    "hks_times",
    "wks_energies",
    "check_landmarks",
    "mirror_distance",
]

#: Eigenvalues below this fraction of the largest one count as zero (constant functions).
ZERO_EIGENVALUE_RTOL = 1e-9

#: The WKS bandwidth σ in units of the energy spacing (Aubry et al. 2011 use 6–7).
WKS_SIGMA_SPACINGS = 7.0


def _nonzero_spectrum(basis: SpectralBasis, k: int | None) -> tuple[np.ndarray, np.ndarray]:
    """The first k eigenpairs without the zero (constant) ones: (λ (r,), Φ (n, r))."""
    k = basis.k if k is None else int(k)
    if not 2 <= k <= basis.k:
        raise CorrespondenceError(
            f"k must be in [2, {basis.k}] (the basis has {basis.k} eigenpairs); got {k}. Fix: "
            f"build the SpectralBasis with at least {k} eigenpairs."
        )
    lam = np.asarray(basis.eigenvalues[:k], dtype=float)
    keep = lam > ZERO_EIGENVALUE_RTOL * max(abs(lam[-1]), 1e-300)
    if not keep.any():
        raise CorrespondenceError(
            "the basis has no positive eigenvalue among its first "
            f"{k}; descriptors need non-constant eigenfunctions."
        )
    return lam[keep], basis.eigenvectors[:, :k][:, keep]


def check_landmarks(landmarks: npt.ArrayLike, n: int, name: str = "landmarks") -> np.ndarray:
    """Validate vertex indices: int64 (q,) with values in [0, n), no repeats.

    Raises
    ------
    LandmarkError
        Not a 1-D integer array, an index out of range (named), or a repeated index.
    """
    a = np.asarray(landmarks)
    if a.ndim != 1 or not (a.size == 0 or np.issubdtype(a.dtype, np.integer)):
        raise LandmarkError(
            f"{name} must be a 1-D array of integer vertex indices; got {a.dtype} {a.shape}."
        )
    a = a.astype(np.int64)
    bad = np.flatnonzero((a < 0) | (a >= n))
    if bad.size:
        raise LandmarkError(
            f"{name} at positions {format_indices(bad)} (values "
            f"{format_indices(a[bad])}) are outside [0, {n}): the mesh has {n} vertices."
        )
    _, first, counts = np.unique(a, return_index=True, return_counts=True)
    if (counts > 1).any():
        raise LandmarkError(
            f"{name} repeat vertices {format_indices(a[np.sort(first[counts > 1])])}; "
            "give each landmark once."
        )
    return a


def hks_times(eigenvalues: npt.ArrayLike, n_times: int = 100) -> np.ndarray:
    """Log-spaced HKS times between 4 ln 10 / λ_max and 4 ln 10 / λ_1 (Sun et al. 2009).

    Parameters
    ----------
    eigenvalues : array_like (k,)
        Ascending; zero eigenvalues are ignored.
    n_times : int

    Returns
    -------
    float64 (n_times,)
        Ascending times: at the smallest, e^{−λ_max t} = 10⁻⁴; at the largest,
        e^{−λ_1 t} = 10⁻⁴ (all but the constant mode have decayed).
    """
    lam = np.asarray(eigenvalues, dtype=float)
    lam = lam[lam > ZERO_EIGENVALUE_RTOL * max(abs(lam).max(initial=0.0), 1e-300)]
    if lam.size == 0 or int(n_times) < 1:
        raise ParameterError("hks_times needs a positive eigenvalue and n_times >= 1")
    c = 4.0 * np.log(10.0)
    return np.geomspace(c / lam.max(), c / lam.min(), int(n_times))


def wks_energies(eigenvalues: npt.ArrayLike, n_energies: int = 100) -> tuple[np.ndarray, float]:
    """WKS log-energies and bandwidth σ (Aubry et al. 2011).

    The log-spectrum [log λ_1, log λ_max] is split into n_energies steps δ; σ = 7δ and the
    energies are evenly spaced in [log λ_1 + 2σ, log λ_max − 2σ], so every filter sees
    eigenvalues on both sides.

    Returns
    -------
    energies : float64 (n_energies,)
    sigma : float
    """
    lam = np.asarray(eigenvalues, dtype=float)
    lam = lam[lam > ZERO_EIGENVALUE_RTOL * max(abs(lam).max(initial=0.0), 1e-300)]
    if lam.size == 0 or int(n_energies) < 1:
        raise ParameterError("wks_energies needs a positive eigenvalue and n_energies >= 1")
    e_min, e_max = np.log(lam.min()), np.log(lam.max())
    sigma = WKS_SIGMA_SPACINGS * (e_max - e_min) / int(n_energies)
    if not sigma > 0:  # a single distinct eigenvalue: one band around it
        return np.full(int(n_energies), e_min), 1.0
    return np.linspace(e_min + 2 * sigma, e_max - 2 * sigma, int(n_energies)), float(sigma)


def _kernel_signature(
    basis: SpectralBasis, weights: np.ndarray, phi: np.ndarray, landmarks: npt.ArrayLike | None
) -> np.ndarray:
    """Σ_i w[s, i] φ_i(x) φ_i(y) for y = x (diagonal) or y = each landmark.

    weights (S, r), phi (n, r) -> (n, S) or, with q landmarks, (n, q S) landmark-major.
    """
    if landmarks is None:
        return (phi * phi) @ weights.T
    lm = check_landmarks(landmarks, basis.mesh.n_vertices)
    # (n, r) * (q, S, r) summed over r -> (n, q, S)
    out = np.einsum("xr,qsr->xqs", phi, phi[lm][:, None, :] * weights[None], optimize=True)
    return out.reshape(phi.shape[0], -1)


def heat_kernel_signature(
    basis: SpectralBasis,
    times: npt.ArrayLike | None = None,
    *,
    n_times: int = 100,
    k: int | None = None,
    landmarks: npt.ArrayLike | None = None,
    scaled: bool = True,
) -> np.ndarray:
    """Heat kernel signature h_t(x) = Σ_i e^{−λ_i t} φ_i(x)² (Sun et al. 2009).

    Parameters
    ----------
    basis : SpectralBasis
    times : array_like (T,), optional
        Positive diffusion times; default :func:`hks_times` of the basis (``n_times`` of them).
    n_times : int
    k : int, optional
        Use the first k eigenpairs (default all of the basis).
    landmarks : array_like of int (q,), optional
        Vertex indices; then the descriptors are the columns h_t(x, ℓ_j) =
        Σ_i e^{−λ_i t} φ_i(x) φ_i(ℓ_j) of the heat kernel.
    scaled : bool
        Divide each time's descriptor by Σ_i e^{−λ_i t} (the heat trace), so that all times
        weigh alike.

    Returns
    -------
    float64 (n, T), or (n, q T) with landmarks (landmark-major: column j T + s is
    landmark j at time s).

    Raises
    ------
    LandmarkError
        A landmark index outside [0, n) or repeated.
    CorrespondenceError
        k outside [2, basis.k].
    ParameterError
        A time that is not positive and finite.
    """
    lam, phi = _nonzero_spectrum(basis, k)
    t = hks_times(lam, n_times) if times is None else np.asarray(times, dtype=float).ravel()
    if t.size == 0 or not (np.isfinite(t).all() and (t > 0).all()):
        raise ParameterError("times must be a non-empty array of positive finite numbers")
    w = np.exp(-np.outer(t, lam))  # (T, r)
    if scaled:
        w /= w.sum(axis=1, keepdims=True)
    return _kernel_signature(basis, w, phi, landmarks)


def wave_kernel_signature(
    basis: SpectralBasis,
    energies: npt.ArrayLike | None = None,
    sigma: float | None = None,
    *,
    n_energies: int = 100,
    k: int | None = None,
    landmarks: npt.ArrayLike | None = None,
) -> np.ndarray:
    """Wave kernel signature (Aubry et al. 2011), normalized per energy.

    WKS_e(x) = Σ_i g_e(λ_i) φ_i(x)² / Σ_i g_e(λ_i), g_e(λ) = exp(−(e − log λ)² / 2σ²):
    the probability of finding at x a quantum particle of log-energy distribution centred
    at e.

    Parameters
    ----------
    basis : SpectralBasis
    energies : array_like (E,), optional
        Log-energies; default :func:`wks_energies` of the basis (``n_energies`` of them,
        with its σ).
    sigma : float, optional
        Bandwidth; required with explicit ``energies`` unless they come with the default.
    n_energies : int
    k : int, optional
        Use the first k eigenpairs (default all of the basis).
    landmarks : array_like of int (q,), optional
        Vertex indices; then the descriptors are the columns Σ_i g_e(λ_i) φ_i(x) φ_i(ℓ_j).

    Returns
    -------
    float64 (n, E), or (n, q E) with landmarks (landmark-major).

    Raises
    ------
    LandmarkError
        A landmark index outside [0, n) or repeated.
    ParameterError
        Non-finite energies or a σ that is not positive.
    """
    lam, phi = _nonzero_spectrum(basis, k)
    if energies is None:
        e, s = wks_energies(lam, n_energies)
        sigma = s if sigma is None else sigma
    else:
        e = np.asarray(energies, dtype=float).ravel()
        if sigma is None:
            raise ParameterError("sigma is required with explicit energies")
    if e.size == 0 or not np.isfinite(e).all():
        raise ParameterError("energies must be a non-empty array of finite numbers")
    if not (np.isfinite(sigma) and sigma > 0):
        raise ParameterError(f"sigma must be positive and finite; got {sigma!r}")
    w = np.exp(-((e[:, None] - np.log(lam)[None, :]) ** 2) / (2.0 * sigma**2))  # (E, r)
    w /= np.maximum(w.sum(axis=1, keepdims=True), 1e-300)
    return _kernel_signature(basis, w, phi, landmarks)


def mirror_distance(basis: SpectralBasis, symmetry: npt.ArrayLike, k: int = 30) -> np.ndarray:
    """How far each vertex lies from its own mirror image: d_B(x, σ(x)).

    With σ a self-map of the mesh (its left-right symmetry, :func:`fvf.symmetry_map`),
    d_B is the biharmonic distance of Lipman, Rustamov and Funkhouser (2010),

    .. math::

        d_B(x, y)^2 = \\sum_{i=1}^{k-1} \\frac{(\\varphi_i(x) - \\varphi_i(y))^2}{\\lambda_i^2},

    smooth, close to the geodesic distance at large scale and cheap from the eigenpairs.
    The result is about 0 on the plane of symmetry (spine, head, tail) and grows along
    limbs that come in pairs (a foot is far from the other foot), so it tells a tail from
    a leg where the kernel signatures may not. Invariant under isometries when σ is.

    Parameters
    ----------
    basis : SpectralBasis
        At least k eigenpairs; λ_0 ≈ 0 is skipped.
    symmetry : array_like of int (n,)
        σ: for each vertex, its image.
    k : int
        Eigenpairs used (the first min(k, basis.k)).

    Returns
    -------
    float64 (n,) >= 0.

    Raises
    ------
    FieldShapeError
        ``symmetry`` not an integer array of length n, or holding an index outside
        [0, n) (named).
    """
    n = basis.eigenvectors.shape[0]
    sigma = check_p2p(symmetry, n, n, "symmetry")  # a vertex map from the mesh to itself
    lam, phi = _nonzero_spectrum(basis, min(int(k), basis.k))
    E = phi / lam
    diff = E - E[sigma]
    return np.sqrt(np.einsum("ij,ij->i", diff, diff))
