r"""Cancelling close singularity pairs of an N-direction field.

A singularity of index +1/N closer than a length r to one of index −1/N is, at the
resolution r, no singularity at all: a quad mesh with edge length r cannot give the two
distinct vertices without folding the quads between them. :func:`cancel_close_singularities`
removes such pairs by editing the field's topology and re-solving its angles with the
topology fixed (the fixed-topology step of mixed-integer field design: Ray, Vallet, Li
& Lévy 2008, "N-symmetry direction field design"; Bommes, Zimmer & Kobbelt 2009, §3):

1. pair singularities of opposite sign greedily, closest first, up to distance r (3D);
2. walk a shortest edge path v₁ → v₂ between the two and change the turning δ_e of the
   field across each path edge by ∓2π/N (in the orientation of the path). That moves 1/N
   of index from v₁ to v₂ and leaves the interior of the path unchanged
   (:func:`fvf.vertex_indices`: each edge adds its turning to one endpoint and subtracts
   it from the other);
3. rotate each face's representative by Δψ_t, minimizing

    $$\sum_e w_e\,(\tilde\delta_e + \Delta\psi_s - \Delta\psi_t)^2
    + \mu \sum_t \frac{A_t}{r^2}\,\Delta\psi_t^2 ,$$

    δ̃ the edited turnings and w_e the weights of the connection Laplacian
    (:func:`fvf.design.connection.connection_pairs`): one sparse SPD solve on the dual
    graph. The small μ fixes the constant and keeps the field where nothing changed.

The edited field's singularities are measured again by :func:`fvf.singularities`; a
cancelled pair can expose the next one, so the steps repeat a few rounds.
:func:`separate_close_singularities` uses the same index move to push two close
singularities of *equal* index ±1/N apart.

The re-solve can turn the field by more than π/N across some edge near a dense cluster of
singularities, which the re-measure reads as other singularities than planned. An edit is
therefore kept only if the re-measured result is better (cancelling: fewer singularities
and none of a higher index; separating: the same indices and fewer close equal pairs); a
round that is not is retried one move at a time (the matrix of step 3 is factored once).

On meshes with near-degenerate triangles the weights w_e span many orders of magnitude
(5 decades on the TOSCA lion), and the weighted re-solve puts the whole edit on the few
light edges next to the moved index, where it exceeds π/N: there no move passes the
re-measure. A move rejected with the weights w_e is therefore tried once more with
w_e = 1 (the dual graph's own Laplacian), which spreads the turning evenly over the
edges; on the lion at 2499 quads this takes 45 of 47 single cancelling moves that the
weighted re-solve refuses.

Two close −1/N singularities are left alone: moving 1/N of index onto one of them asks
the field to turn by 2π·2/N around one vertex, and the smooth re-solve of step 3 then
turns it by more than π/N across some edges of that vertex's ring, so that the measured
indices split into two −1/N singularities again.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from ..errors import ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.geometry import cross_rows
from ..mesh.inputs import as_face_field
from ..mesh.nfield import FROM_FIELD, FromField, NField, field_order
from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import Backend, factor_hermitian
from .connection import connection_pairs
from .indices import as_connection_rotations, singularities
from .nfields import check_nonzero, edge_angles

__all__ = [
    "cancel_close_singularities",
    "separate_close_singularities",
    "tidy_close_singularities",
    "close_singularity_pairs",
    "close_equal_pairs",
    "keep_singularities_off_curves",
    "KEEP_WEIGHT",
    "HOLD_WEIGHT",
    "SEPARATION",
]

#: Weight μ of keeping the original angles, relative to the smoothness term.
KEEP_WEIGHT = 1e-3
#: Weight of keeping the angle on the faces :func:`keep_singularities_off_curves` holds
#: (those whose direction is a constraint), relative to the smoothness term.
HOLD_WEIGHT = 1e3
#: Distance, in units of the radius, at which :func:`separate_close_singularities` puts
#: the moved singularity from the one it stays away from.
SEPARATION = 1.25
#: Moves of a rejected round retried one at a time, closest pairs first: each costs a solve
#: and a re-measure, so a field with hundreds of close pairs (noise) stays O(RETRY_MAX)
#: solves per round (a random cross field on 22.7k faces: 23 s -> 6 s); real fields
#: have tens (the lion: 47).
RETRY_MAX = 64
TWO_PI = 2.0 * np.pi


def close_singularity_pairs(
    mesh: TriMesh,
    vertices: np.ndarray,
    steps: np.ndarray,
    radius: float,
) -> list[tuple[int, int]]:
    """Pairs (a, b) of singular vertices of opposite sign closer than ``radius``, closest
    first.

    Parameters
    ----------
    mesh : TriMesh
    vertices : int64 (s,)
        Singular vertices.
    steps : int64 (s,)
        N × their indices (non-zero integers).
    radius : float
        3D distance below which a pair is taken.

    Returns
    -------
    list of (int, int)
        Vertex pairs, disjoint; 1/N of index moves from a to b (their indices have
        opposite signs), which lowers the total |index| by 2/N: a ±1/N, ∓1/N pair
        cancels, a ±2/N, ∓1/N pair leaves one ±1/N singularity.
    """
    return _greedy_close_pairs(
        mesh, vertices, radius, lambda i, j: np.sign(steps[i]) == -np.sign(steps[j])
    )


def _greedy_close_pairs(
    mesh: TriMesh,
    vertices: np.ndarray,
    radius: float,
    keep: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> list[tuple[int, int]]:
    """Disjoint pairs of ``vertices`` closer than ``radius`` (3D), closest first.

    The pairs (i, j) of positions in ``vertices`` for which ``keep(i, j)`` (bool, one per
    candidate pair) holds, matched greedily: a vertex joins the first pair it can.
    """
    if vertices.size < 2 or radius <= 0:
        return []
    P = mesh.vertices[vertices]
    ij = cKDTree(P).query_pairs(radius, output_type="ndarray")
    if ij.size == 0:
        return []
    i, j = ij[:, 0], ij[:, 1]
    kept = keep(i, j)
    i, j = i[kept], j[kept]
    order = np.argsort(np.linalg.norm(P[i] - P[j], axis=1), kind="stable")
    used = np.zeros(vertices.size, dtype=bool)
    pairs = []
    for a, b in zip(i[order], j[order], strict=True):  # greedy matching over a few pairs
        if used[a] or used[b]:
            continue
        used[a] = used[b] = True
        pairs.append((int(vertices[a]), int(vertices[b])))
    return pairs


def _edge_graph(mesh: TriMesh, keep: np.ndarray | None = None) -> sp.csr_array:
    """The vertex graph weighted by edge length, sparse (n, n) (upper triangle); only the
    edges ``keep`` (bool (E,)) when given."""
    E, X = mesh.edges, mesh.vertices
    if keep is not None:
        E = E[keep]
    n = mesh.n_vertices
    w = np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1)
    return sp.coo_array((w, (E[:, 0], E[:, 1])), shape=(n, n)).tocsr()


def _edge_paths(mesh: TriMesh, pairs: list[tuple[int, int]], limit: float) -> list[np.ndarray]:
    """Shortest vertex paths (by edge length) between the vertices of each pair.

    The searches stop at ``limit``; a pair not joined within it is searched again without.
    """
    G = _edge_graph(mesh)
    src = np.array([a for a, _ in pairs])
    _, pred = dijkstra(G, directed=False, indices=src, return_predecessors=True, limit=limit)
    paths = []
    for row, (a, b) in enumerate(pairs):  # loop over a few singularity pairs
        if pred[row, b] < 0:
            _, full = dijkstra(G, directed=False, indices=[a], return_predecessors=True)
            pred[row] = full[0]
        path = [b]
        while path[-1] != a and path[-1] >= 0:
            path.append(int(pred[row, path[-1]]))
        paths.append(np.array(path[::-1], dtype=np.int64))
    return paths


def _edited_turnings(
    mesh: TriMesh,
    u: np.ndarray,
    n: int,
    moves: list[tuple[int, int, int]],
    limit: float,
    rotations: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Interior edges and their turnings δ_e (relative to the connection turned by
    ``rotations``) with 1/N of index moved along each move's path.

    ``moves``: (a, b, s) moves s/N of index (s = ±1) from vertex a to vertex b.
    """
    interior, phi = edge_angles(mesh, u, rotations)
    delta = phi - (TWO_PI / n) * np.rint(n * phi / TWO_PI)
    full = np.zeros(mesh.n_edges)
    full[interior] = delta
    E = mesh.edges
    ends = [(a, b) for a, b, _ in moves]
    for (_, _, s), path in zip(moves, _edge_paths(mesh, ends, limit), strict=True):
        x0, x1 = path[:-1], path[1:]
        e = mesh.edge_ids(np.stack([x0, x1], axis=1))
        along = np.where(E[e, 0] == x0, 1.0, -1.0)
        full[e] -= along * s * TWO_PI / n
    return interior, full[interior]


