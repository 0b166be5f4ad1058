"""Vector-field design: the smoothest tangent field meeting direction constraints.

The field is piecewise constant, one complex coefficient z_t per face in
``mesh.face_bases`` (:mod:`fvf.connection`), and its smoothness is the connection energy
of Knöppel, Crane, Pinkall & Schröder (2013, "Globally optimal direction fields", the
n = 1 case of their smoothness energy),

.. math::

    E(z) = z^* L z = \\sum_{(s,t)} w_{st} |z_s - r_{st} z_t|^2 ,

with L from :func:`fvf.design.connection.connection_laplacian`. :func:`design_field` minimises it
subject to constraints on a few faces c with targets τ_c (complex, in the faces' frames):

* **soft**: minimise E(z) + Σ_c w_c A_F(c) |z_c − τ_c|², i.e. solve
  (L + [w A_F]_C) z = [w A_F]_C τ (one sparse Hermitian solve);
* **hard**: z_c = τ_c exactly; the constrained unknowns are eliminated and the free ones
  solve L_FF z_F = −L_FC τ_C.

Without constraints the smoothest field of unit L2 norm is returned: the lowest
eigenfield of L z = λ [A_F] z (Knöppel et al.'s "globally optimal" field).

Point constraints: a piecewise-constant field has one value per face, so a constraint at
a point applies to **the face containing the point**. Give points either as (face,
barycentric coordinates), checked by :func:`locate_points`, or as ambient positions,
assigned to the nearest face by :func:`closest_faces` (``points=`` of
:func:`design_field`). A point on an edge or a vertex belongs to several closed faces; the
face it was given in (barycentric form), or the lowest-numbered nearest face (ambient
form), receives the constraint.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..calculus import hat_gradients
from ..errors import (  # noqa: F401 (re-exported)
    ConflictingConstraintError,
    ConstraintError,
    ConstraintIndexError,
    FvfError,
    FvfWarning,
    NormalDirectionError,
    ParameterError,
    PointLocationError,
    UnconstrainedComponentWarning,
    ZeroDirectionError,
    format_indices,
)
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_direction_count, as_nonnegative
from ..mesh.nfield import NField
from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import Backend, factor_hermitian
from ..numerics.progress import ProgressCallback, make_progress
from .alignment import ALIGN_STRENGTH, alignment_targets
from .connection import ConnectionKind, check_kind, connection_laplacian, smoothest_fields
from .holonomy import smoothing_length
from .indices import fill_vanishing_faces
from .nfields import from_power, to_power

__all__ = [
    "design_field",
    "constraint_targets",
    "locate_points",
    "closest_faces",
    "SOFT_WEIGHT",
    "NORMAL_DIRECTION_RTOL",
]

#: Default soft weight: w_c A_F(c) = SOFT_WEIGHT · L_cc (the face's own stiffness).
SOFT_WEIGHT = 100.0
#: A direction whose in-plane part is below this fraction of its length is rejected.
NORMAL_DIRECTION_RTOL = 1e-3
#: A direction shorter than this times the longest one counts as zero.
_ZERO_RTOL = 1e-12
#: Duplicate constraints on a face must agree to this relative tolerance.
_CONFLICT_RTOL = 1e-9
#: Barycentric coordinates: tolerance on their sum and on negative values.
_BARY_TOL = 1e-9


# ---------------------------------------------------------------------------- inputs
def _as_faces(mesh: TriMesh, faces: npt.ArrayLike, name: str = "faces") -> np.ndarray:
    f = np.asarray(faces)
    if f.ndim == 0:
        f = f.reshape(1)
    if f.ndim != 1 or not (np.issubdtype(f.dtype, np.integer) or f.size == 0):
        raise ConstraintError(
            f"{name} must be a 1-D array of integer face indices; got shape {f.shape}, "
            f"dtype {f.dtype}."
        )
    f = f.astype(np.int64)
    m = mesh.n_faces
    bad = np.flatnonzero((f < 0) | (f >= m))
    if bad.size:
        raise ConstraintIndexError(
            f"constraints {format_indices(bad)} refer to faces outside [0, {m}) (e.g. "
            f"{name}[{int(bad[0])}] = {int(f[bad[0]])}). Fix: use 0-based face indices of "
            "this mesh."
        )
    return f


def _as_vectors(a: npt.ArrayLike, k: int, name: str) -> np.ndarray:
    v = np.asarray(a)
    if v.dtype == object or not (
        np.issubdtype(v.dtype, np.floating) or np.issubdtype(v.dtype, np.integer)
    ):
        raise ConstraintError(f"{name} must be a real array; got dtype {v.dtype}.")
    v = np.asarray(v, dtype=float)
    if v.ndim == 1 and k == 1 and v.shape == (3,):
        v = v[None]
    if v.shape != (k, 3):
        raise ConstraintError(
            f"{name} must have shape ({k}, 3), one ambient vector per constraint; got {v.shape}."
        )
    bad = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if bad.size:
        raise ConstraintError(f"{name} has NaN or inf at constraints {format_indices(bad)}.")
    return v


@takes_mesh
def constraint_targets(
    mesh: TriMesh, faces: npt.ArrayLike, directions: npt.ArrayLike, normalize: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Check constraints and turn them into complex targets in the face frames.

    Parameters
    ----------
    mesh : TriMesh
    faces : array_like of int, (k,)
        Constrained face of each constraint.
    directions : array_like, float (k, 3)
        Ambient vectors, projected onto their face planes.
    normalize : bool
        Scale each projected direction to unit length (else its length is the target
        magnitude).

    Returns
    -------
    faces : int64 (k,)
    targets : complex128 (k,)
        τ_c = ``mesh.to_complex`` of the projected (and normalised) direction.

    Raises
    ------
    ConstraintIndexError
        A face index outside [0, m).
    ZeroDirectionError
        A zero direction (length below 1e-12 of the longest).
    NormalDirectionError
        A direction whose in-plane part is below :data:`NORMAL_DIRECTION_RTOL` (1e-3) of
        its length (within 0.06° of the normal).
    ConstraintError
        Wrong shapes or non-finite values.
    """
    f = _as_faces(mesh, faces)
    d = _as_vectors(directions, f.size, "directions")
    length = np.linalg.norm(d, axis=1)
    scale = length.max(initial=0.0)
    zero = np.flatnonzero(length <= _ZERO_RTOL * scale) if scale > 0 else np.arange(f.size)
    if zero.size:
        raise ZeroDirectionError(
            f"constraints {format_indices(zero)} have a zero direction (faces "
            f"{format_indices(f[zero])}). Fix: give a non-zero vector in the face plane, or "
            "drop the constraint."
        )
    N = mesh.face_normals[f]
    tangent = d - np.einsum("ij,ij->i", d, N)[:, None] * N
    tlen = np.linalg.norm(tangent, axis=1)
    normal = np.flatnonzero(tlen < NORMAL_DIRECTION_RTOL * length)
    if normal.size:
        raise NormalDirectionError(
            f"constraints {format_indices(normal)} have directions (nearly) normal to their "
            f"faces {format_indices(f[normal])} (in-plane part "
            f"{tlen[normal[0]] / length[normal[0]]:.2g} of the length), so the projected "
            "direction is undefined. Fix: give a vector "
            "in the face plane (mesh.face_bases[face] spans it)."
        )
    B = mesh.face_bases[f]
    z = np.einsum("kj,kj->k", B[:, 0], tangent) + 1j * np.einsum("kj,kj->k", B[:, 1], tangent)
    if normalize:
        z = z / np.abs(z)
    return f, z


