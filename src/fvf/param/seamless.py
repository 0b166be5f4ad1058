r"""Seamless global parameterization aligned with a cross field (QuadCover / MIQ style).

Pipeline (``docs/quads.md`` has the derivation):

1. a cross field u (:func:`fvf.design_field`, curvature-aligned by default) with its
   close singularity pairs cancelled or moved apart (:func:`fvf.cancel_close_singularities`,
   :func:`fvf.separate_close_singularities`), and its
   frame (X, Y) = (1/h)(a u, b J u) per face, h the target edge length and a, b positive
   per-face scales (:mod:`fvf.param.frame_field`);
2. combing and a cut graph through the singularities (:func:`fvf.comb`,
   :func:`fvf.cut_graph`; :mod:`fvf.param.cutmesh`);
3. transition functions across the cut, uv_s = R^q uv_t + c (:mod:`fvf.param.seams`);
4. the Poisson fit

    $$\min_{u, v} \sum_t A_t \big( |\nabla u - X|^2 + |\nabla v - Y|^2 \big)$$

    over the PL coordinates of the cut mesh, subject to the transitions, solved as sparse
    normal equations (:mod:`fvf.numerics.cholesky`);
5. integer rounding of the chain translations and of the singular-vertex positions
   (:mod:`fvf.param.rounding`), so that every transition is a rotation by k·90° plus an
   integer translation and every cone sits on an integer point;
6. local stiffening where uv triangles are flipped (:mod:`fvf.param.uv_folds`).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from dataclasses import field as dataclass_field

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..calculus import hat_gradients, vertex_to_face
from ..design.cancellation import keep_singularities_off_curves, tidy_close_singularities
from ..design.holonomy import as_log_scale
from ..errors import (
    FlippedParameterizationWarning,
    ParameterError,
    ParameterizationInputError,
    format_indices,
    user_stacklevel,
)
from ..mesh.convert import takes_mesh
from ..mesh.nfield import require_order
from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import Backend
from ..numerics.progress import ProgressCallback, make_progress
from ..numerics.summary import html_repr, short_repr
from .cutmesh import CutMesh, cut_mesh
from .features import feature_constraints
from .frame_field import (
    SCALINGS,
    Alignment,
    Scaling,
    commuting_scale,
    default_connection_rotations,
    default_cross_field,
    fitted_scale,
    unit_cross_field,
)
from .rounding import MixedIntegerSolver, integer_lattice
from .seams import ROTATIONS, SeamSystem, feature_rows, seam_system
from .sizing import curvature_log_scale
from .strips import strip_scale, strip_widths
from .uv_folds import flip_count as _flip_count
from .uv_folds import repair_folds

__all__ = ["SeamlessParameterization", "seamless_parameterization", "uv_flips", "edge_length_for"]

#: The largest integer system eliminated (bytes of its dense lattice basis): beyond it (a
#: thread's sharp edges as iso-lines, thousands of cones) the attempt is refused before
#: the memory runs out.
LATTICE_BYTES = 2**28


@dataclass(frozen=True)
class SeamlessParameterization:
    """Result of :func:`seamless_parameterization`.

    Attributes
    ----------
    uv : float64 (m, 3, 2)
        Coordinates of each face corner (``uv[t, i]`` at vertex ``faces[t, i]``), in units
        of the target edge length.
    field : float64 (m, 3)
        The combed cross-field representative per face (the direction of ∂/∂u).
    cut : bool (E,)
        Edges of the cut graph.
    rotation : int64 (E,)
        q_e per edge: across edge e, uv on side ``sides[e, 0]`` = R^{q_e} uv on side
        ``sides[e, 1]`` + ``translation[e]`` (0 and 0 off the cut).
    translation : float64 (E, 2)
        c_e per edge, integers after rounding.
    sides : int64 (E, 2)
        Faces (s, t) of each edge in the orientation of ``rotation``.
    singular : int64 (S,)
        Singular vertices (cones); ``index4[singular]`` are 4 × their indices.
    index4 : int64 (n,)
    edge_length : float
        h: one unit of uv is this long on the surface (before the frame scale).
    flipped : int64 (k,)
        Faces whose uv triangle is flipped or degenerate (signed area ≤ 0).
    residual_real : float
        Relative fit residual ‖∇uv − (X, Y)‖ / ‖(X, Y)‖ before rounding (the part of the
        frame that is not a gradient: its curl).
    residual : float
        The same after rounding.
    info : dict
        ``n_integers`` (int: integer unknowns rounded), ``n_chains`` (int: cut chains),
        ``scale`` (float64 (m, 2): the frame scales (a, b) per face), ``log_scale``
        (float64 (n,): the conformal scale of ``sizing``, or None), ``seconds`` (dict:
        wall time per stage, keyed by the stage's progress message).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    uv: np.ndarray
    field: np.ndarray
    cut: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    sides: np.ndarray
    singular: np.ndarray
    index4: np.ndarray
    edge_length: float
    flipped: np.ndarray
    residual_real: float
    residual: float
    info: dict = dataclass_field(default_factory=dict)

    @property
    def n_flipped(self) -> int:
        """Number of flipped or degenerate uv triangles."""
        return int(self.flipped.size)


def uv_flips(uv: np.ndarray) -> np.ndarray:
    """Faces whose uv triangle has signed area ≤ 0, int64 (k,). uv: float64 (m, 3, 2)."""
    a = uv[:, 1] - uv[:, 0]
    b = uv[:, 2] - uv[:, 0]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return np.flatnonzero(~(det > 0))


def edge_length_for(mesh: TriMesh, target_faces: int | None, edge_length: float | None) -> float:
    """h from a target number of quads (h = √(area / target)) or an explicit edge length."""
    if target_faces is not None and edge_length is not None:
        raise ParameterError("give target_faces or edge_length, not both")
    if edge_length is not None:
        h = float(edge_length)
        if not (np.isfinite(h) and h > 0):
            raise ParameterError(f"edge_length must be a finite number > 0; got {edge_length!r}")
        return h
    if target_faces is None:
        target_faces = max(mesh.n_faces // 10, 1)
    try:
        q = int(target_faces)
    except (TypeError, ValueError) as exc:
        raise ParameterError(
            f"target_faces must be a positive integer; got {target_faces!r}"
        ) from exc
    if q < 1 or q != target_faces:
        raise ParameterError(f"target_faces must be a positive integer; got {target_faces!r}")
    return float(np.sqrt(mesh.total_area / q))


def _check_mesh(mesh: TriMesh) -> None:
    if not isinstance(mesh, TriMesh):
        raise ParameterError(f"mesh must be a fvf.TriMesh; got {type(mesh).__name__}")
    if mesh.n_components != 1:
        comp = mesh.vertex_components
        firsts = np.unique(comp, return_index=True)[1]
        raise ParameterizationInputError(
            f"the mesh has {mesh.n_components} components (first vertices "
            f"{format_indices(firsts)}); parameterize each component separately "
            "(split by mesh.vertex_components)"
        )
    if not mesh.is_closed:
        raise ParameterizationInputError(
            f"the mesh has {mesh.n_boundary_loops} boundary loop(s) (boundary vertices "
            f"{format_indices(mesh.boundary_vertices)}); seamless parameterization and quad "
            "meshing need a closed surface: fill the holes first (e.g. with a fan per loop)"
        )


def _energy_matrix(mesh: TriMesh, cm: CutMesh) -> sp.csr_array:
    """A (4m, 2W): wedge coordinates ↦ √A_t (∇u, ∇v) on face t (local coordinates)."""
    m = mesh.n_faces
    B = mesh.face_bases
    G = np.einsum("mij,mkj->mik", hat_gradients(mesh), B)  # (m, 3 corners, 2 comps)
    w = np.sqrt(mesh.face_areas)
    rows, cols, vals = [], [], []
    for coord in (0, 1):  # u, v
        for comp in (0, 1):  # local x, y of the gradient
            r = 4 * np.arange(m) + 2 * coord + comp
            rows.append(np.repeat(r, 3))
            cols.append((2 * cm.wedges + coord).ravel())
            vals.append((G[:, :, comp] * w[:, None]).ravel())
    A = sp.csr_array(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(4 * m, 2 * cm.n_wedges),
    )
    return A


def _local_frame(cm: CutMesh, h: float, scale: np.ndarray | None) -> np.ndarray:
    """(X, Y) per face in local coordinates, float64 (m, 2, 2): rows X and Y = J X."""
    c, s = np.cos(cm.angles), np.sin(cm.angles)
    X = np.stack([c, s], axis=1)
    Y = np.stack([-s, c], axis=1)
    frame = np.stack([X, Y], axis=1) / h
    if scale is not None:
        frame = frame * scale[:, :, None]
    return frame


def _frame_axes(mesh: TriMesh, cm: CutMesh) -> np.ndarray:
    """The unit frame axes X, J X per face (:func:`_local_frame` at h = 1) as ambient
    vectors, float64 (m, 2, 3)."""
    local = _local_frame(cm, 1.0, None)
    return np.stack([mesh.from_local(local[:, 0]), mesh.from_local(local[:, 1])], axis=1)


def _check_lattice_size(rows: int, cols: int, cones: int, chains: int, iso: int) -> None:
    """Refuse an integer system whose lattice basis (:func:`integer_lattice`: N, up to
    (cols, cols) float64, and its product with the integer kernel of the rows left, about
    as large again) exceeds :data:`LATTICE_BYTES`:
    :class:`fvf.ParameterizationInputError` (in :func:`fvf.quad_mesh`, the end of one
    attempt, not of the call)."""
    need = 2.0 * 8.0 * cols * cols
    if need > LATTICE_BYTES:
        raise ParameterizationInputError(
            f"the integer conditions across the cut form a {rows} x {cols} system "
            f"({need / 2**30:.3g} GiB for its lattice basis, more than "
            f"{LATTICE_BYTES / 2**30:.3g}) "
            f"from {cones} cones, {chains} seam chains and {iso} feature iso-line "
            "conditions: too many sharp edges to make iso-lines (a thread, a knurl) or too "
            "many cones (slivers much finer than the quads); hold the field along the "
            "features only (feature_isolines=False), remesh at the quad scale "
            "(remesh=True), or ask for fewer quads"
        )


def _variables(
    ss: SeamSystem, cm: CutMesh, iso: tuple[sp.csr_array, np.ndarray] | None = None
) -> tuple[sp.csr_array, np.ndarray, np.ndarray, np.ndarray]:
    """Split y into real and integer unknowns; return Q (y = Q [real; w]) and bookkeeping.

    ``iso``: the feature iso-line conditions and integer root coordinates of
    :func:`fvf.param.seams.feature_rows`, added to the closing conditions.
    """
    R, C = ss.n_roots, ss.n_chains
    ncol = 2 * R + 2 * C
    sing_roots = np.unique(ss.root_of_vertex[cm.singular])
    rows, iso_cols = iso if iso is not None else (sp.csr_array((0, ncol)), np.empty(0, np.int64))
    int_cols = np.concatenate(
        [
            np.stack([2 * sing_roots, 2 * sing_roots + 1], axis=1).ravel(),
            2 * R + np.arange(2 * C),
            iso_cols,
        ]
    ).astype(np.int64)
    int_cols = np.unique(int_cols)
    pinned = (
        np.array([2 * sing_roots[0], 2 * sing_roots[0] + 1])
        if sing_roots.size
        else np.array([0, 1])
    )
    int_cols = np.setdiff1d(int_cols, pinned)
    real_cols = np.setdiff1d(np.setdiff1d(np.arange(ncol), int_cols), pinned)
    closing = sp.vstack([ss.closing, rows]).tocsr()
    _check_lattice_size(closing.shape[0], int_cols.size, cm.singular.size, C, rows.shape[0])
    N = integer_lattice(closing[:, int_cols], prefer=int_cols >= 2 * R)
    nr = real_cols.size
    Q = sp.bmat(
        [
            [
                sp.csr_array((np.ones(nr), (real_cols, np.arange(nr))), shape=(ncol, nr)),
                sp.csr_array(
                    (np.ones(int_cols.size), (int_cols, np.arange(int_cols.size))),
                    shape=(ncol, int_cols.size),
                )
                @ sp.csr_array(N),
            ],
        ]
    ).tocsr()
    integer = nr + np.arange(N.shape[1])
    return Q, integer, int_cols, N


def _transitions(mesh: TriMesh, uv: np.ndarray, ss: SeamSystem) -> np.ndarray:
    """c_e = uv_s(a) − R^q uv_t(a) at the first end point a of each edge, float64 (E, 2)."""
    E = mesh.edges
    s, t = ss.edge_sides[:, 0], ss.edge_sides[:, 1]
    ok = (s >= 0) & (t >= 0)
    out = np.zeros((mesh.n_edges, 2))
    a = E[ok, 0]
    js = np.argmax(mesh.faces[s[ok]] == a[:, None], axis=1)
    jt = np.argmax(mesh.faces[t[ok]] == a[:, None], axis=1)
    us, ut = uv[s[ok], js], uv[t[ok], jt]
    out[ok] = us - np.einsum("eij,ej->ei", ROTATIONS[ss.edge_q[ok]], ut)
    return out


@dataclass
class _FitSystem:
    """The Poisson fit over the seamless unknowns (see :func:`_fit_system`)."""

    ss: SeamSystem
    K: sp.csr_array  # (4m, p): y ↦ √A_t (∇s, ∇t) per face (rows s_x, s_y, t_x, t_y)
    integer: np.ndarray  # int64 (k,): the integer unknowns of y
    lift: sp.csr_array  # (2W, p): y ↦ wedge coordinates


def _fit_system(mesh: TriMesh, cm: CutMesh, features: np.ndarray | None = None) -> _FitSystem:
    """Transitions, the lattice of integer unknowns and the fit matrix K = A P Q; feature
    edges (indices into ``mesh.edges``) become integer iso-lines."""
    ss = seam_system(mesh, cm)
    A = _energy_matrix(mesh, cm)
    iso = None if features is None else feature_rows(mesh, cm, ss, features)
    Q, integer, _, _ = _variables(ss, cm, iso)
    lift = (ss.P @ Q).tocsr()
    return _FitSystem(ss, (A @ lift).tocsr(), integer, lift)


def _rhs(mesh: TriMesh, frame: np.ndarray) -> np.ndarray:
    """b (4m,): √A_t (X_t, Y_t) in local coordinates, for a frame (m, 2, 2)."""
    return (frame * np.sqrt(mesh.face_areas)[:, None, None]).reshape(-1)


def _frame_scale(
    mesh: TriMesh,
    cm: CutMesh,
    fs: _FitSystem,
    solver: MixedIntegerSolver,
    h: float,
    scaling: str,
    iterations: int,
    log_scale: np.ndarray | None = None,
) -> np.ndarray:
    """Per-face (a, b) of the frame, float64 (m, 2), for ``scaling`` (module frames),
    times e^{s} on each face for a conformal ``log_scale`` s (n,) (:mod:`.sizing`)."""
    size = np.ones(mesh.n_faces)
    if log_scale is not None:
        size = np.exp(vertex_to_face(mesh) @ log_scale)
    if scaling == "commuting":
        return commuting_scale(mesh, cm) * size[:, None]
    sc = np.repeat(size[:, None], 2, axis=1)
    if scaling == "fitted":
        for _ in range(iterations):
            y = solver.real(fs.K.T @ _rhs(mesh, _local_frame(cm, h, sc)))
            grads = (fs.K @ y).reshape(-1, 2, 2) / np.sqrt(mesh.face_areas)[:, None, None]
            sc = fitted_scale(mesh, cm, grads / size[:, None, None], h) * size[:, None]
    return sc


@takes_mesh
def seamless_parameterization(
    mesh: TriMesh,
    *,
    field: npt.ArrayLike | None = None,
    target_faces: int | None = None,
    edge_length: float | None = None,
    align: Alignment = "curvature",
    scale: npt.ArrayLike | None = None,
    scaling: Scaling = "fitted",
    rounding_batch: float = 0.05,
    scale_iterations: int = 3,
    stiffening_iterations: int = 8,
    cone_cancel_radius: float = 1.0,
    backend: Backend = "auto",
    progress: bool | ProgressCallback | None = None,
    features: npt.ArrayLike | None = None,
    feature_isolines: bool = True,
    thin_strips: bool = False,
    sizing: str | npt.ArrayLike | None = None,
) -> SeamlessParameterization:
    """A global parameterization whose iso-lines follow a cross field, seamless across cuts.

    Parameters
    ----------
    mesh : TriMesh
        Closed, one component (else :class:`fvf.ParameterizationInputError`).
    field : array_like (m, 3), optional
        Cross field as one representative tangent vector per face (any of the four
        directions). Default: :func:`fvf.param.frame_field.default_cross_field` with ``align``
        (curvature-aligned at the scale h, its cones measured against the connection of
        :func:`fvf.param.frame_field.default_connection_rotations`).
    target_faces : int, optional
        Approximate number of quads: h = √(area / target_faces). Default m / 10.
    edge_length : float, optional
        h directly (exclusive with ``target_faces``).
    align : {"curvature", "smooth"}
        Default field when ``field`` is None.
    scale : array_like (m, 2), optional
        Positive per-face scalings (a, b) of the frame (a u, b J u); overrides
        ``scaling``.
    scaling : {"fitted", "commuting", "none"}
        How the frame is scaled when ``scale`` is None (:mod:`fvf.param.frame_field`): the
        fitted gradient lengths (``scale_iterations`` rounds, default), the chapter's
        commuting rescaling (:func:`fvf.rescale_frame`), or unit lengths.
    rounding_batch : float
        Fraction of the remaining integers fixed per greedy step (1 = direct rounding).
    scale_iterations : int
        Rounds of fitting and rescaling for ``scaling="fitted"``.
    stiffening_iterations : int
        While uv triangles are flipped after rounding: rounds of local repair
        (:mod:`fvf.param.uv_folds`).
    cone_cancel_radius : float
        Opposite cone pairs closer than this many edge lengths h are cancelled
        (:func:`fvf.cancel_close_singularities`), then equal ones moved apart
        (:func:`fvf.separate_close_singularities`), then opposite ones cancelled again,
        then cones of index beyond ±1/2 split
        (:func:`fvf.design.cancellation.split_large_singularities`), all on one factored
        matrix (:func:`fvf.design.cancellation.tidy_close_singularities`); 0 keeps the
        field's topology (and a cone beyond ±1/2 is refused).
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        Sparse Cholesky backend (:mod:`fvf.numerics.cholesky`).
    progress : None, bool or callable
        ``True`` for a tqdm bar per stage, or a callback ``(stage, done, total)``
        (:mod:`fvf.numerics.progress`): each stage is reported as ``(message, 0, 1)``
        when it starts and ``(message, 1, 1)`` when it ends; the message names the stage
        and its size (the command prints them).
    features : array_like of int (k,), optional
        Sharp feature edges (indices into ``mesh.edges``; :mod:`fvf.param.features`): the
        default field is held along them (when ``field`` is None), and each one within 20°
        of a frame axis becomes an integer iso-line (:func:`fvf.param.seams.feature_rows`),
        so that it is followed by quad edges.
    feature_isolines : bool
        False: the features only hold the default field (two parallel features closer
        than about half an edge length h would otherwise share an iso-line and fold).
    thin_strips : bool
        With features as iso-lines: stretch the frame across strips between parallel
        features narrower than 3/4 h (a thin wall's rim), so that each is one quad
        across instead of collapsing (:mod:`fvf.param.strips`). :func:`fvf.quad_mesh`
        tries it on each surface after the plain iso-line attempt, with
        ``cone_cancel_radius=0``.
    sizing : None, "curvature" or array_like float (n,)
        Quads of varying size: a conformal log scale s per vertex, quads of edge
        h e^{-s} (:mod:`fvf.param.sizing`); ``"curvature"`` for
        :func:`fvf.param.sizing.curvature_log_scale` (quad edges at most a radius of
        curvature). The default field is then designed for the scaled metric (its cones
        follow the changes of size) and the frame is scaled by e^{s}. Needs
        ``align="curvature"`` or a ``field``. Default None: one size h.

    Returns
    -------
    SeamlessParameterization
        ``uv`` (m, 3, 2) with integer transitions across the cut and cones on integer
        points; ``flipped`` lists faces with non-positive uv area (a
        :class:`fvf.FlippedParameterizationWarning` is issued when it is not empty).
    """
    _check_mesh(mesh)
    clock = _Stages(progress)
    h = edge_length_for(mesh, target_faces, edge_length)
    if scaling not in SCALINGS:
        raise ParameterError(f"scaling must be one of {SCALINGS}; got {scaling!r}")
    sc = None if scale is None else _user_scale(mesh, scale)
    require_order(field, 4, "seamless_parameterization")
    size = _log_scale(mesh, sizing, h, align if field is None else None)
    clock("cross field" if field is None else "reading the cross field")
    held = None if features is None or field is not None else feature_constraints(mesh, features)
    u, rot = _cross_field(mesh, field, align, h, held, size, clock.substages("cross field"))
    if cone_cancel_radius > 0:
        clock("cancelling and separating close cones")
        r = cone_cancel_radius * h
        u = tidy_close_singularities(
            mesh, u, 4, radius=r, max_step=2, backend=backend, connection_rotations=rot
        )
    iso = features is not None and feature_isolines
    if iso and held is not None:  # the default field, held along the features
        clock("moving cones off the feature iso-lines")
        edges = np.asarray(features, np.int64)
        u = _cones_off_features(mesh, u, edges, held[0], h, rot, backend)
    clock("combing and cut graph")
    cm = cut_mesh(mesh, u, rot)
    _check_cones(mesh, cm)
    clock(f"transitions across the cut ({int(cm.cut.sum())} edges, {cm.singular.size} cones)")
    fs = _fit_system(mesh, cm, np.asarray(features, np.int64) if iso else None)
    clock(f"Poisson fit ({fs.K.shape[1]} unknowns, {fs.integer.size} integers)")
    solver = MixedIntegerSolver((fs.K.T @ fs.K).tocsr(), fs.integer, backend)
    if sc is None:
        clock(f"frame scaling ({scaling})")
        sc = _frame_scale(mesh, cm, fs, solver, h, scaling, scale_iterations, size)
        if iso and thin_strips:
            widths = strip_widths(mesh, np.asarray(features, np.int64), _frame_axes(mesh, cm), h)
            sc = strip_scale(widths, h, sc)
    frame = _local_frame(cm, h, sc)
    b = _rhs(mesh, frame)
    g = fs.K.T @ b
    y_real = solver.real(g)
    clock("integer rounding")
    y = solver.rounded(g, batch=rounding_batch)
    flips = _flip_count(fs.K @ y)
    if flips and stiffening_iterations > 0:
        clock(f"repairing {flips} flipped triangles")
        y, _ = repair_folds(
            mesh,
            fs.K,
            solver,
            y,
            b,
            rounds=stiffening_iterations,
            batch=rounding_batch,
            backend=backend,
            progress=clock.detail,
            release_solver=True,
        )
    uv = (fs.lift @ y).reshape(-1, 2)[cm.wedges]
    bnorm = float(np.linalg.norm(b))
    res_real = float(np.linalg.norm(fs.K @ y_real - b)) / bnorm
    res = float(np.linalg.norm(fs.K @ y - b)) / bnorm
    flipped = uv_flips(uv)
    _warn_flipped(flipped)
    trans = _transitions(mesh, uv, fs.ss)
    trans[~cm.cut] = 0.0
    clock(None)
    info = {
        "n_integers": int(fs.integer.size),
        "n_chains": fs.ss.n_chains,
        "scale": sc,
        "log_scale": size,
        "seconds": clock.seconds,
    }
    return SeamlessParameterization(
        uv=uv,
        field=cm.field,
        cut=cm.cut,
        rotation=np.where(cm.cut, fs.ss.edge_q, 0),
        translation=trans,
        sides=fs.ss.edge_sides,
        singular=cm.singular,
        index4=cm.index4,
        edge_length=h,
        flipped=flipped,
        residual_real=res_real,
        residual=res,
        info=info,
    )


def _cones_off_features(
    mesh: TriMesh,
    u: np.ndarray,
    features: np.ndarray,
    held: np.ndarray,
    h: float,
    rot: np.ndarray | None,
    backend: Backend,
) -> np.ndarray:
    """The field with its cones closer than h to a feature iso-line (not on one) moved h
    away from it, the faces ``held`` along the features (int64 (k,)) kept
    (:func:`fvf.design.cancellation.keep_singularities_off_curves`)."""
    return keep_singularities_off_curves(
        mesh,
        u,
        4,
        curve_vertices=np.unique(mesh.edges[features]),
        radius=h,
        held=held,
        backend=backend,
        connection_rotations=rot,
    )


def _warn_flipped(flipped: np.ndarray) -> None:
    if flipped.size:
        warnings.warn(
            f"{flipped.size} uv triangles are flipped or degenerate (faces "
            f"{format_indices(flipped)}); try another target (more quads resolve features "
            "narrower than a quad edge, fewer let close cones cancel) or a smoother field",
            FlippedParameterizationWarning,
            stacklevel=user_stacklevel(),
        )


def _cross_field(
    mesh: TriMesh,
    field: npt.ArrayLike | None,
    align: Alignment,
    h: float,
    held: tuple[np.ndarray, np.ndarray] | None,
    log_scale: np.ndarray | None,
    progress: ProgressCallback | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """The unit cross field (m, 3) the fit follows and the connection's rotations (E,) its
    cones are measured against (None: Levi-Civita): the user's field, or the default one
    held to ``held`` (the faces and directions of :func:`feature_constraints`), designed
    for the metric scaled by ``log_scale``."""
    if field is not None:
        return unit_cross_field(mesh, field), None
    u = default_cross_field(
        mesh, align, edge_length=h, constraints=held, progress=progress, log_scale=log_scale
    )
    return u, default_connection_rotations(mesh, align, h, log_scale)


def _log_scale(
    mesh: TriMesh, sizing: object, h: float, align: Alignment | None
) -> np.ndarray | None:
    """The conformal log scale (n,) of ``sizing`` (None: uniform), checked."""
    if sizing is None:
        return None
    if align == "smooth":
        raise ParameterError(
            "sizing designs the field for a scaled metric, which the curvature-aligned "
            "field does: use align='curvature' (the default) or pass a field"
        )
    if isinstance(sizing, str):
        if sizing != "curvature":
            raise ParameterError(f"sizing must be None, 'curvature' or an array; got {sizing!r}")
        return curvature_log_scale(mesh, h)
    return as_log_scale(mesh, sizing)


class _Stages:
    """The stages reported to the user's ``progress`` (``(message, 0, 1)`` at the start,
    ``(message, 1, 1)`` at the end), and the wall time of each stage."""

    def __init__(self, progress: bool | ProgressCallback | None) -> None:
        self.report = make_progress(progress)
        self.seconds: dict[str, float] = {}
        self._stage: str | None = None
        self._message: str | None = None
        self._t0 = time.perf_counter()

    def __call__(self, message: str | None) -> None:
        """End the running stage; start ``message`` (None: only end)."""
        now = time.perf_counter()
        if self._stage is not None and self._message is not None:
            self.seconds[self._stage] = self.seconds.get(self._stage, 0.0) + now - self._t0
            self.report(self._message, 1, 1)
        self._t0 = now
        self._message = message
        self._stage = None if message is None else message.split(" (")[0]
        if message is not None:
            self.report(message, 0, 1)

    def detail(self, message: str) -> None:
        """A message within the running stage (a round of fold repair)."""
        self.report(message, 1, 1)

    def substages(self, prefix: str) -> ProgressCallback:
        """A ``progress`` for a function the running stage calls: each of its stages, as
        it starts, becomes the detail ``"prefix: stage"`` (so a long stage is not silent)."""

        def progress(stage: str, done: int, total: int) -> None:
            if done == 0:
                self.detail(f"{prefix}: {stage}")

        return progress


def _user_scale(mesh: TriMesh, scale: npt.ArrayLike) -> np.ndarray:
    """A user's per-face scales (a, b), checked: finite, positive, float64 (m, 2)."""
    sc = np.asarray(scale, dtype=np.float64)
    if sc.shape != (mesh.n_faces, 2) or not np.all(np.isfinite(sc)) or np.any(sc <= 0):
        raise ParameterError(
            f"scale must be a finite positive float array of shape ({mesh.n_faces}, 2)"
        )
    return sc


def _check_cones(mesh: TriMesh, cm: CutMesh) -> None:
    """Cones of index other than ±1/4 cannot be resolved by this pipeline's quads."""
    bad = cm.singular[np.abs(cm.index4[cm.singular]) > 2]
    if bad.size:
        err = ParameterizationInputError(
            f"the cross field has singularities of index beyond ±1/2 at vertices "
            f"{format_indices(bad)} (4 × index {format_indices(cm.index4[bad])}); smooth the "
            "field (align='smooth') or design one with cones of index ±1/4"
        )
        err.where = mesh.vertices[bad]
        raise err