class _Reangler:
    """Step 3 of the module docstring with its matrix factored once: Δψ (m,) minimizing
    Σ w_e (δ_e + Δψ_s − Δψ_t)² + μ Σ A_t Δψ_t² / r² for any turnings δ."""

    def __init__(
        self,
        mesh: TriMesh,
        radius: float,
        backend: Backend,
        uniform: bool = False,
        held: np.ndarray | None = None,
    ) -> None:
        _, _, w = connection_pairs(mesh, "knoppel")
        if uniform:  # the dual graph's own Laplacian (see _edit)
            w = np.ones_like(w)
        interior = np.flatnonzero((mesh.edge_faces >= 0).all(axis=1))
        ef = mesh.edge_faces[interior]
        m, k = mesh.n_faces, interior.size
        self.D = sp.csr_array(
            (
                np.concatenate([np.ones(k), -np.ones(k)]),
                (np.tile(np.arange(k), 2), np.concatenate([ef[:, 0], ef[:, 1]])),
            ),
            shape=(k, m),
        )
        self.w = w
        mu = KEEP_WEIGHT * mesh.face_areas / radius**2
        if held is not None:  # faces whose direction is a constraint: kept
            mu[held] *= HOLD_WEIGHT / KEEP_WEIGHT
        H = (self.D.T @ sp.diags_array(w) @ self.D + sp.diags_array(mu)).tocsr()
        self.fac = factor_hermitian(H, backend, solves="few")

    def __call__(self, delta: np.ndarray) -> np.ndarray:
        return self.fac.solve(-(self.D.T @ (self.w * delta)))


