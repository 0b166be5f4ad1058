"""Laplace–Beltrami eigenbases and operators reduced to them (Azencot et al. 2013).

The chapter's second pillar (§1): a functional vector field D_v, an n x n matrix, is
represented compactly by the k x k matrix D̂_v = Φᵀ [A_V] D^V_v Φ in the basis Φ of the
k smoothest Laplace–Beltrami eigenfunctions. This module holds the basis (a solver object
with its eigenpairs, optionally cached on disk), projection and reconstruction in the
A_V inner product (eq. 26), reduced operators, brackets and flows, and the inverse
problem: the field whose reduced operator is closest to a given k x k matrix.
"""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path
from typing import Any, Literal, overload

import numpy as np
import numpy.typing as npt

from ..calculus import grad, rotate, stiffness, vertex_to_face
from ..errors import FieldShapeError, ParameterError
from ..flows.functional import FunctionalFlow
from ..io.atomic import atomic_path
from ..mesh.convert import takes_mesh
from ..mesh.inputs import TangentPolicy, as_count, as_face_field, as_vertex_function
from ..mesh.trimesh import TriMesh
from ..numerics.eigen import smallest_eigenpairs
from ..numerics.expm import as_times, dense_expm_action
from ..numerics.progress import ProgressCallback

__all__ = [
    "SpectralBasis",
    "laplace_basis",
    "gradient_field_basis",
]

_CACHE_VERSION = "fvf-lb-1"


