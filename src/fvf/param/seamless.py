r"""Seamless global parameterization aligned with a cross field (QuadCover / MIQ style).

Pipeline (``docs/quads.md`` has the derivation):

1. a cross field u (curvature-aligned by default, :mod:`fvf.param.frames`) and its frame
   (X, Y) = (s/h)(u, J u) per face, h the target edge length and s an optional positive
   per-face scale (e.g. a commuting rescaling);
2. combing and a cut graph through the singularities (:mod:`fvf.param.cutgraph`);
3. transition functions across the cut, uv_s = R^q uv_t + c (:mod:`fvf.param.seams`);
4. the Poisson fit

   $$\min_{u, v} \sum_t A_t \big( |\nabla u - X|^2 + |\nabla v - Y|^2 \big)$$

   over the PL coordinates of the cut mesh, subject to the transitions, solved as sparse
   normal equations (:func:`fvf.numerics.eigen.factor_spd`);
5. integer rounding of the chain translations and of the singular-vertex positions
   (:mod:`fvf.param.rounding`), so that every transition is a rotation by k·90° plus an
   integer translation and every cone sits on an integer point.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from dataclasses import field as dataclass_field

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..calculus import hat_gradients
from ..errors import (
    FlippedParameterizationWarning,
    ParameterError,
    ParameterizationInputError,
    format_indices,
)
from ..mesh.convert import takes_mesh
from ..mesh.trimesh import TriMesh
from .cones import cancel_close_cones
from .cutgraph import CutMesh, comb_and_cut
from .frames import Alignment, cross_field_angles, default_cross_field
from .rounding import MixedIntegerSolver, integer_lattice
from .seams import ROTATIONS, SeamSystem, seam_system

__all__ = ["SeamlessParameterization", "seamless_parameterization", "uv_flips", "edge_length_for"]


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
    """

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


def _energy_matrix(
    mesh: TriMesh, cm: CutMesh, frame: np.ndarray
) -> tuple[sp.csr_array, np.ndarray]:
    """A (4m, 2W) and b (4m,): √A_t (∇u, ∇v) on face t against √A_t (X_t, Y_t) (local)."""
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
    b = (frame * w[:, None, None]).reshape(-1)
    return A, b


def _energy_matrix_rhs(mesh: TriMesh, frame: np.ndarray) -> np.ndarray:
    """b (4m,) of :func:`_energy_matrix` for a frame (m, 2, 2)."""
    return (frame * np.sqrt(mesh.face_areas)[:, None, None]).reshape(-1)


def _fitted_scale(
    mesh: TriMesh, cm: CutMesh, fit: np.ndarray, h: float, sc: np.ndarray, smooth: int = 3
) -> np.ndarray:
    """New per-face scales (a, b): fitted gradient lengths along X̂, Ŷ, smoothed, normalized.

    ``fit`` (4m,) is √A_t (∇u, ∇v) of the current real solution. The logs of a and b are
    averaged ``smooth`` times over faces sharing an uncut edge (where the frames' labels
    agree); the result is scaled so that Σ_t A_t a_t b_t = Σ_t A_t (same quad count).
    """
    A = mesh.face_areas
    G = fit.reshape(-1, 2, 2) / np.sqrt(A)[:, None, None]
    c, s = np.cos(cm.angles), np.sin(cm.angles)
    a = (G[:, 0, 0] * c + G[:, 0, 1] * s) * h
    b = (-G[:, 1, 0] * s + G[:, 1, 1] * c) * h
    la = np.log(np.clip(a, 0.25, 4.0))
    lb = np.log(np.clip(b, 0.25, 4.0))
    ef = mesh.edge_faces
    ok = (~cm.cut) & (ef >= 0).all(axis=1)
    m = mesh.n_faces
    W = sp.coo_array((np.ones(ok.sum()), (ef[ok, 0], ef[ok, 1])), shape=(m, m))
    W = (W + W.T + sp.eye_array(m)).tocsr()
    W = sp.diags_array(1.0 / W.sum(axis=1)) @ W
    for _ in range(smooth):
        la, lb = W @ la, W @ lb
    new = np.exp(np.stack([la, lb], axis=1))
    new /= np.sqrt(np.sum(A * new[:, 0] * new[:, 1]) / A.sum())
    return new