class _Reanglers:
    """The weighted and the uniform :class:`_Reangler` of one mesh and radius, each
    factored when first used; shared by consecutive edits of the same field
    (:func:`tidy_close_singularities`), so that the dual-graph matrix is factored once."""

    def __init__(
        self, mesh: TriMesh, radius: float, backend: Backend, held: np.ndarray | None = None
    ) -> None:
        self._args = (mesh, radius, backend)
        self._held = held
        self._built: dict[bool, _Reangler] = {}

    def __call__(self, uniform: bool = False) -> _Reangler:
        if uniform not in self._built:
            self._built[uniform] = _Reangler(*self._args, uniform=uniform, held=self._held)
        return self._built[uniform]


def _checked(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int | FromField,
    radius: float,
    rounds: int,
    rotations: npt.ArrayLike | None,
) -> tuple[int, float, np.ndarray, np.ndarray | None]:
    """The checked N, radius, unit field and ``connection_rotations`` (float64 (E,) or
    None) of the public entrances."""
    n = field_order(u, n, 4, "u")
    radius = float(radius)
    if not (np.isfinite(radius) and radius >= 0):
        raise ParameterError(f"radius must be a finite number >= 0; got {radius!r}")
    if int(rounds) != rounds or rounds < 0:
        raise ParameterError(f"rounds must be an integer >= 0; got {rounds!r}")
    u = as_face_field(mesh, u, "u")
    check_nonzero(mesh, u, "its singularities")
    rot = _rotations(mesh, rotations)
    return n, radius, u / np.linalg.norm(u, axis=1, keepdims=True), rot


