"""Fields that commute with a given field: rescaling (§4.4.1) and ACAP fields (§4.4.2).

Both minimize the mixed Lie bracket through ad_v (eqs. 62–63, :func:`fvf.ad`), whose
output is a vertex field measured in the A_V inner product:
‖ad_v w‖² = (ad_v w)ᵀ [A_V ⊗ I_3] (ad_v w).
"""

from __future__ import annotations

import warnings
from typing import Literal, overload

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..calculus import field_product, stiffness, vertex_to_face
from ..errors import ParameterError
from ..mesh.convert import MeshLike, takes_mesh
from ..mesh.inputs import TangentPolicy, as_face_field
from ..mesh.trimesh import TriMesh
from ..numerics.eigen import SpectralFallbackWarning, SpectralSolveError, smallest_eigenpairs
from ..operators.brackets import ad
from .connection import ConnectionKind, real_connection_laplacian, tangent_basis_matrix

__all__ = ["rescaling_operator", "rescale", "acap_energy_matrix", "acap_fields"]

AcapSolver = Literal["auto", "direct", "multilevel"]
ACAP_SOLVERS = ("auto", "direct", "multilevel")
#: ``solver="auto"`` uses the multilevel eigensolver from this many faces on.
ACAP_MULTILEVEL_MIN_FACES = 120_000
#: ``solver="auto"`` falls back to the direct solver up to this many faces only (its
#: factor took 10.5 GB at 375k faces and grows ~4.5x per 4x faces).
ACAP_DIRECT_MAX_FACES = 400_000


def _vertex_mass3(mesh: TriMesh) -> sp.csr_array:
    return sp.csr_array(sp.diags_array(np.repeat(mesh.vertex_areas, 3)))


def _weight(x: object, name: str) -> float:
    """A finite weight >= 0, else :class:`~fvf.errors.ParameterError`."""
    try:
        value = float(x)  # type: ignore[arg-type]  # any failure is reported below
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a finite number >= 0; got {x!r}") from exc
    if not (np.isfinite(value) and value >= 0):
        raise ParameterError(f"{name} must be a finite number >= 0; got {value!r}")
    return value


@takes_mesh
def rescaling_operator(mesh: TriMesh, v: npt.ArrayLike, u: npt.ArrayLike) -> sp.csr_array:
    """F(v, u) = ad_v [u]• I_F^V: sparse (3n, n), f ↦ [v, f u] as a vertex field (eq. 65)."""
    v = as_face_field(mesh, v, "v")
    u = as_face_field(mesh, u, "u")
    return (ad(mesh, v, tangent="ignore") @ (field_product(mesh, u) @ vertex_to_face(mesh))).tocsr()


@overload
def rescale(
    mesh: MeshLike,
    /,
    v: npt.ArrayLike,
    u: npt.ArrayLike,
    alpha: float,
    *,
    return_energy: Literal[False] = ...,
) -> np.ndarray: ...
@overload
def rescale(
    mesh: MeshLike,
    /,
    v: npt.ArrayLike,
    u: npt.ArrayLike,
    alpha: float,
    *,
    return_energy: Literal[True],
) -> tuple[np.ndarray, float]: ...
@takes_mesh
def rescale(
    mesh: TriMesh,
    v: npt.ArrayLike,
    u: npt.ArrayLike,
    alpha: float,
    *,
    return_energy: bool = False,
) -> np.ndarray | tuple[np.ndarray, float]:
    """Commutation-guided rescaling: the f minimizing ½‖[v, f u]‖² + (α/2)‖∇f‖², ∫f² = 1.

    Solves the generalized eigenproblem (eqs. 65–66) for the smallest eigenpair of

        E f = λ [A_V] f,   E = F(v,u)ᵀ [A_V ⊗ I_3] F(v,u) + α W,

    with F from :func:`rescaling_operator` and W = :func:`fvf.stiffness` (the weak form of
    α L, so that fᵀ W f = ‖∇f‖²). The constraint ∫f² = fᵀ[A_V]f = 1 is eq. (66)'s.

    Parameters
    ----------
    mesh : TriMesh
    v, u : array_like (m, 3)
    alpha : float
        Smoothness weight α >= 0 (units of area⁻¹ × ‖v‖²·‖u‖²; choose relative to the
        bracket term, e.g. as a fraction of ``λ_max(FᵀAF) / λ_max(W)``).
    return_energy : bool
        Also return the minimal energy ½λ.

    Returns
    -------
    f : float64 (n,)
        A_V-normalized, sign chosen so that ∫f > 0.
    """
    alpha = _weight(alpha, "alpha")
    F = rescaling_operator(mesh, v, u)
    E = (F.T @ _vertex_mass3(mesh) @ F + alpha * stiffness(mesh)).tocsr()
    E = 0.5 * (E + E.T)
    lam, f = smallest_eigenpairs(E, mesh.vertex_areas, 1)
    f = f[:, 0] * (1.0 if mesh.vertex_areas @ f[:, 0] >= 0 else -1.0)
    return (f, 0.5 * float(lam[0])) if return_energy else f