def _distortion(mesh: TriMesh, fit: np.ndarray, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-face distortion |σ₁ − 1| + |σ₂ − 1| of J F⁻¹ and flip flags (J = (∇u, ∇v)).

    ``fit`` (4m,) is √A_t (∇u, ∇v); ``frame`` (m, 2, 2) the target rows (X, Y).
    """
    J = fit.reshape(-1, 2, 2) / np.sqrt(mesh.face_areas)[:, None, None]
    M = J @ np.linalg.inv(frame)
    sv = np.linalg.svd(M, compute_uv=False)
    det = np.linalg.det(J)
    return np.abs(sv - 1.0).sum(axis=1), ~(det > 0)


def _flip_count(fit: np.ndarray) -> int:
    """Number of faces whose fitted Jacobian (∇u, ∇v) has det ≤ 0 (fit: (4m,))."""
    J = fit.reshape(-1, 4)
    return int(np.count_nonzero(~(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2] > 0)))


def _stiffen(mesh: TriMesh, w: np.ndarray, distortion: np.ndarray, flips: np.ndarray) -> np.ndarray:
    """Bommes et al.'s update w ← w + min(distortion, 5), ×4 on flipped faces and their
    edge neighbours."""
    w = w + np.minimum(distortion, 5.0)
    hot = flips.copy()
    adj = mesh.face_adjacency[flips]
    hot[adj[adj >= 0]] = True
    w[hot] *= 4.0
    return w


def _local_frame(cm: CutMesh, h: float, scale: np.ndarray | None) -> np.ndarray:
    """(X, Y) per face in local coordinates, float64 (m, 2, 2): rows X and Y = J X."""
    c, s = np.cos(cm.angles), np.sin(cm.angles)
    X = np.stack([c, s], axis=1)
    Y = np.stack([-s, c], axis=1)
    frame = np.stack([X, Y], axis=1) / h
    if scale is not None:
        frame = frame * scale[:, :, None]
    return frame


def _variables(
    ss: SeamSystem, cm: CutMesh
) -> tuple[sp.csr_array, np.ndarray, np.ndarray, np.ndarray]:
    """Split y into real and integer unknowns; return Q (y = Q [real; w]) and bookkeeping."""
    R, C = ss.n_roots, ss.n_chains
    ncol = 2 * R + 2 * C
    sing_roots = np.unique(ss.root_of_vertex[cm.singular])
    int_cols = np.concatenate(
        [np.stack([2 * sing_roots, 2 * sing_roots + 1], axis=1).ravel(), 2 * R + np.arange(2 * C)]
    ).astype(np.int64)
    pinned = (
        np.array([2 * sing_roots[0], 2 * sing_roots[0] + 1])
        if sing_roots.size
        else np.array([0, 1])
    )
    int_cols = np.setdiff1d(int_cols, pinned)
    real_cols = np.setdiff1d(np.setdiff1d(np.arange(ncol), int_cols), pinned)
    Cz = ss.closing[:, int_cols].toarray() if ss.closing.shape[0] else np.zeros((0, int_cols.size))
    N = integer_lattice(Cz, prefer=int_cols >= 2 * R)
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


@takes_mesh
def seamless_parameterization(
    mesh: TriMesh,
    *,
    field: npt.ArrayLike | None = None,
    target_faces: int | None = None,
    edge_length: float | None = None,
    align: Alignment = "curvature",
    scale: npt.ArrayLike | None = None,
    rounding_batch: float = 0.05,
    scale_iterations: int = 3,
    stiffening_iterations: int = 8,
    cone_cancel_radius: float = 1.0,
    progress: Callable[[str], None] | None = None,
) -> SeamlessParameterization:
    """A global parameterization whose iso-lines follow a cross field, seamless across cuts.

    Parameters
    ----------
    mesh : TriMesh
        Closed, one component (else :class:`fvf.ParameterizationInputError`).
    field : array_like (m, 3), optional
        Cross field as one representative tangent vector per face (any of the four
        directions). Default: :func:`fvf.param.frames.default_cross_field` with ``align``.
    target_faces : int, optional
        Approximate number of quads: h = √(area / target_faces). Default m / 10.
    edge_length : float, optional
        h directly (exclusive with ``target_faces``).
    align : {"curvature", "smooth"}
        Default field when ``field`` is None.
    scale : array_like (m, 2), optional
        Positive per-face scalings (a, b) of the frame (a u, b J u) (e.g. a commuting
        rescaling); default: adapted to the field by ``scale_iterations`` rounds of
        fitting and rescaling (below).
    rounding_batch : float
        Fraction of the remaining integers fixed per greedy step (1 = direct rounding).
    scale_iterations : int
        When ``scale`` is None: rounds of "fit, then rescale the frame by the fitted
        gradient lengths" (a, b per face, smoothed over uncut neighbours), which lowers
        the curl of the frame before rounding; 0 keeps the unit frame.
    cone_cancel_radius : float
        Opposite cone pairs closer than this many edge lengths h are cancelled
        (:mod:`fvf.param.cones`); 0 keeps the field's topology.
    progress : callable, optional
        Called with a short message as each stage starts (the command prints them).
    stiffening_iterations : int
        While uv triangles are flipped after rounding: rounds of local stiffening (Bommes
        et al. 2009, §6): the weight of each face grows with its distortion (flipped faces
        and their neighbours most) and the rounded solve is repeated.

    Returns
    -------
    SeamlessParameterization
        ``uv`` (m, 3, 2) with integer transitions across the cut and cones on integer
        points; ``flipped`` lists faces with non-positive uv area (a
        :class:`fvf.FlippedParameterizationWarning` is issued when it is not empty).
    """
    _check_mesh(mesh)
    say = progress or (lambda message: None)
    h = edge_length_for(mesh, target_faces, edge_length)
    say("cross field" if field is None else "reading the cross field")
    u = default_cross_field(mesh, align, length_scale=h) if field is None else field
    phi = cross_field_angles(mesh, u)
    sc = None
    if scale is not None:
        sc = np.asarray(scale, dtype=np.float64)
        if sc.shape != (mesh.n_faces, 2) or not np.all(np.isfinite(sc)) or np.any(sc <= 0):
            raise ParameterError(
                f"scale must be a finite positive float array of shape ({mesh.n_faces}, 2)"
            )
    say("combing, cones and cut graph")
    cm = comb_and_cut(mesh, phi)
    if cone_cancel_radius > 0:
        for _ in range(3):  # a cancelled pair can expose the next one
            edited = cancel_close_cones(mesh, phi, cm, cone_cancel_radius * h, h)
            if edited is None:
                break
            phi, raw = edited
            cm = comb_and_cut(mesh, phi, raw=raw)
    _check_cones(mesh, cm)
    say(f"transitions across the cut ({int(cm.cut.sum())} edges, {cm.singular.size} cones)")
    ss = seam_system(mesh, cm)
    A, _ = _energy_matrix(mesh, cm, _local_frame(cm, h, None))
    Q, integer, _, _ = _variables(ss, cm)
    K = (A @ ss.P @ Q).tocsr()
    solver = MixedIntegerSolver((K.T @ K).tocsr(), integer, K)
    say(f"Poisson fit ({K.shape[1]} unknowns, {integer.size} integers)")
    if sc is None:
        sc = np.ones((mesh.n_faces, 2))
        for _ in range(scale_iterations):
            b = _energy_matrix_rhs(mesh, _local_frame(cm, h, sc))
            y_real = solver.real(K.T @ b)
            sc = _fitted_scale(mesh, cm, K @ y_real, h, sc)
    frame = _local_frame(cm, h, sc)
    b = _energy_matrix_rhs(mesh, frame)
    y_real = solver.real(K.T @ b)
    weights = np.ones(mesh.n_faces)
    say("integer rounding")
    for it in range(stiffening_iterations + 1):
        sw = np.repeat(np.sqrt(weights), 4)
        if it:
            Kw = sp.diags_array(sw) @ K
            solver = MixedIntegerSolver((Kw.T @ Kw).tocsr(), integer, K)
        gw = K.T @ (sw**2 * b)
        y = solver.rounded(gw, batch=rounding_batch)
        if _flip_count(K @ y):
            y = solver.local_search(gw, y, K)
        x = (ss.P @ (Q @ y)).reshape(-1, 2)
        uv = x[cm.wedges]
        distortion, flips = _distortion(mesh, K @ y, frame)
        if not flips.any():
            break
        say(f"stiffening ({int(flips.sum())} flipped triangles)")
        weights = _stiffen(mesh, weights, distortion, flips)
    bnorm = float(np.linalg.norm(b))
    res_real = float(np.linalg.norm(K @ y_real - b)) / bnorm
    res = float(np.linalg.norm(K @ y - b)) / bnorm
    flipped = uv_flips(uv)
    if flipped.size:
        warnings.warn(
            f"{flipped.size} uv triangles are flipped or degenerate (faces "
            f"{format_indices(flipped)}); use a larger edge length or a smoother field",
            FlippedParameterizationWarning,
            stacklevel=2,
        )
    trans = _transitions(mesh, uv, ss)
    trans[~cm.cut] = 0.0
    rot = np.where(cm.cut, ss.edge_q, 0)
    info = {"n_integers": int(integer.size), "n_chains": ss.n_chains}
    return SeamlessParameterization(
        uv=uv,
        field=mesh.from_complex(np.exp(1j * cm.angles)),
        cut=cm.cut,
        rotation=rot,
        translation=trans,
        sides=ss.edge_sides,
        singular=cm.singular,
        index4=cm.index4,
        edge_length=h,
        flipped=flipped,
        residual_real=res_real,
        residual=res,
        info=info,
    )


def _check_cones(mesh: TriMesh, cm: CutMesh) -> None:
    """Cones of index other than ±1/4 cannot be resolved by this pipeline's quads."""
    bad = cm.singular[np.abs(cm.index4[cm.singular]) > 2]
    if bad.size:
        raise ParameterizationInputError(
            f"the cross field has singularities of index beyond ±1/2 at vertices "
            f"{format_indices(bad)} (4 × index {format_indices(cm.index4[bad])}); smooth the "
            "field (align='smooth') or design one with cones of index ±1/4"
        )