def _merge_duplicates(
    faces: np.ndarray, targets: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    uniq, first, inverse = np.unique(faces, return_index=True, return_inverse=True)
    if uniq.size == faces.size:
        return faces, targets, weights
    ref = targets[first][inverse]
    tol = _CONFLICT_RTOL * np.abs(targets).max()
    bad = np.flatnonzero(np.abs(targets - ref) > tol)
    if bad.size:
        raise ConflictingConstraintError(
            f"faces {format_indices(np.unique(faces[bad]))} are constrained more than once "
            f"with different targets (constraints {format_indices(bad)}). Fix: keep one "
            "constraint per face (or average the directions yourself)."
        )
    w = np.bincount(inverse, weights=weights, minlength=uniq.size)
    return uniq, targets[first], w


# ---------------------------------------------------------------------------- points
@takes_mesh
def locate_points(
    mesh: TriMesh, faces: npt.ArrayLike, barycentric: npt.ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Check points given by barycentric coordinates; return their faces and positions.

    For a piecewise-constant field, a constraint at a point applies to the face that
    contains it: here the face it is given in (a point on an edge or vertex stays in the
    face given).

    Parameters
    ----------
    mesh : TriMesh
    faces : array_like of int, (k,)
    barycentric : array_like, float (k, 3)
        Coordinates with respect to the corners ``mesh.faces[faces]``; each row must be
        non-negative and sum to 1 (to 1e-9; rows are renormalised).

    Returns
    -------
    faces : int64 (k,)
        The faces holding the constraints (pass them to :func:`design_field`).
    positions : float64 (k, 3)
        The ambient points Σ_i β_i x_i.

    Raises
    ------
    ConstraintIndexError
        A face index outside [0, m).
    PointLocationError
        Wrong shape, non-finite values, a row not summing to 1, or a negative coordinate
        (the point is outside its face), naming the rows.
    """
    f = _as_faces(mesh, faces)
    b = np.asarray(barycentric, dtype=float)
    if b.ndim == 1 and f.size == 1 and b.shape == (3,):
        b = b[None]
    if b.shape != (f.size, 3):
        raise PointLocationError(
            f"barycentric must have shape ({f.size}, 3), one row per face; got {b.shape}."
        )
    bad = np.flatnonzero(~np.isfinite(b).all(axis=1))
    if bad.size:
        raise PointLocationError(f"barycentric has NaN or inf in rows {format_indices(bad)}.")
    total = b.sum(axis=1)
    bad = np.flatnonzero(np.abs(total - 1.0) > _BARY_TOL)
    if bad.size:
        raise PointLocationError(
            f"barycentric rows {format_indices(bad)} do not sum to 1 (e.g. {total[bad[0]]:.6g}). "
            "Fix: divide each row by its sum."
        )
    bad = np.flatnonzero((b < -_BARY_TOL).any(axis=1))
    if bad.size:
        raise PointLocationError(
            f"barycentric rows {format_indices(bad)} have negative coordinates: the points "
            f"lie outside faces {format_indices(f[bad])}. Fix: give the face containing each "
            "point, or locate ambient points with fvf.design.constrained.closest_faces."
        )
    b = np.clip(b, 0.0, None)
    b /= b.sum(axis=1)[:, None]
    positions = np.einsum("ki,kij->kj", b, mesh.vertices[mesh.faces[f]])
    return f, positions


@takes_mesh
def closest_faces(
    mesh: TriMesh, points: npt.ArrayLike, chunk: int = 1 << 18
) -> tuple[np.ndarray, np.ndarray]:
    """The face nearest to each ambient point, and the barycentric coordinates of the
    nearest point on it.

    Parameters
    ----------
    mesh : TriMesh
    points : array_like, float (k, 3)
    chunk : int
        Upper bound on point-face pairs evaluated at once (about 250 bytes each).

    Returns
    -------
    faces : int64 (k,)
        For a point on the surface, the face containing it (on a shared edge or vertex the
        lowest-numbered one).
    barycentric : float64 (k, 3)
        Non-negative, summing to 1.

    Notes
    -----
    Exact (brute force over all faces, vectorised in chunks of points): O(k m) time. Per
    face, the barycentric coordinates of the projection follow from the hat gradients,
    λ_i(p) = δ_i0 + ∇φ_i · (p − x_0) (measured from corner 0, not from the centroid,
    so that far from the origin only exact coordinate differences enter); when one is
    negative the nearest point lies on an edge, and the nearest of the three edge points
    is taken.
    """
    p = np.asarray(points, dtype=float)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None]
    if p.ndim != 2 or p.shape[1] != 3:
        raise PointLocationError(f"points must have shape (k, 3); got {p.shape}.")
    bad = np.flatnonzero(~np.isfinite(p).all(axis=1))
    if bad.size:
        raise PointLocationError(f"points has NaN or inf in rows {format_indices(bad)}.")
    m = mesh.n_faces
    X = mesh.vertices[mesh.faces]  # (m, 3 corners, 3)
    G = hat_gradients(mesh)  # (m, 3, 3)
    X0 = X[:, 0]
    N = mesh.face_normals
    corner0 = np.array([1.0, 0.0, 0.0])
    out_f = np.empty(p.shape[0], dtype=np.int64)
    out_b = np.empty((p.shape[0], 3))
    step = max(1, chunk // m)
    for lo in range(0, p.shape[0], step):  # chunks of points, each vectorised over faces
        q = p[lo : lo + step]  # (c, 3)
        rel = q[:, None, :] - X0[None]  # (c, m, 3)
        lam = corner0 + np.einsum("tij,ctj->cti", G, rel)  # (c, m, 3)
        inside = (lam >= 0).all(axis=2)
        d2 = np.einsum("ctj,tj->ct", rel, N) ** 2
        bary = lam.copy()
        # nearest point on each edge (a, b) = corners (i+1, i+2), parameter s in [0, 1]
        best = np.full(d2.shape, np.inf)
        for i in range(3):
            a, b = (i + 1) % 3, (i + 2) % 3
            e = X[:, b] - X[:, a]  # (m, 3)
            qa = q[:, None, :] - X[None, :, a]  # (c, m, 3)
            s = np.clip(np.einsum("ctj,tj->ct", qa, e) / np.einsum("tj,tj->t", e, e), 0, 1)
            r = qa - s[..., None] * e[None]
            de = np.einsum("ctj,ctj->ct", r, r)
            take = ~inside & (de < best)
            best = np.where(take, de, best)
            edge_bary = np.zeros(lam.shape)
            edge_bary[..., a] = 1.0 - s
            edge_bary[..., b] = s
            bary = np.where(take[..., None], edge_bary, bary)
        dist = np.where(inside, d2, best)
        k = np.argmin(dist, axis=1)
        rows = np.arange(q.shape[0])
        out_f[lo : lo + step] = k
        out_b[lo : lo + step] = bary[rows, k]
    out_b = np.clip(out_b, 0.0, None)
    out_b /= out_b.sum(axis=1)[:, None]
    return out_f, out_b


# ---------------------------------------------------------------------------- design
def _soft_weights(
    mesh: TriMesh, L: sp.csr_array, f: np.ndarray, weights: npt.ArrayLike | float | None
) -> np.ndarray:
    """w_c per constraint: the user's, checked, or SOFT_WEIGHT · L_cc / A_F(c)."""
    A = mesh.face_areas
    if weights is None:
        return SOFT_WEIGHT * L.diagonal().real[f] / A[f]
    w = np.asarray(weights, dtype=float)
    if w.ndim > 1 or w.size not in (1, f.size):
        raise ConstraintError(
            f"weights must be a scalar or have shape ({f.size},), one per constraint; got "
            f"shape {w.shape}."
        )
    w = np.broadcast_to(w.reshape(-1), f.shape).copy()
    bad = np.flatnonzero(~(np.isfinite(w) & (w > 0)))
    if bad.size:
        raise ConstraintError(
            f"weights must be finite and > 0; constraints {format_indices(bad)} are not."
        )
    return w


def _active_faces(L: sp.csr_array, seeds: np.ndarray) -> np.ndarray:
    """Faces in a component of L's coupling graph holding a seed; warns about the others."""
    pattern = sp.csr_array((np.ones(L.nnz), L.indices, L.indptr), shape=L.shape)
    _, label = connected_components(pattern, directed=False)
    has = np.zeros(label.max() + 1, dtype=bool)
    has[label[seeds]] = True
    active = has[label]
    if not active.all():
        free = np.flatnonzero(~active)
        warnings.warn(
            f"faces {format_indices(free)} lie in components of the mesh without "
            "constraints; the field is zero there. Fix: add a constraint per component.",
            UnconstrainedComponentWarning,
            stacklevel=3,
        )
    return active


def _power(z: np.ndarray, n: int) -> np.ndarray:
    """|z| (z/|z|)^n for non-zero z."""
    return z if n == 1 else np.abs(z) * (z / np.abs(z)) ** n


def _nearest_root(w: np.ndarray, target: np.ndarray, n: int) -> np.ndarray:
    """The n-th root of w (|w|, angle/n + 2πk/n) closest in angle to ``target``."""
    root = np.abs(w) * np.exp(1j * np.angle(w) / n)
    k = np.rint(n * np.angle(target * np.conj(root)) / (2 * np.pi))
    return root * np.exp(2j * np.pi * k / n)


def _solve_design(
    L: sp.csr_array,
    pen: np.ndarray,
    rhs: np.ndarray,
    active: np.ndarray,
    fixed: np.ndarray,
    tau_fixed: np.ndarray,
    backend: Backend,
) -> np.ndarray:
    """Minimise z*Lz + Σ pen |z − t|² (rhs = pen·t) with z fixed on ``fixed``, zero off
    ``active``: one Hermitian positive definite solve."""
    m = L.shape[0]
    z = np.zeros(m, dtype=complex)
    z[fixed] = tau_fixed
    free = np.zeros(m, dtype=bool)
    free[active] = True
    free[fixed] = False
    rest = np.flatnonzero(free)
    if rest.size:
        # (L z)[rest] with z zero off ``fixed`` is L[rest, fixed] τ_fixed: one product
        # instead of a copy of L's rows that would stay alive through the factorization
        b = (rhs[rest] - (L @ z)[rest]).astype(complex)
        S = sp.csr_array(L)[rest][:, rest] + sp.diags_array(pen[rest])
        z[rest] = factor_hermitian(S, backend, solves="few").solve(b)
    return z


@takes_mesh
def design_field(
    mesh: TriMesh,
    faces: npt.ArrayLike | None = None,
    directions: npt.ArrayLike | None = None,
    *,
    points: npt.ArrayLike | None = None,
    weights: npt.ArrayLike | float | None = None,
    hard: bool = False,
    kind: ConnectionKind = "knoppel",
    normalize: bool = True,
    n: int = 1,
    align: str | npt.ArrayLike | None = None,
    align_weights: npt.ArrayLike | float | None = None,
    align_strength: float = ALIGN_STRENGTH,
    backend: Backend = "auto",
    progress: bool | ProgressCallback | None = None,
    curvature_smoothing: float | None = None,
    align_smoothing: float | None = None,
    log_scale: npt.ArrayLike | None = None,
) -> NField:
    """The smoothest tangent N-field meeting direction constraints (Knöppel et al. 2013).

    Minimises the connection energy E(z) = z^* L_N z (:func:`fvf.connection_laplacian`
    with ``n``; the smoothness energy of Knöppel, Crane, Pinkall & Schröder, "Globally
    optimal direction fields", 2013) of a piecewise-constant field in its power
    representation z (:mod:`fvf.design.nfields`; z = the field itself for n = 1), subject
    to constraints on faces and an optional alignment term:

    * soft (default): minimise E(z) + Σ_c w_c A_F(c) |z_c − τ_c|²;
    * hard (``hard=True``): z_c = τ_c exactly, E minimised over the other faces;
    * alignment (``align=``): + β Σ_t ω_t A_t |z_t − τ_t|² over all faces
      (:mod:`fvf.design.alignment`: principal curvature directions weighted by the
      curvature anisotropy, or a user field with per-face weights).

    For n ≥ 2 the targets are the N-th powers of the given directions, so a constrained
    face keeps its direction up to a rotation by 2π/N.

    Parameters
    ----------
    mesh : TriMesh
    faces : array_like of int, (k,), optional
        Constrained faces (duplicates allowed when their targets agree as N-direction
        sets; their soft weights add up).
    directions : array_like, float (k, 3), optional
        Ambient direction of each constraint, projected onto its face plane; the target
        τ_c is the projection in complex frame coordinates (unit length when
        ``normalize``, else its length is the target magnitude), raised to the N-th power.
    points : array_like, float (k, 3), optional
        Ambient positions instead of ``faces``: each constraint applies to the face
        nearest to (containing) its point (:func:`closest_faces`).
    weights : float or array_like (k,), optional
        Soft weights w_c > 0 (units 1/area). Default w_c = SOFT_WEIGHT · L_cc / A_F(c)
        (SOFT_WEIGHT = 100): the penalty on a constrained face is 100 times the face's own
        diagonal stiffness, so soft constraints are met to about 1%, independently of the
        mesh size. Not allowed with ``hard=True``.
    hard : bool
        Impose the targets exactly (eliminate those unknowns).
    kind : {"knoppel", "singer_wu"}
        The connection Laplacian (:mod:`fvf.connection`).
    normalize : bool
        Normalise the projected directions to unit length.
    n : int
        Symmetry order N ≥ 1: 1 vector (default), 2 line, 4 cross, 6 field.
    align : "curvature" or array_like float (m, 3), optional
        Alignment targets (:func:`fvf.design.alignment.alignment_targets`);
        ``"curvature"`` needs an even n.
    align_weights : float or array_like (m,), optional
        ω_t ≥ 0 per face (1/length²); see :mod:`fvf.design.alignment` for the defaults.
    align_strength : float
        β ≥ 0 (default 1).
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        Sparse factorization (:mod:`fvf.numerics.cholesky`).
    progress : None, bool or callable
        ``True`` for a tqdm bar, or a callback ``(stage, done, total)``.
    curvature_smoothing : float, optional
        A length ℓ > 0 (mesh units): use the connection whose holonomy is the angle defect
        smoothed over ℓ (:mod:`fvf.design.holonomy`), so that vertices with a large angle
        defect (spikes, pinches, valence-4 vertices of remeshed scans) do not each force
        a cone. Closed meshes, ``kind="knoppel"``. Default: the Levi-Civita connection.
    log_scale : array_like, float (n,), optional
        With ``curvature_smoothing``: a conformal scale s per vertex, the connection is
        then that of the metric e^{2s} g (:func:`fvf.connection_laplacian`): the field
        a parameterization with quads of edge h e^{-s} follows.
    align_smoothing : float, optional
        A length ℓ > 0 (mesh units): the alignment target is diffused over ℓ before the
        design, by one implicit heat step of the field's own connection Laplacian,
        (M + ℓ² L_N) ζ̃ = M ζ with ζ_t = β ω_t τ_t complex (m,) and M the face areas; the
        term then reads Σ_t |ζ̃_t| A_t |z_t − ζ̃_t/|ζ̃_t||². Directions that only hold on a
        scale below ℓ (the principal directions of a noisy scan) average out, and their
        weight with them. Default: no smoothing.

    Returns
    -------
    NField, float64 (m, 3)
        The field as ambient per-face vectors (tangent), an :class:`fvf.NField` that
        carries ``n`` (an ndarray; consumers such as :func:`fvf.singularities` read ``n``
        from it); for n ≥ 2 one representative per
        face (:func:`fvf.design.nfields.from_power`), of length |z_t|, chosen on each
        constrained face as the direction of the set nearest to the given one (so a hard
        constraint is returned exactly). With no constraints and no alignment: the
        smoothest field of unit L2 norm, Σ A_F |u|² = 1, the lowest eigenfield of
        L_N z = λ [A_F] z (:func:`fvf.design.connection.smoothest_fields`); on a mesh
        of several parts (faces joined across sides), that of each part, scaled so that
        its share of Σ A_F |u|² is its share of the area (a lone face: its first side's
        direction); on meshes
        of up to ``DEGENERATE_PROBE_FACES`` faces whose lowest eigenvalue is repeated,
        the member of its eigenspace whose shortest face vector is longest (of the
        eigenbasis and seeded combinations), not whichever basis the solver returns.
        Where the minimiser vanishes (a cone at the centre of a face of a symmetric shape, or
        round-off where an N-field localises), the face gets the direction of a
        neighbour at length ``FILL_RTOL`` (1e-6) times the largest
        (:func:`fvf.design.indices.fill_vanishing_faces`): the cone sits on a vertex
        and :func:`fvf.singularities` reports it.

    Raises
    ------
    ConstraintIndexError, ZeroDirectionError, NormalDirectionError,
    ConflictingConstraintError
        Bad constraints, naming the offending constraint rows and faces
        (:func:`constraint_targets`); for n ≥ 2 two constraints on a face conflict when
        they are different N-direction sets.
    ConstraintError
        Wrong shapes, non-positive weights, ``faces`` together with ``points``,
        ``weights`` with ``hard=True``, bad ``align`` or ``align_weights``.
    DirectionCountError
        n not an integer ≥ 1, or ``align="curvature"`` with an odd n.

    Warns
    -----
    UnconstrainedComponentWarning
        A connected component (of the faces coupled by L) carries no constraint and no
        positive alignment weight; the field is zero on it (the minimiser of least norm).

    Notes
    -----
    Soft: (L_N + [w A_F]_C + β[ω A_F]) z = [w A_F]_C τ + β[ω A_F] τ_align. Hard:
    z_C = τ_C and the same system on the free faces, moving L_FC τ_C to the right side.
    Both systems are Hermitian positive definite on every component with a constraint,
    solved by one sparse Cholesky factorization (:mod:`fvf.numerics.cholesky`; SuperLU
    without the ``[fast]`` extra). The soft solution is linear in the targets; with a
    single constraint on a flat mesh both give the constant field.

    Examples
    --------
    >>> import numpy as np
    >>> import fvf
    >>> from fvf.design.constrained import design_field
    >>> mesh = fvf.disk(4, 6)
    >>> u = design_field(mesh, [0], [[2.0, 0.0, 0.0]], hard=True)
    >>> bool(np.allclose(u, [1.0, 0.0, 0.0]))
    True
    """
    kind = check_kind(kind)
    n = as_direction_count(n)
    report = make_progress(progress)
    f, tau = _given_constraints(mesh, faces, directions, points, weights, hard, normalize)
    if align_smoothing is not None and align is None:
        raise ParameterError(
            "align_smoothing diffuses an alignment target: pass align= too, or drop it"
        )

    def smoothest() -> NField:  # nothing to meet: the smoothest N-field of each part
        def of(part: TriMesh, scale: np.ndarray | None) -> np.ndarray:
            small = part.n_faces <= DEGENERATE_PROBE_FACES
            energies, fields = smoothest_fields(
                part,
                min(DEGENERATE_PROBE, part.n_faces) if small else 1,
                kind,
                n=n,
                backend=backend,
                progress=progress,
                curvature_smoothing=curvature_smoothing,
                log_scale=scale,
            )
            return _most_uniform(part, energies, fields, n)

        u = _per_component(mesh, log_scale, of)
        return NField(_with_directions(mesh, u), n)

    if f.size == 0 and align is None:
        return smoothest()
    report("assemble", 0, 1)  # its parts reported as they start: minutes on 2M faces
    report("assemble: connection Laplacian", 0, 1)
    L = connection_laplacian(
        mesh, kind, n, curvature_smoothing=curvature_smoothing, log_scale=log_scale
    )
    A = mesh.face_areas
    if align is not None:
        report("assemble: alignment targets", 0, 1)
    pen, rhs = _alignment_terms(mesh, n, align, align_weights, align_strength)
    if align_smoothing is not None:
        report("assemble: smoothing the alignment", 0, 1)
        pen, rhs = _smoothed_alignment(mesh, L, pen, rhs, align_smoothing, backend)
    seeds = np.concatenate([f, np.flatnonzero(pen > 0)])
    if f.size:
        w = _soft_weights(mesh, L, f, None if hard else weights)
        _, first = np.unique(f, return_index=True)
        given = tau if first.size == f.size else tau[first]  # _merge_duplicates' order
        f, tau_n, w = _merge_duplicates(f, _power(tau, n), w)
        tau = given
    else:
        tau_n, w = tau, np.zeros(0)
    report("assemble", 1, 1)
    if seeds.size == 0:
        warnings.warn(
            "the alignment weights are zero on every face (e.g. a flat or umbilic surface "
            "with align='curvature'); returning the smoothest field. Fix: add constraints "
            "or give align_weights.",
            UnconstrainedComponentWarning,
            stacklevel=2,
        )
        return smoothest()
    active = _active_faces(L, seeds)
    if hard:
        fixed, tau_fixed = f, tau_n
    else:
        fixed, tau_fixed = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=complex)
        pen[f] += w * A[f]
        rhs[f] += w * A[f] * tau_n
    report("solve", 0, 1)
    z = _solve_design(L, pen, rhs, active, fixed, tau_fixed, backend)
    report("solve", 1, 1)
    return NField(_with_directions(mesh, _field_from_power(mesh, z, n, f, tau, hard)), n)


def _alignment_terms(
    mesh: TriMesh,
    n: int,
    align: str | npt.ArrayLike | None,
    align_weights: npt.ArrayLike | float | None,
    align_strength: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The alignment term of :func:`design_field`: (penalty β ω_t A_t float64 (m,),
    right side β ω_t A_t τ_t complex (m,)); zeros without ``align``."""
    pen = np.zeros(mesh.n_faces)
    rhs = np.zeros(mesh.n_faces, dtype=complex)
    if align is not None:
        beta = as_nonnegative(align_strength, "align_strength", ConstraintError)
        t_align, omega = alignment_targets(mesh, align, n, align_weights)
        pen += beta * omega * mesh.face_areas
        rhs += pen * t_align
    return pen, rhs


def _smoothed_alignment(
    mesh: TriMesh,
    L: sp.csr_array,
    pen: np.ndarray,
    rhs: np.ndarray,
    length: float,
    backend: Backend,
) -> tuple[np.ndarray, np.ndarray]:
    """The alignment term of :func:`design_field` diffused over ``length``
    (``align_smoothing``): ζ̃ = (M + ℓ² L)⁻¹ M ζ, ζ = rhs / A; returns (|ζ̃| A, ζ̃ A)."""
    ell = smoothing_length(length, "align_smoothing")
    A = mesh.face_areas
    M = sp.diags_array(A.astype(complex))
    zeta = factor_hermitian(sp.csr_array(M + ell**2 * L), backend, "few").solve(M @ (rhs / A))
    return np.abs(zeta) * A, zeta * A


def _given_constraints(
    mesh: TriMesh,
    faces: npt.ArrayLike | None,
    directions: npt.ArrayLike | None,
    points: npt.ArrayLike | None,
    weights: npt.ArrayLike | float | None,
    hard: bool,
    normalize: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`design_field`'s constraint arguments checked together: (faces int64 (k,),
    targets complex (k,) in the face frames, not yet raised to the N-th power)."""
    if points is not None:
        if faces is not None:
            raise ConstraintError("give either faces or points, not both.")
        faces, _ = closest_faces(mesh, points)
    if (faces is None) != (directions is None):
        raise ConstraintError("faces (or points) and directions must be given together.")
    if faces is None and weights is not None:
        raise ConstraintError("weights were given without constraints.")
    if hard and weights is not None:
        raise ConstraintError("weights apply to soft constraints only (hard=False).")
    if faces is None or directions is None:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=complex)
    return constraint_targets(mesh, faces, directions, normalize)


#: On meshes of up to this many faces (dense eigenpairs) :func:`design_field` computes
#: :data:`DEGENERATE_PROBE` smoothest fields, so that within a degenerate lowest
#: eigenspace (a symmetric mesh: the regular tetrahedron's vector fields span three
#: complex dimensions) it can choose a member instead of taking the solver's.
DEGENERATE_PROBE_FACES = 600
DEGENERATE_PROBE = 3
#: Eigenvalues within this relative distance of the lowest belong to its eigenspace.
DEGENERATE_RTOL = 1e-8
#: Seeded combinations of a degenerate eigenbasis tried by :func:`_most_uniform`.
UNIFORM_TRIALS = 32


def _per_component(
    mesh: TriMesh,
    log_scale: npt.ArrayLike | None,
    smoothest: Callable[[TriMesh, np.ndarray | None], np.ndarray],
) -> np.ndarray:
    """The smoothest field of each part of the mesh (:attr:`TriMesh.vertex_components`), float64
    (m, 3): ``smoothest(part, its log_scale)`` on each part of two faces or more, scaled to
    Σ A_t |u_t|² = its share of the area (the whole has unit L2 norm and the same mean
    length on every part: the lowest eigenfield of the whole lives on one part and is zero
    on the others); a part of one face (no side shared: its energy is zero for every
    field) gets its first side's direction."""
    label = mesh.vertex_components[mesh.faces[:, 0]]  # a valid mesh's parts meet at no vertex
    parts = np.bincount(label)
    if parts.size == 1:
        return smoothest(mesh, None if log_scale is None else np.asarray(log_scale, float))
    A = mesh.face_areas
    share = np.sqrt(np.bincount(label, A) / A.sum())
    P = mesh.vertices[mesh.faces]
    side = P[:, 1] - P[:, 0]
    u = side / np.linalg.norm(side, axis=1, keepdims=True) * (share[label] / np.sqrt(A))[:, None]
    for part in np.flatnonzero(parts > 1):  # a loop over the parts of several faces
        faces = np.flatnonzero(label == part)
        used, F = np.unique(mesh.faces[faces], return_inverse=True)
        sub = TriMesh(mesh.vertices[used], F.reshape(-1, 3))
        scale = None if log_scale is None else np.asarray(log_scale, float)[used]
        u[faces] = smoothest(sub, scale) * share[part]
    return u


def _most_uniform(mesh: TriMesh, energies: np.ndarray, fields: np.ndarray, n: int) -> np.ndarray:
    """The lowest eigenfield, or within a degenerate lowest eigenspace the member whose
    shortest face vector is longest (relative to its longest) among the eigenbasis and
    :data:`UNIFORM_TRIALS` seeded combinations of it: a basis the solver returns can
    vanish on a face by chance (float64 (m, 3), one representative per face)."""
    lam = np.asarray(energies, dtype=float)
    same = np.abs(lam - lam[0]) <= DEGENERATE_RTOL * max(float(np.abs(lam).max()), 1.0)
    if same.sum() < 2:
        return fields[0]
    Z = np.stack([to_power(mesh, fields[k], n) for k in np.flatnonzero(same)])  # (d, m)
    rng = np.random.default_rng(0)
    coef = rng.standard_normal((UNIFORM_TRIALS, len(Z))) + 1j * rng.standard_normal(
        (UNIFORM_TRIALS, len(Z))
    )
    trials = np.concatenate([Z, coef @ Z])  # every row a member of the eigenspace
    size = np.abs(trials)
    score = size.min(axis=1) / np.maximum(size.max(axis=1), 1e-300)
    best = trials[int(np.argmax(score))]
    scale = np.sqrt(mesh.face_areas @ np.abs(best) ** 2)
    return from_power(mesh, best / scale, n)  # unit L2 norm, as the eigenfields


def _with_directions(mesh: TriMesh, u: np.ndarray) -> np.ndarray:
    """u (m, 3) with a direction on every face where it vanishes (a cone at a face's
    centre on a symmetric shape), so every function of fvf accepts the design."""
    return fill_vanishing_faces(mesh, u)


def _field_from_power(
    mesh: TriMesh, z: np.ndarray, n: int, f: np.ndarray, tau: np.ndarray, hard: bool
) -> NField:
    """Ambient (m, 3) field of the power representation z (complex (m,)): for n ≥ 2 the
    N-th root, taken on each constrained face f as the root nearest to its target tau
    (exactly the target for hard constraints)."""
    if n == 1:
        return NField(mesh.from_complex(z), 1)
    root = np.abs(z) * np.exp(1j * np.angle(z) / n)
    if f.size:
        root[f] = tau if hard else _nearest_root(z[f], tau, n)
    return NField(mesh.from_complex(root), n)