@takes_mesh
def acap_energy_matrix(
    mesh: TriMesh, v: npt.ArrayLike, lam: float, kind: ConnectionKind = "knoppel"
) -> sp.csr_array:
    """E_B = Bᵀ (ad_vᵀ [A_V ⊗ I_3] ad_v) B + λ L_conn: sparse symmetric (2m, 2m) (§4.4.2).

    B (3m, 2m) is the per-face orthonormal tangent basis (:func:`fvf.tangent_basis_matrix`)
    and L_conn the real form of the face connection Laplacian in the same basis
    (:func:`fvf.real_connection_laplacian`); both terms are weak (integrated) forms,
    paired with the mass [A_F] repeated twice.
    """
    v = as_face_field(mesh, v, "v")
    A = ad(mesh, v, tangent="ignore")
    B = tangent_basis_matrix(mesh)
    AB = (A @ B).tocsr()  # (3n, 2m)
    lam = _weight(lam, "lam")
    E = AB.T @ _vertex_mass3(mesh) @ AB + lam * real_connection_laplacian(mesh, kind)
    E = sp.csr_array(E)
    return (0.5 * (E + E.T)).tocsr()


@takes_mesh
def acap_fields(
    mesh: TriMesh,
    v: npt.ArrayLike,
    lam: float,
    k: int,
    *,
    kind: ConnectionKind = "knoppel",
    tangent: TangentPolicy = "project",
    solver: AcapSolver = "auto",
    tol: float = 1e-8,
    seed: int = 0,
) -> np.ndarray:
    """As-commuting-as-possible fields: the k smallest eigenvectors of E_B (§4.4.2).

    Minimizes ‖ad_v w‖² + λ E_conn(w) over tangent fields w with ∫|w|² = 1; v itself
    (and every multiple of it) is in the kernel of ad_v, and the connection energy picks
    the smooth ones (Fig. 11).

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
    lam : float
        Weight λ of the connection energy (:func:`acap_energy_matrix`).
    k : int
        Number of fields.
    kind : {"knoppel", "singer_wu"}
        Connection Laplacian (:func:`fvf.real_connection_laplacian`).
    tangent : {"project", "ignore", "warn", "raise"}
        What to do with normal components of v (:func:`fvf.as_face_field`).
    solver : {"auto", "direct", "multilevel"}
        Eigensolver of E_B x = μ [A_F] x. ``"direct"``: :func:`fvf.smallest_eigenpairs`
        (shift-invert on a sparse factorization; memory grows ~4.5x per 4x faces).
        ``"multilevel"``: :func:`fvf.numerics.multilevel.face_field_eigenpairs` (LOBPCG
        preconditioned by smoothed-aggregation multigrid; memory linear in m).
        ``"auto"``: multilevel from :data:`ACAP_MULTILEVEL_MIN_FACES` faces on, else
        direct; if the multilevel solve fails, a
        :class:`~fvf.numerics.eigen.SpectralFallbackWarning` is emitted and the direct path runs
        (up to :data:`ACAP_DIRECT_MAX_FACES` faces; beyond, SpectralSolveError).
    tol : float
        Bound on every eigenpair's relative residual (:func:`fvf.numerics.eigen.eigen_residuals`),
        for both solvers.
    seed : int
        Seed of the solvers' random start vectors / power iterations.

    Returns
    -------
    float64 (k, m, 3)
        Tangent, unit L2 norm (eq. 26), ordered by increasing energy.

    Raises
    ------
    ParameterError
        Unknown ``solver``, bad ``lam``.
    SpectralInputError
        Bad k or tol.
    SpectralSolveError
        The chosen solver failed (``"auto"``: both failed).

    Notes
    -----
    Cost (one thread, refined spot mesh, v = J grad y, λ = 10⁻², k = 4,
    ``benchmarks/bench_apps.py --acap-only`` on a shared 2-core machine): E_B has about 52
    entries per face and assembles in 1.0 s / 3.1 s / 25 s at 94k / 375k / 1.5M faces.
    The direct eigensolve (:func:`fvf.smallest_eigenpairs`, a sparse factorization of
    E_B − σ[A_F] under a nested-dissection ordering, :mod:`fvf.ordering`) takes 0.8 s at
    5.9k, 21 s at 94k (peak memory 2.4 GB) and 190–500 s at 375k faces (10.5 GB); the
    factor grows about 4.5x per 4x faces, so 1.5M faces would need about 40 GB.

    The multilevel solver (:mod:`fvf.multilevel`: smoothed-aggregation multigrid with a
    face-pair block smoother, preconditioning block LOBPCG) stops when every pair meets
    ``tol`` and also has ‖E_B x − μ[A_F]x‖ ≤ 10⁻³ μ_k (:data:`fvf.numerics.multilevel.RTOL`); the
    ``tol`` measure alone is too weak for an iterative solver on fine meshes. Against the
    direct solver the eigenvalues agree to ≤ 1.5e-9 / 1.1e-9 / 4.1e-10 / 2.5e-10
    (relative) and the 4-dimensional eigenspaces to a sine of the largest principal angle
    ≤ 1.8e-5 / 1.1e-5 / 4.9e-6 / 5.3e-6 at 5.9k / 23k / 94k / 375k faces, in 32 / 33 / 42 /
    49 LOBPCG iterations. Eigensolve time and peak memory: 25 s and 0.7 GB at 94k faces,
    92 s and 2.1 GB at 375k; 549 s (45 s setup, 58 iterations) and 7.8 GB at 1,499,136
    faces, under 10 min with the assembly (there the eigenvalues agree to 1e-10 with a
    second run at rtol = 10⁻⁴). Iterations grow with 1/λ (stronger anisotropy of
    ‖ad_v w‖²): on small test meshes λ = 10⁻³ needed 100–300 iterations, which is why the
    direct solver stays the default below :data:`ACAP_MULTILEVEL_MIN_FACES`.
    """
    if solver not in ACAP_SOLVERS:
        raise ParameterError(f"solver must be one of {ACAP_SOLVERS}; got {solver!r}")
    if isinstance(k, float | np.floating) and float(k).is_integer():
        k = int(k)  # k = 2.0 worked before the solver choice; keep it working
    v = as_face_field(mesh, v, "v", tangent)
    E = acap_energy_matrix(mesh, v, lam, kind)
    mass = np.repeat(mesh.face_areas, 2)
    use_ml = solver == "multilevel" or (
        solver == "auto" and mesh.n_faces >= ACAP_MULTILEVEL_MIN_FACES
    )
    X = None
    if use_ml:
        from ..numerics.multilevel import face_field_eigenpairs

        try:
            _, X = face_field_eigenpairs(mesh, E, k, tol=tol, seed=seed)
        except (SpectralSolveError, np.linalg.LinAlgError) as exc:  # LinAlgError: coarse
            if solver == "multilevel":
                raise
            if mesh.n_faces > ACAP_DIRECT_MAX_FACES:
                raise SpectralSolveError(
                    f"acap_fields: the multilevel eigensolver failed ({exc}), and the direct "
                    f"solver would need tens of GB at {mesh.n_faces} faces. Fix: a larger "
                    "lam (the iteration slows down as lam/|v|^2 gets small), a coarser mesh, "
                    "or solver='direct' on a machine with the memory."
                ) from exc
            warnings.warn(
                f"acap_fields: the multilevel eigensolver failed ({exc}); using the direct "
                "solver instead",
                SpectralFallbackWarning,
                stacklevel=2,
            )
    if X is None:
        _, X = smallest_eigenpairs(E, mass, k, tol=tol, seed=seed)
    B = tangent_basis_matrix(mesh)
    return (B @ X).T.reshape(X.shape[1], mesh.n_faces, 3)