def _checked_edits(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int | FromField,
    radius: float,
    rounds: int,
    backend: Backend,
    connection_rotations: npt.ArrayLike | None,
    *rules_at: Callable[[float], tuple[Callable, Callable]],
) -> np.ndarray:
    """The public entrances: check the arguments, then run :func:`_edit` with each
    ``rules_at(radius)`` (``moves_for`` and ``better``) in turn on one factored matrix."""
    n, radius, u, rot = _checked(mesh, u, n, radius, rounds, connection_rotations)
    reanglers = _Reanglers(mesh, radius, backend)
    for rules in rules_at:
        u = _edit(mesh, u, n, radius, rounds, reanglers, *rules(radius), rot)
    return NField(u, n)


@takes_mesh
def cancel_close_singularities(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int | FromField = FROM_FIELD,
    *,
    radius: float,
    rounds: int = 3,
    backend: Backend = "auto",
    connection_rotations: npt.ArrayLike | None = None,
) -> np.ndarray:
    """An N-field with the singularity pairs closer than ``radius`` removed (module doc).

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3)
        One representative vector per face, non-zero on every face.
    n : int, optional
        Symmetry order N ≥ 1. Default: the ``n`` of an :class:`fvf.NField` ``u``, else 4.
    radius : float
        3D distance below which a +1/N, −1/N pair cancels. For a quad mesh the target
        edge length.
    rounds : int
        Pair, cancel and re-measure at most this many times.
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        Sparse factorization of the dual-graph system.
    connection_rotations : float (E,), optional
        Measure and edit the field against the Levi-Civita connection turned by these
        angles (:func:`fvf.vertex_indices`); default none.

    Returns
    -------
    float64 (m, 3)
        The edited field, one unit representative per face (u itself, normalized, when
        no pair is closer than ``radius``).

    Raises
    ------
    ParameterError
        radius negative or not finite, rounds < 0.
    FieldShapeError
        Wrong shape, non-finite values or a zero vector on some face.
    """
    return _checked_edits(
        mesh, u, n, radius, rounds, backend, connection_rotations, partial(_cancelling, mesh)
    )


def _cancelling(mesh: TriMesh, radius: float) -> tuple[Callable, Callable]:
    """``moves_for`` and ``better`` of :func:`cancel_close_singularities` (see _edit)."""

    def moves_for(ids, steps):
        step_of = dict(zip(ids.tolist(), steps.tolist(), strict=True))
        pairs = close_singularity_pairs(mesh, ids, steps, radius)
        return [(a, b, int(np.sign(step_of[a]))) for a, b in pairs]

    def better(before, after):  # a lower total |index|, none of a higher index
        return _total(after) < _total(before) and _peak(after) <= _peak(before)

    return moves_for, better


def _total(state: tuple[np.ndarray, np.ndarray]) -> int:
    """The sum of |N × index| over the singularities of a ``_measure`` result."""
    return int(np.abs(state[1]).sum())


def _peak(state: tuple[np.ndarray, np.ndarray]) -> int:
    """The largest |N × index| of a ``_measure`` result (0 without singularities)."""
    return int(np.abs(state[1]).max(initial=0))