class SpectralBasis:
    """The k smallest Laplace–Beltrami eigenpairs of a mesh, and operators reduced to them.

    Solves W φ = λ [A_V] φ (W = :func:`fvf.stiffness`, so λ are the eigenvalues of
    L = −div grad) with :func:`fvf.numerics.eigen.smallest_eigenpairs`.

    Parameters
    ----------
    mesh : TriMesh
    k : int
        Number of eigenpairs, 1 <= k < n.
    tol : float
        Relative residual of every eigenpair (see :func:`fvf.numerics.eigen.eigen_residuals`).
    seed : int
        Seed of the eigensolver's random start (results are deterministic).
    cache_dir : str or Path, optional
        If given, the eigenpairs are stored in and loaded from
        ``cache_dir/lb-<hash>.npz``, the hash covering (V, F, k, tol).
    progress : None, bool or callable
        ``True`` for a tqdm bar, or a callback ``(stage, done, total)``
        (:func:`fvf.numerics.eigen.smallest_eigenpairs`: ``"factor"``, ``"iterate"``).

    Attributes
    ----------
    eigenvalues : float64 (k,)
        Ascending; the first is 0 (up to round-off) on a connected mesh.
    eigenvectors : float64 (n, k)
        A_V-orthonormal: ``Φᵀ [A_V] Φ = I``; sign convention of
        :func:`fvf.numerics.eigen.smallest_eigenpairs`.

    Examples
    --------
    >>> import numpy as np, fvf
    >>> basis = fvf.SpectralBasis(fvf.icosphere(3), 9)
    >>> np.round(basis.eigenvalues[:4], 1).tolist() == [0, 2, 2, 2]  # l(l+1), 2l+1 times
    True
    """

    @takes_mesh
    def __init__(
        self,
        mesh: TriMesh,
        k: int,
        *,
        tol: float = 1e-8,
        seed: int = 0,
        cache_dir: str | Path | None = None,
        progress: bool | ProgressCallback | None = None,
    ) -> None:
        self.mesh = mesh
        self.k = as_count(k, "k", 1)
        self.tol = float(tol)
        path = None
        if cache_dir is not None:
            path = Path(cache_dir) / f"lb-{self.cache_key()}.npz"
            if self._load_cache(path):
                return
        self.eigenvalues, self.eigenvectors = smallest_eigenpairs(
            stiffness(mesh), mesh.vertex_areas, self.k, tol=self.tol, seed=seed, progress=progress
        )
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            with atomic_path(path) as tmp:  # whole or not at all: never a half-written cache
                np.savez(tmp, eigenvalues=self.eigenvalues, eigenvectors=self.eigenvectors)

    def _load_cache(self, path: Path) -> bool:
        """Take the eigenpairs from a cache file; False (recompute) when it is missing or
        unreadable, or holds arrays of the wrong shape (never trusted blindly)."""
        try:
            with np.load(path, allow_pickle=False) as data:
                values, vectors = data["eigenvalues"], data["eigenvectors"]
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
            return False
        n = self.mesh.n_vertices
        if values.shape != (self.k,) or vectors.shape != (n, self.k):
            return False
        if not (np.isfinite(values).all() and np.isfinite(vectors).all()):
            return False
        self.eigenvalues, self.eigenvectors = values, vectors
        return True

    @classmethod
    def from_eigenpairs(
        cls, mesh: TriMesh, eigenvalues: npt.ArrayLike, eigenvectors: npt.ArrayLike
    ) -> SpectralBasis:
        """A basis from eigenpairs computed elsewhere (no eigensolve, no check of them).

        Parameters
        ----------
        mesh : TriMesh
        eigenvalues : array_like (k,)
        eigenvectors : array_like (n, k)
            Expected A_V-orthonormal eigenvectors of L = −div grad on ``mesh``.

        Raises
        ------
        FieldShapeError
            Shapes that do not fit the mesh or each other.
        """
        lam = np.asarray(eigenvalues, dtype=float)
        phi = np.asarray(eigenvectors, dtype=float)
        if lam.ndim != 1 or phi.shape != (mesh.n_vertices, lam.size):
            raise FieldShapeError(
                f"eigenvectors must be ({mesh.n_vertices}, {lam.size}) for "
                f"{lam.size} eigenvalues; got {phi.shape}"
            )
        out = object.__new__(cls)
        out.mesh, out.k, out.tol = mesh, lam.size, float("nan")
        out.eigenvalues, out.eigenvectors = lam, phi
        return out

    def truncate(self, k: int) -> SpectralBasis:
        """The first k eigenpairs as a basis of its own (no eigensolve; arrays shared).

        Raises
        ------
        ParameterError
            k outside [1, self.k].
        """
        k = int(k)
        if not 1 <= k <= self.k:
            raise ParameterError(f"k must be in [1, {self.k}]; got {k}")
        if k == self.k:
            return self
        out = object.__new__(SpectralBasis)
        out.mesh, out.k, out.tol = self.mesh, k, self.tol
        out.eigenvalues = self.eigenvalues[:k]
        out.eigenvectors = self.eigenvectors[:, :k]
        return out

    def cache_key(self) -> str:
        """sha256 of the mesh arrays, k and tol: the on-disk cache's file name."""
        h = hashlib.sha256(_CACHE_VERSION.encode())
        h.update(self.mesh.vertices.tobytes())
        h.update(self.mesh.faces.tobytes())
        h.update(f"{self.k}:{self.tol!r}".encode())
        return h.hexdigest()[:32]

    # ------------------------------------------------------------------ functions
    def project(self, f: npt.ArrayLike) -> np.ndarray:
        """Coefficients Φᵀ [A_V] f: PL function(s) (n,) or (n, c) -> (k,) or (k, c)."""
        f = as_vertex_function(self.mesh, f, columns=True)
        return self.eigenvectors.T @ (self.mesh.vertex_areas.reshape(-1, *[1] * (f.ndim - 1)) * f)

    def reconstruct(self, coefficients: npt.ArrayLike) -> np.ndarray:
        """Φ c: coefficients (k,) or (k, c) -> PL function(s) (n,) or (n, c)."""
        c = np.asarray(coefficients, dtype=float)
        if c.shape[0] != self.k:
            raise FieldShapeError(f"coefficients must have {self.k} rows; got shape {c.shape}")
        return self.eigenvectors @ c

    # ------------------------------------------------------------------ operators
    def reduce(self, O: Any) -> np.ndarray:
        """Ô = Φᵀ [A_V] O Φ: any n x n operator (sparse, dense or LinearOperator) -> (k, k)."""
        n = self.mesh.n_vertices
        if O.shape != (n, n):
            raise FieldShapeError(f"operator must be ({n}, {n}); got {O.shape}")
        OPhi = np.asarray(O @ self.eigenvectors)  # (n, k)
        return self.eigenvectors.T @ (self.mesh.vertex_areas[:, None] * OPhi)

    @property
    def _hat_data(self) -> tuple[np.ndarray, np.ndarray]:
        """(A_F I_F^V Φ (m, k), grad Φ (m, 3, k)): D̂_v = Hᵀ (D^F_v Φ) for any field."""
        cached = getattr(self, "_hat_cache", None)
        if cached is None:
            mesh = self.mesh
            H = mesh.face_areas[:, None] * (vertex_to_face(mesh) @ self.eigenvectors)
            G = (grad(mesh) @ self.eigenvectors).reshape(mesh.n_faces, 3, self.k)
            cached = self._hat_cache = (H, G)
        return cached

    def reduced_D(self, v: npt.ArrayLike, tangent: TangentPolicy = "project") -> np.ndarray:
        """D̂_v = Φᵀ [A_V] D^V_v Φ: float64 (k, k) (Azencot et al. 2013).

        Computed as (A_F I_F^V Φ)ᵀ (D^F_v Φ), using A_V I_V^F = (I_F^V)ᵀ A_F (§3.1),
        without assembling D^V_v. Linear in v.
        """
        return self.reduced_D_many(as_face_field(self.mesh, v, "v", tangent)[None])[0]

    def reduced_D_many(self, fields: np.ndarray) -> np.ndarray:
        """D̂ for a stack of checked tangent fields (p, m, 3) -> (p, k, k)."""
        H, G = self._hat_data
        p, m = fields.shape[0], self.mesh.n_faces
        DPhi = np.matmul(np.asarray(fields).transpose(1, 0, 2), G)  # (m, p, k): D^F_v Φ
        out = H.T @ DPhi.reshape(m, -1)  # (k, p k): one matrix product for all fields
        return out.reshape(self.k, p, self.k).transpose(1, 0, 2)

    def reduced_laplacian(self) -> np.ndarray:
        """L̂ = diag(eigenvalues), (k, k)."""
        return np.diag(self.eigenvalues)

    def reduced_bracket(self, v: npt.ArrayLike, w: npt.ArrayLike) -> np.ndarray:
        """[D̂_v, D̂_w] = D̂_v D̂_w − D̂_w D̂_v: the reduced vertex bracket (eq. 46), (k, k).

        This is the bracket of the reduced operators, which differs from the reduction of
        D^V_{[v,w]} by the part of D^V_w Φ outside the span; use
        ``basis.reduce(fvf.bracket_V(mesh, v, w))`` or ``bracket_F`` for the latter.
        """
        Dv, Dw = self.reduced_D(v), self.reduced_D(w)
        return Dv @ Dw - Dw @ Dv

    def commutator_with_laplacian(self, v: npt.ArrayLike) -> float:
        """‖D̂_v L̂ − L̂ D̂_v‖_F / (‖D̂_v‖_F · λ_max): 0 for a Killing field (scale-free)."""
        D = self.reduced_D(v)
        lam = self.eigenvalues
        C = D * (lam[None, :] - lam[:, None])
        return float(np.linalg.norm(C) / (np.linalg.norm(D) * max(abs(lam[-1]), 1e-300)))

    # ------------------------------------------------------------------ flows
    @overload
    def reduced_flow(
        self,
        v: npt.ArrayLike,
        f: npt.ArrayLike,
        t: float | npt.ArrayLike,
        *,
        error_estimate: Literal[False] = ...,
        n_quadrature: int = ...,
    ) -> np.ndarray: ...
    @overload
    def reduced_flow(
        self,
        v: npt.ArrayLike,
        f: npt.ArrayLike,
        t: float | npt.ArrayLike,
        *,
        error_estimate: Literal[True],
        n_quadrature: int = ...,
    ) -> tuple[np.ndarray, Any]: ...
    def reduced_flow(
        self,
        v: npt.ArrayLike,
        f: npt.ArrayLike,
        t: float | npt.ArrayLike,
        *,
        error_estimate: bool = False,
        n_quadrature: int = 33,
    ) -> np.ndarray | tuple[np.ndarray, Any]:
        """Flow a function in the reduced basis: Φ exp(−t D̂_v) Φᵀ[A_V] f (eq. 42 reduced).

        Parameters
        ----------
        v : array_like (m, 3)
        f : array_like (n,)
        t : float or array_like (T,)
        error_estimate : bool
            Also return an upper estimate of ‖f_full(t) − f_reduced(t)‖_{A_V}.
        n_quadrature : int
            Time samples for the error integral.

        Returns
        -------
        f_t : float64 (n,) or (T, n)
        error : float or float64 (T,), only if ``error_estimate``
            e^{μ|t|} ‖f − ΦΦᵀA f‖ + ∫_0^{|t|} e^{μ(|t|−s)} ‖(D Φ − Φ D̂) c(s)‖ ds, with μ the
            growth rate of the full flow (:class:`fvf.FunctionalFlow`): the variation-of-
            constants bound on the difference to the full flow, integrated by the
            trapezoidal rule. It vanishes when span(Φ) is invariant under D^V_v.
        """
        v = as_face_field(self.mesh, v, "v")
        f = as_vertex_function(self.mesh, f)
        Dhat = self.reduced_D(v, tangent="ignore")
        c0 = self.project(f)
        times, _ = as_times(t)
        # (T, k), one eigen-decomposition for all times; no times give (0, n), as every
        # flow of fvf.flow
        coeffs = dense_expm_action(-Dhat, c0, times).reshape(-1, self.k)
        out = coeffs @ self.eigenvectors.T  # (T, n)
        if not error_estimate:
            return out[0] if np.ndim(t) == 0 else out
        phi = FunctionalFlow(self.mesh, v, growth_limit=np.inf, tangent="ignore")
        a = self.mesh.vertex_areas
        R = phi.operator @ self.eigenvectors - self.eigenvectors @ Dhat  # (n, k) leakage
        e0 = f - self.eigenvectors @ c0
        norm0 = float(np.sqrt(a @ (e0 * e0)))
        errs: list[float] = []
        for T in times:
            mu = phi.growth_rate[0] if T >= 0 else phi.growth_rate[1]
            s = np.linspace(0.0, abs(T), n_quadrature)
            cs = dense_expm_action(-np.sign(T) * Dhat, c0, s)  # (q, k)
            leak = np.sqrt(np.einsum("i,qi->q", a, (cs @ R.T) ** 2))  # (q,)
            weights = np.exp(mu * (abs(T) - s)) * leak
            errs.append(np.exp(mu * abs(T)) * norm0 + np.trapezoid(weights, s))
        if np.ndim(t) == 0:
            return out[0], float(errs[0])
        return out, np.array(errs)

    # ------------------------------------------------------------------ inverse problem
    def field_from_operator(
        self, Dhat: npt.ArrayLike, fields: npt.ArrayLike | None = None
    ) -> tuple[np.ndarray, float]:
        """The field whose reduced operator is closest to a k x k matrix (least squares).

        Minimizes ‖Σ_j a_j D̂_{ψ_j} − D̂‖_F over the coefficients of a field basis ψ
        (Azencot et al. 2013).

        Parameters
        ----------
        Dhat : array_like (k, k)
        fields : array_like (p, m, 3), optional
            Tangent field basis; default :func:`gradient_field_basis` with all k − 1
            non-constant eigenfunctions.

        Returns
        -------
        v : float64 (m, 3)
        residual : float
            ‖D̂_v − D̂‖_F / ‖D̂‖_F.
        """
        Dhat = np.asarray(Dhat, dtype=float)
        if Dhat.shape != (self.k, self.k):
            raise FieldShapeError(f"Dhat must be ({self.k}, {self.k}); got {Dhat.shape}")
        psi = gradient_field_basis(self) if fields is None else np.asarray(fields, float)
        A = self.reduced_D_many(psi).reshape(len(psi), -1).T  # (k², p)
        coef, *_ = np.linalg.lstsq(A, Dhat.ravel(), rcond=None)
        v = np.einsum("p,ptc->tc", coef, psi)
        res = np.linalg.norm(A @ coef - Dhat.ravel()) / max(np.linalg.norm(Dhat), 1e-300)
        return v, float(res)