def _apply_moves(
    mesh: TriMesh,
    u: np.ndarray,
    n: int,
    moves: list[tuple[int, int, int]],
    radius: float,
    reangle: _Reangler,
    rotations: np.ndarray | None,
) -> np.ndarray:
    """The field with each move's index moved along its path, angles re-solved (steps 2–3)."""
    interior, delta = _edited_turnings(mesh, u, n, moves, 4.0 * radius, rotations)
    full = np.zeros(mesh.n_edges)
    full[interior] = delta
    dpsi = reangle(full[(mesh.edge_faces >= 0).all(axis=1)])
    Ju = cross_rows(mesh.face_normals, u)
    return np.cos(dpsi)[:, None] * u + np.sin(dpsi)[:, None] * Ju


def _measure(
    mesh: TriMesh, u: np.ndarray, n: int, rotations: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Singular vertices int64 (s,) and N × their indices int64 (s,)."""
    ids, ind = singularities(mesh, u, n=n, connection_rotations=rotations)
    return ids, np.rint(n * np.asarray(ind, dtype=float)).astype(np.int64)


def _edit(
    mesh: TriMesh,
    u: np.ndarray,
    n: int,
    radius: float,
    rounds: int,
    reanglers: _Reanglers,
    moves_for: Callable[[np.ndarray, np.ndarray], list],
    better: Callable[[tuple, tuple], bool],
    rotations: np.ndarray | None = None,
) -> np.ndarray:
    """Rounds of "find moves, apply them, re-measure"; a round whose result is not
    ``better`` than its start is retried one move at a time (the first
    :data:`RETRY_MAX`), keeping the moves that are.

    ``moves_for(ids, steps)`` → list of (a, b, s); ``better(before, after)`` compares two
    ``_measure`` results. The re-measure guards against the re-solve turning the field by
    more than π/N across an edge, which would make other singularities than planned.
    """
    state = _measure(mesh, u, n, rotations)
    for _ in range(int(rounds)):  # a few rounds: an edit can expose the next pair
        moves = moves_for(*state)
        if not moves:
            break
        reangle = reanglers()
        trial = _apply_moves(mesh, u, n, moves, radius, reangle, rotations)
        after = _measure(mesh, trial, n, rotations)
        if better(state, after):
            u, state = trial, after
            continue
        progress = False
        for move in moves[:RETRY_MAX]:  # retry one at a time, closest pairs first
            trial = _apply_moves(mesh, u, n, [move], radius, reangle, rotations)
            after = _measure(mesh, trial, n, rotations)
            if not better(state, after):  # the uniform-weight re-solve (module docstring)
                trial = _apply_moves(mesh, u, n, [move], radius, reanglers(uniform=True), rotations)
                after = _measure(mesh, trial, n, rotations)
            if better(state, after):
                u, state, progress = trial, after, True
        if not progress:
            break
    return u


def close_equal_pairs(
    mesh: TriMesh, vertices: np.ndarray, steps: np.ndarray, radius: float
) -> list[tuple[int, int]]:
    """Disjoint pairs (a, b) of singular vertices of equal index ±1/N closer than
    ``radius`` (3D), closest first; ``vertices`` int64 (s,), ``steps`` N × their indices."""
    return _greedy_close_pairs(
        mesh, vertices, radius, lambda i, j: (steps[i] == steps[j]) & (np.abs(steps[i]) == 1)
    )


@takes_mesh
def separate_close_singularities(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int | FromField = FROM_FIELD,
    *,
    radius: float,
    rounds: int = 3,
    backend: Backend = "auto",
    connection_rotations: npt.ArrayLike | None = None,
) -> np.ndarray:
    """An N-field whose singularities of equal index ±1/N are about ``radius`` apart.

    Two singularities of equal index ±1/N closer than r (3D) are separated: a of the
    pair (a, b) moves to the vertex c nearest to a (shortest edge paths) among those at
    least SEPARATION · r from b and from every other singularity that stays, by the index
    move of the module docstring (step 2, along
    a shortest path a → c) and the re-solve of step 3. For a quad mesh with edge length r,
    two such cones closer than r would have to sit on distinct integer points, which
    folds the quads between them.

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3)
        One representative vector per face, non-zero on every face.
    n : int, optional
        Symmetry order N ≥ 1. Default: the ``n`` of an :class:`fvf.NField` ``u``, else 4.
    radius : float
        3D distance below which a pair of equal singularities is separated.
    rounds : int
        Pair, move and re-measure at most this many times.
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
    connection_rotations : float (E,), optional
        As in :func:`cancel_close_singularities`.

    Returns
    -------
    float64 (m, 3)
        The edited field, one unit representative per face (u normalized when no pair is
        closer than ``radius``).

    Raises
    ------
    ParameterError
        radius negative or not finite, rounds < 0.
    FieldShapeError
        Wrong shape, non-finite values or a zero vector on some face.
    """
    return _checked_edits(
        mesh, u, n, radius, rounds, backend, connection_rotations, partial(_separating, mesh)
    )


def _separating(mesh: TriMesh, radius: float) -> tuple[Callable, Callable]:
    """``moves_for`` and ``better`` of :func:`separate_close_singularities`."""

    def moves_for(ids, steps):
        step_of = dict(zip(ids.tolist(), steps.tolist(), strict=True))
        pairs = close_equal_pairs(mesh, ids, steps, radius)
        if not pairs:
            return []
        targets = _separation_targets(mesh, pairs, ids, radius)
        return [
            (a, c, int(np.sign(step_of[a])))
            for (a, _), c in zip(pairs, targets, strict=True)
            if c >= 0
        ]

    def better(before: tuple, after: tuple) -> bool:  # the same indices, fewer close pairs
        return np.array_equal(np.sort(after[1]), np.sort(before[1])) and len(
            close_equal_pairs(mesh, after[0], after[1], radius)
        ) < len(close_equal_pairs(mesh, before[0], before[1], radius))

    return moves_for, better


def _separation_targets(
    mesh: TriMesh, pairs: list[tuple[int, int]], singular: np.ndarray, radius: float
) -> list[int]:
    """For each pair (a, b): the vertex nearest to a (along edges) among those at least
    SEPARATION · radius (along edges) from every singular vertex that does not move (the
    b's and those in no pair; a itself for a pair (a, a), which splits a) and from the
    targets chosen before it; −1 when there is none within 4 · radius of a."""
    G = _edge_graph(mesh)
    far = SEPARATION * radius
    fixed = np.setdiff1d(singular, [a for a, b in pairs if a != b])  # (a, a): a stays too
    clear = dijkstra(G, directed=False, indices=fixed, min_only=True, limit=far) >= far
    clear[singular] = False
    D = dijkstra(G, directed=False, indices=[a for a, _ in pairs], limit=4.0 * radius)
    return _greedy_targets(mesh, D, clear, far)


def _greedy_targets(mesh: TriMesh, D: np.ndarray, allowed: np.ndarray, far: float) -> list[int]:
    """For each row k of the distances D (s, n) from a moving singularity: the nearest
    ``allowed`` vertex (bool (n,)) at least ``far`` (3D) from the targets chosen for the
    rows before it; −1 where none is reachable. O(n) per row."""
    ok = allowed.copy()
    X = mesh.vertices
    out: list[int] = []
    for row in D:  # a few singularities
        da = np.where(ok, row, np.inf)
        c = int(np.argmin(da))
        if not np.isfinite(da[c]):
            out.append(-1)
            continue
        out.append(c)
        ok &= np.linalg.norm(X - X[c], axis=1) >= far
    return out


def split_large_singularities(
    mesh: TriMesh,
    u: np.ndarray,
    n: int,
    *,
    radius: float,
    max_step: int,
    rounds: int = 3,
    backend: Backend = "auto",
    connection_rotations: npt.ArrayLike | None = None,
) -> np.ndarray:
    """The N-field with each singularity of |N × index| > ``max_step`` split: 1/N of its
    index moves (step 2 of the module docstring, then the re-solve of step 3) to the
    nearest vertex at least SEPARATION · ``radius`` from every singularity, as in
    :func:`separate_close_singularities`; an edit is kept when it lowers
    Σ max(|N × index| − max_step, 0) without raising the largest |N × index|.

    A quad mesh has no vertex for an index beyond ±1/2 (valence 2 or 6+). Where the field
    is nearly zero around a vertex (the smoothest cross field of a body scan can have
    |z| ~ 1e-10 of its maximum), the turnings across its ring's edges sit close to ±π/N
    and their sum can reach a measured index of −3/4. ``u``: unit representatives
    float64 (m, 3), checked by the caller; returns the edited field, float64 (m, 3).
    """
    reanglers = _Reanglers(mesh, radius, backend)
    rules = _splitting(mesh, radius, max_step)
    return _edit(
        mesh, u, n, radius, rounds, reanglers, *rules, _rotations(mesh, connection_rotations)
    )


def _splitting(mesh: TriMesh, radius: float, max_step: int) -> tuple[Callable, Callable]:
    """``moves_for`` and ``better`` of :func:`split_large_singularities`."""

    def excess(state: tuple[np.ndarray, np.ndarray]) -> int:
        return int(np.maximum(np.abs(state[1]) - max_step, 0).sum())

    def moves_for(ids, steps):
        big = ids[np.abs(steps) > max_step]
        if big.size == 0:
            return []
        step_of = dict(zip(ids.tolist(), steps.tolist(), strict=True))
        pairs = [(int(a), int(a)) for a in big]
        targets = _separation_targets(mesh, pairs, ids, radius)
        return [
            (a, c, int(np.sign(step_of[a])))
            for (a, _), c in zip(pairs, targets, strict=True)
            if c >= 0
        ]

    def better(before: tuple, after: tuple) -> bool:
        return excess(after) < excess(before) and _peak(after) <= _peak(before)

    return moves_for, better


def tidy_close_singularities(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int | FromField = FROM_FIELD,
    *,
    radius: float,
    max_step: int = 2,
    rounds: int = 3,
    backend: Backend = "auto",
    connection_rotations: npt.ArrayLike | None = None,
) -> np.ndarray:
    """The edits a quad mesh of edge length ``radius`` needs, in order, on one factored
    matrix: opposite pairs cancelled (:func:`cancel_close_singularities`), equal pairs
    moved apart (:func:`separate_close_singularities`), the opposite pairs those moves
    brought close cancelled, singularities beyond ``max_step``/N split
    (:func:`split_large_singularities`).

    The same as the four calls one after the other, with the dual-graph matrix of step 3
    (module docstring) factored once for all of them instead of once per call.

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3)
        One representative vector per face, non-zero on every face.
    n : int, optional
        Symmetry order N ≥ 1. Default: the ``n`` of an :class:`fvf.NField` ``u``, else 4.
    radius : float
        3D distance at which singularities count as close.
    max_step : int
        Largest |N × index| left alone.
    rounds : int
        Rounds of each edit at most.
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
    connection_rotations : float (E,), optional
        As in :func:`cancel_close_singularities`.

    Returns
    -------
    float64 (m, 3)
        The edited field, one unit representative per face.

    Raises
    ------
    ParameterError
        radius negative or not finite, rounds < 0.
    FieldShapeError
        Wrong shape, non-finite values or a zero vector on some face.
    """
    return _checked_edits(
        mesh,
        u,
        n,
        radius,
        rounds,
        backend,
        connection_rotations,
        partial(_cancelling, mesh),
        partial(_separating, mesh),
        partial(_cancelling, mesh),  # pairs the moves brought close
        lambda r: _splitting(mesh, r, max_step),  # index beyond max_step / N
    )


def keep_singularities_off_curves(
    mesh: TriMesh,
    u: np.ndarray,
    n: int,
    *,
    curve_vertices: np.ndarray,
    radius: float,
    held: np.ndarray | None = None,
    rounds: int = 2,
    backend: Backend = "auto",
    connection_rotations: npt.ArrayLike | None = None,
) -> np.ndarray:
    """The N-field with its singularities near curves (not on them) moved to ``radius``.

    A singular vertex at distance 0 < d < r (shortest edge paths) from ``curve_vertices``
    (the vertices of sharp features that become integer iso-lines of a parameterization)
    moves to the vertex nearest to it, along edges that touch no curve vertex (so it stays
    on its side of the curves), among those at least r from the curves and
    :data:`SEPARATION` · r from every other singularity, within 2 r; by the index move of
    the module docstring and the re-solve of step 3 with the ``held`` faces kept. A cone
    at 0.6 r from an iso-line would otherwise round onto it (the quads between collapse)
    or one unit away (they double), whichever the greedy rounding meets first. An edit is
    kept when the indices are the same and fewer singularities are near the curves.

    Parameters
    ----------
    mesh : TriMesh
    u : float64 (m, 3)
        Unit representatives, one per face (checked by the caller).
    n : int
    curve_vertices : int64 (c,)
    radius : float
        The distance r (for a quad mesh, the edge length h).
    held : int64 (k,), optional
        Faces whose direction is a constraint (kept by weight :data:`HOLD_WEIGHT`).
    rounds : int
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
    connection_rotations : float (E,), optional
        As in :func:`cancel_close_singularities`.

    Returns
    -------
    float64 (m, 3)
        The edited field (u itself when no singularity is near a curve, or no move helps).
    """
    curve = np.unique(np.asarray(curve_vertices, dtype=np.int64))
    if curve.size == 0 or radius <= 0:
        return u
    reanglers = _Reanglers(mesh, radius, backend, held=held)
    rules = _off_curves(mesh, curve, radius)
    return _edit(
        mesh, u, n, radius, rounds, reanglers, *rules, _rotations(mesh, connection_rotations)
    )


def _rotations(mesh: TriMesh, connection_rotations: npt.ArrayLike | None) -> np.ndarray | None:
    """The checked ``connection_rotations`` float64 (E,), or None."""
    if connection_rotations is None:
        return None
    return as_connection_rotations(mesh, connection_rotations)


def _off_curves(mesh: TriMesh, curve: np.ndarray, radius: float) -> tuple[Callable, Callable]:
    """``moves_for`` and ``better`` of :func:`keep_singularities_off_curves`."""
    G = _edge_graph(mesh)
    to_curve = dijkstra(G, directed=False, indices=curve, min_only=True, limit=2.0 * radius)
    on_curve = np.zeros(mesh.n_vertices, dtype=bool)
    on_curve[curve] = True
    E = mesh.edges
    inside = ~on_curve[E].any(axis=1)  # paths that stay on their side of the curves
    Gs = _edge_graph(mesh, inside)

    def near(ids: np.ndarray) -> np.ndarray:
        return ids[(to_curve[ids] > 0) & (to_curve[ids] < radius)]

    def moves_for(ids, steps):
        movers = near(ids)
        if movers.size == 0:
            return []
        step_of = dict(zip(ids.tolist(), steps.tolist(), strict=True))
        far = SEPARATION * radius
        others = np.setdiff1d(ids, movers)
        ok = to_curve >= radius
        if others.size:
            ok &= dijkstra(G, directed=False, indices=others, min_only=True, limit=far) >= far
        D = dijkstra(Gs, directed=False, indices=movers, limit=2.0 * radius)
        targets = _greedy_targets(mesh, D, ok, far)
        return [
            (a, c, int(np.sign(step_of[a])))
            for a, c in zip(movers.tolist(), targets, strict=True)
            if c >= 0
        ]

    def better(before: tuple, after: tuple) -> bool:
        return np.array_equal(np.sort(after[1]), np.sort(before[1])) and (
            near(after[0]).size < near(before[0]).size
        )

    return moves_for, better