def gradient_field_basis(basis: SpectralBasis, count: int | None = None) -> np.ndarray:
    """The fields grad φ_i and J grad φ_i of the first non-constant eigenfunctions.

    Parameters
    ----------
    basis : SpectralBasis
    count : int, optional
        How many eigenfunctions (default all but the first, constant one), 1 <= count < k.

    Returns
    -------
    float64 (2 count, m, 3)
        ``[grad φ_1, J grad φ_1, grad φ_2, J grad φ_2, ...]``: a basis of smooth tangent
        fields with no harmonic part (see :func:`fvf.smoothest_fields` for genus > 0).
    """
    mesh = basis.mesh
    count = basis.k - 1 if count is None else int(count)
    if not 1 <= count <= basis.k - 1:
        raise ParameterError(
            f"count must be in [1, {basis.k - 1}] (the basis has {basis.k - 1} non-constant "
            f"eigenfunctions); got {count}"
        )
    G = (grad(mesh) @ basis.eigenvectors[:, 1 : count + 1]).reshape(mesh.n_faces, 3, -1)
    G = np.moveaxis(G, 2, 0)  # (count, m, 3)
    JG = np.stack([rotate(mesh, g) for g in G])
    return np.stack([G, JG], axis=1).reshape(-1, mesh.n_faces, 3)


@takes_mesh
def laplace_basis(mesh: TriMesh, k: int, **kwargs: Any) -> tuple[np.ndarray, np.ndarray]:
    """The k smallest Laplace–Beltrami eigenpairs: (eigenvalues (k,), eigenvectors (n, k)).

    One-off form of :class:`SpectralBasis` (A_V-orthonormal eigenvectors, ascending
    eigenvalues of L = −div grad).
    """
    b = SpectralBasis(mesh, k, **kwargs)
    return b.eigenvalues, b.eigenvectors
