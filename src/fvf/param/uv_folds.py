r"""Removing flipped uv triangles after rounding: local and global stiffening.

After integer rounding the Poisson fit

.. math::

    \min_y \sum_t w_t A_t \bigl(|\nabla s - X|^2 + |\nabla t - Y|^2\bigr)

may leave some uv triangles flipped (det(∇s, ∇t) ≤ 0), typically around cones placed
close together. Bommes et al. (2009, §6) stiffen the fit where it is distorted — the
weight w_t of a face grows with its distortion |σ₁ − 1| + |σ₂ − 1| (σ the singular values
of (∇s, ∇t) against the frame, at most :data:`DISTORTION_CAP` per round), and ×
:data:`FLIP_BOOST` on flipped faces and their edge neighbours — and solve again.
:func:`repair_folds` does this on two levels per round:

1. **local** (:func:`local_repair`): the integers stay as rounded (every real solution is
   then seamless) and only the real unknowns of a region around the flipped faces (a few
   face rings) are solved for, the rest held fixed: a small sparse system;
2. **integer moves** (:func:`integer_moves`), when folds remain: single integer unknowns
   move by ±1 while that lowers the flip count; with the real unknowns re-solved exactly,
   each move changes the fit by a fixed sparse column, so a candidate costs an update of
   the faces it touches;
3. **global**, when folds remain: the weighted fit is factored again and the integers
   are rounded again (:class:`fvf.param.rounding.MixedIntegerSolver`), so that the
   rounding itself can move away from the folds.

The solution with the fewest flips seen is kept (ties: the first).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import Backend, factor_hermitian
from .rounding import SCHUR_BLOCK_ENTRIES, MixedIntegerSolver, solved_columns

__all__ = [
    "flip_count",
    "flipped_faces",
    "face_distortion",
    "local_repair",
    "integer_moves",
    "repair_folds",
]

#: Largest distortion added to a face's weight per round (Bommes et al. 2009).
DISTORTION_CAP = 5.0
#: Extra factor on the weights of flipped faces and their edge neighbours per round.
FLIP_BOOST = 4.0
#: Entries of a response column below this fraction of its largest are dropped.
RESPONSE_RTOL = 1e-2
#: Integer unknowns tried per sweep of :func:`integer_moves`: those responding most at
#: the flipped faces.
SEARCH_CANDIDATES = 24
#: Flipped faces whose rows of R rank the candidates of a sweep of :func:`integer_moves`
#: (evenly spaced among them when more are flipped). Each costs four solves with the real
#: block's factor: on a ribbon closed by domes, 888 flipped faces made 68 s of row solves
#: for moves that could not succeed.
MOVE_ROW_FACES = 64
#: :func:`repair_folds` stops when a new rounding leaves more than RUNAWAY_FACTOR × the
#: fewest flips seen + RUNAWAY_SLACK: the stiffening weights have run away (on the TOSCA
#: lion rounds then start from 4000–5000 flipped triangles and cost 25 s each, never
#: coming back; the repairs that succeed on the shared meshes stay far below).
RUNAWAY_FACTOR = 4
RUNAWAY_SLACK = 64
#: It also stops when a new rounding leaves more flips than the rounding it started
#: from and more than WORSE_FLOOR: on the 27 OpenSCAD parts at 2,000 quads the 7
#: repairs that succeeded after their first round started every later round from at
#: most 22 flips, never more than the first; the failed repairs spent 44 of their 120 s
#: in rounds after such a rounding.
WORSE_FLOOR = 32
#: :func:`repair_folds` stops after this many rounds in a row that did not lower the
#: fewest flips seen (on the wild corpus's plate with six holes, the input's rounds go
#: 336, 586, 643, … 802 flipped triangles, 8 rounds and 3.6 s, never below the first;
#: the repairs that succeed there do so within a round of their last improvement).
STALL_ROUNDS = 2
#: :func:`repair_folds` leaves a rounding alone when more than this fraction of the
#: triangles is flipped: the repair is local (it stiffens the fit around the flips), and
#: such a rounding is a field the integer grid cannot follow, not a few folds (a
#: hemisphere whose smooth rim was made an integer iso-line: 2,652 and 5,349 flipped
#: triangles, about half and a quarter of them, 190 s of repair rounds that never
#: succeed; the repairs that succeed on the shared meshes and the wild corpus start from
#: at most a few percent).
HOPELESS_FRACTION = 0.1


def flipped_faces(fit: np.ndarray) -> np.ndarray:
    """bool (m,): faces whose Jacobian (∇s, ∇t) has det ≤ 0 (``fit`` (4m,) rows s_x, s_y,
    t_x, t_y, any positive per-face factor)."""
    J = fit.reshape(-1, 4)
    return ~(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2] > 0)


def flip_count(fit: np.ndarray) -> int:
    """Number of flipped faces of a fit (4m,) (:func:`flipped_faces`)."""
    return int(np.count_nonzero(flipped_faces(fit)))


def face_distortion(fit: np.ndarray, target: np.ndarray) -> np.ndarray:
    """|σ₁ − 1| + |σ₂ − 1| per face, float64 (m,), σ the singular values of J F⁻¹.

    ``fit`` and ``target`` (4m,) are √A_t (∇s, ∇t) and √A_t (X, Y) per face (the factor
    cancels).
    """
    J = fit.reshape(-1, 2, 2)
    F = target.reshape(-1, 2, 2)
    det_f = F[:, 0, 0] * F[:, 1, 1] - F[:, 0, 1] * F[:, 1, 0]
    adj_f = np.stack([F[:, 1, 1], -F[:, 0, 1], -F[:, 1, 0], F[:, 0, 0]], axis=1)
    M = J @ (adj_f.reshape(-1, 2, 2) / det_f[:, None, None])  # J F⁻¹
    # 2 × 2 singular values in closed form: σ₁ ± σ₂ = √(|M|²_F ± 2 |det M|)
    frob = np.einsum("tij,tij->t", M, M)
    det_m = np.abs(M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0])
    plus = np.sqrt(frob + 2.0 * det_m)
    minus = np.sqrt(np.maximum(frob - 2.0 * det_m, 0.0))
    s1, s2 = 0.5 * (plus + minus), 0.5 * (plus - minus)
    return np.abs(s1 - 1.0) + np.abs(s2 - 1.0)


def _dilate(mesh: TriMesh, mask: np.ndarray, rings: int) -> np.ndarray:
    """Faces within ``rings`` edge-adjacency steps of the faces in ``mask``, bool (m,)."""
    adj = mesh.face_adjacency
    out = mask.copy()
    for _ in range(rings):  # a few rings
        nb = adj[out]
        out[nb[nb >= 0]] = True
    return out


def stiffen(mesh: TriMesh, w: np.ndarray, fit: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bommes et al.'s weight update, float64 (m,): w + min(distortion, cap), then ×
    :data:`FLIP_BOOST` on flipped faces and their edge neighbours."""
    w = w + np.minimum(face_distortion(fit, b), DISTORTION_CAP)
    w[_dilate(mesh, flipped_faces(fit), 1)] *= FLIP_BOOST
    return w


def local_repair(
    mesh: TriMesh,
    K: sp.csr_array,
    real: np.ndarray,
    y: np.ndarray,
    b: np.ndarray,
    w: np.ndarray,
    *,
    rounds: int = 3,
    rings: int = 4,
    backend: Backend = "auto",
) -> tuple[np.ndarray, np.ndarray]:
    """Local stiffening rounds with the integers fixed (step 1 of the module docstring).

    Parameters
    ----------
    mesh : TriMesh
    K : sparse (4m, p)
        The fit: y ↦ √A_t (∇s, ∇t) per face (rows s_x, s_y, t_x, t_y).
    real : int64 (r,)
        The unknowns of y that may change (the real ones).
    y : float64 (p,)
        The rounded solution.
    b : float64 (4m,)
        √A_t (X, Y) per face, the target.
    w : float64 (m,)
        Face weights to start from (updated by :func:`stiffen` each round).
    rounds : int
        Rounds at most; round i solves within ``rings * (i + 1)`` face rings of the flips.

    Returns
    -------
    y : float64 (p,)
        The solution with the fewest flips seen (the integers unchanged).
    w : float64 (m,)
        The final face weights.
    """
    is_real = np.zeros(K.shape[1], dtype=bool)
    is_real[real] = True
    Kc = K.tocsc()
    best, best_y = flip_count(K @ y), y
    for it in range(rounds):  # a few stiffening rounds
        fit = K @ y
        flips = flipped_faces(fit)
        if not flips.any():
            break
        w = stiffen(mesh, w, fit, b)
        region = _dilate(mesh, flips, rings * (it + 1))
        rows = (4 * np.flatnonzero(region)[:, None] + np.arange(4)).ravel()
        cols = np.unique(K[rows].indices)
        free = cols[is_real[cols]]
        Kf = Kc[:, free]
        touched = np.unique(Kf.indices)  # every row whose value the free unknowns change
        Kf = sp.csr_array(Kf)[touched]
        sw = np.repeat(w, 4)[touched]
        rhs_rows = b[touched] - (K[touched] @ y - Kf @ y[free])
        H = Kf.T @ sp.diags_array(sw) @ Kf
        y = y.copy()
        fac = factor_hermitian(sp.csr_array(H), backend, solves="few")
        y[free] = fac.solve(Kf.T @ (sw * rhs_rows))
        count = flip_count(K @ y)
        if count < best:
            best, best_y = count, y
    return best_y, w


class _Responses:
    """Entries of R = K_i − K_r H_rr⁻¹ H_ri (4m, k), computed when first asked and kept.

    Column i is the change of K y per unit step of integer unknown i with the real
    unknowns re-solved. A few rows of R (those of the flipped faces) cost one solve per
    row, H_rr⁻¹ K_rᵀ (H_rr is symmetric); a column costs one solve, H_rr⁻¹ H_ri. Only the
    rows at flipped faces and the columns of the candidates tried are ever needed, so this
    is far cheaper than all k columns when k is hundreds (a solve per integer unknown).
    """

    def __init__(self, solver: MixedIntegerSolver, K: sp.csr_array):
        Kc = sp.csc_array(K)
        self.solver = solver
        self.Ki = Kc[:, solver.integer]
        self.Kr = Kc[:, solver.real_idx]
        del Kc
        self._K = sp.csr_array(K)  # its rows: no row-major copy of K_r (0.15 GB at 750k faces)
        self._rows: dict[int, np.ndarray] = {}
        self._cols: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        # right-hand sides per solve, so that a block holds SCHUR_BLOCK_ENTRIES at most
        self._block = max(1, SCHUR_BLOCK_ENTRIES // max(solver.real_idx.size, 1))

    def known(self, idx: np.ndarray) -> np.ndarray:
        """bool (len(idx),): whether the row of R at each of ``idx`` is already solved."""
        return np.array([r in self._rows for r in idx.tolist()], dtype=bool)

    def rows(self, idx: np.ndarray) -> np.ndarray:
        """float64 (len(idx), k): R at the rows ``idx``."""
        new = np.array([r for r in idx.tolist() if r not in self._rows], dtype=np.int64)
        for lo in range(0, new.size, self._block):  # solve blocks of bounded memory
            part = new[lo : lo + self._block]
            Kp = self._K[part]
            Ki, Kr = Kp[:, self.solver.integer], sp.csc_array(Kp[:, self.solver.real_idx].T)
            for cut, X in solved_columns(self.solver.fac, Kr):
                values = Ki[cut].toarray() - (self.solver.Hri.T @ X).T
                self._rows.update(zip(part[cut].tolist(), values, strict=True))
        return np.array([self._rows[r] for r in idx.tolist()]).reshape(idx.size, -1)

    def columns(self, cols: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """(rows, values) of each column in ``cols``, entries below :data:`RESPONSE_RTOL` of
        the column's largest dropped."""
        new = np.array([c for c in cols.tolist() if c not in self._cols], dtype=np.int64)
        for lo in range(0, new.size, self._block):  # solve blocks of bounded memory
            part = new[lo : lo + self._block]
            for cut, Z in solved_columns(self.solver.fac, self.solver.Hri[:, part]):
                R = self.Ki[:, part[cut]].toarray()  # (4m, a few): not the block's width
                R -= self.Kr @ Z
                for c, col in zip(part[cut].tolist(), R.T, strict=True):
                    keep = np.flatnonzero(np.abs(col) >= RESPONSE_RTOL * np.abs(col).max())
                    self._cols[c] = (keep, col[keep])
        return [self._cols[c] for c in cols.tolist()]


def _ranking_faces(bad: np.ndarray, R: _Responses) -> np.ndarray:
    """int64: at most :data:`MOVE_ROW_FACES` of the flipped faces ``bad``, those whose rows
    of R are known first, then evenly spaced others."""
    if bad.size <= MOVE_ROW_FACES:
        return bad
    known = R.known(bad * 4)
    new = bad[~known]
    room = max(MOVE_ROW_FACES - int(known.sum()), 0)
    if new.size > room:  # (none when room is 0: linspace gives no index)
        new = new[np.linspace(0, new.size - 1, room).round().astype(np.int64)]
    return np.sort(np.concatenate([bad[known], new]))


def integer_moves(
    solver: MixedIntegerSolver, K: sp.csr_array, g: np.ndarray, y: np.ndarray, sweeps: int = 30
) -> np.ndarray:
    """Move single integer unknowns by ±1 while that lowers the number of flipped faces.

    Parameters
    ----------
    solver : MixedIntegerSolver
        Of the fit whose minimizer y is (H = Kᵀ W K for face weights W).
    K : sparse (4m, p)
        y ↦ √A_t (∇s, ∇t) per face (rows s_x, s_y, t_x, t_y).
    g : float64 (p,)
        The right-hand side y was rounded for.
    y : float64 (p,)
        A rounded minimizer (y[solver.integer] integers).
    sweeps : int
        Moves at most. Per sweep the best of ±1 on the :data:`SEARCH_CANDIDATES` integer
        unknowns responding most at flipped faces is taken (fewest flips, then lowest
        energy ½ wᵀS w − rᵀw); stops at zero flips or when no move helps.

    Returns
    -------
    float64 (p,)
        ``y`` with the moved integers, and its real unknowns changed as re-solving
        changes them: y_r − H_rr⁻¹ H_ri Δw for the integer steps Δw (the fit is then
        K y + R Δw, exactly what the moves were chosen on; ``y`` need not be the
        minimizer of ``solver``'s fit, e.g. after :func:`local_repair`).
    """
    _, r = solver.reduced(g)
    w = y[solver.integer].copy()
    fit = (K @ y).reshape(-1, 4)
    R = _Responses(solver, K)

    def det(f):
        return f[:, 0] * f[:, 3] - f[:, 1] * f[:, 2]

    flipped = ~(det(fit) > 0)
    best = int(flipped.sum())
    S = solver.S
    where: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # per column: its faces, slots
    for _ in range(sweeps):  # a few sweeps over a few candidate unknowns
        if best == 0:
            break
        bad_rows = (_ranking_faces(np.flatnonzero(flipped), R)[:, None] * 4 + np.arange(4)).ravel()
        strength = np.abs(R.rows(bad_rows)).max(axis=0)
        cand = np.argsort(-strength, kind="stable")[:SEARCH_CANDIDATES]
        cand = cand[strength[cand] > 0]
        choice = None
        for i, (rows, vals) in zip(cand.tolist(), R.columns(cand), strict=True):
            if i not in where:  # the faces a column touches, and its rows among theirs
                f = np.unique(rows // 4)
                where[i] = (f, np.searchsorted((f[:, None] * 4 + np.arange(4)).ravel(), rows))
            faces, slots = where[i]
            before = int(flipped[faces].sum())
            for step in (-1.0, 1.0):
                local = fit[faces].copy().ravel()
                local[slots] += step * vals
                after = int(np.count_nonzero(~(det(local.reshape(-1, 4)) > 0)))
                score = best - before + after
                de = step * (S[i] @ w - r[i]) + 0.5 * S[i, i]
                if choice is None or (score, de) < (choice[0], choice[3]):
                    choice = (score, i, step, de)
        if choice is None or choice[0] >= best:
            break
        best, i, step, _ = choice
        w[i] += step
        rows, vals = R.columns(np.array([i]))[0]
        fit.ravel()[rows] += step * vals
        flipped = ~(det(fit) > 0)
    step_w = w - y[solver.integer]
    out = y.copy()
    out[solver.integer] = w
    if step_w.any():
        out[solver.real_idx] -= solver.fac.solve(solver.Hri @ step_w)
    return out


def repair_folds(
    mesh: TriMesh,
    K: sp.csr_array,
    solver: MixedIntegerSolver,
    y: np.ndarray,
    b: np.ndarray,
    *,
    rounds: int = 8,
    batch: float = 0.05,
    backend: Backend = "auto",
    progress: Callable[[str], None] | None = None,
    release_solver: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Remove flipped uv triangles: local, then global stiffening rounds (module docstring).

    Parameters
    ----------
    mesh : TriMesh
    K : sparse (4m, p)
        The fit: y ↦ √A_t (∇s, ∇t) per face (rows s_x, s_y, t_x, t_y).
    solver : MixedIntegerSolver
        Of the unweighted fit H = KᵀK (its integer unknowns are those of y).
    y : float64 (p,)
        The rounded solution.
    b : float64 (4m,)
        √A_t (X, Y) per face, the target.
    rounds : int
        Rounds at most (each: a local repair, integer moves, then a new factorization
        and rounding of the stiffened fit while flips remain); fewer when a new rounding
        leaves far more flips than the best seen (:data:`RUNAWAY_FACTOR`) or more than
        the first (:data:`WORSE_FLOOR`), or
        :data:`STALL_ROUNDS` rounds in a row did not lower it; none when more than
        :data:`HOPELESS_FRACTION` of the triangles are flipped.
    batch : float
        Greedy rounding batch (:meth:`MixedIntegerSolver.rounded`).
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
    progress : callable, optional
        Called with a message per round.
    release_solver : bool
        Release ``solver``'s factorization (:meth:`MixedIntegerSolver.release`) before the
        first new factorization, so that two are never held at once (with the blocked
        response solves, ``fvf.quad_mesh`` on 750k faces peaks at 4.0 GB instead of 5.7 GB;
        docs/quads.md). For callers that do not solve with it again.

    Returns
    -------
    y : float64 (p,)
        The solution with the fewest flipped faces seen (y[integer] integers).
    weights : float64 (m,)
        The final face weights.
    """
    w = np.ones(mesh.n_faces)
    g = K.T @ b
    best, best_y = flip_count(K @ y), y
    worse = max(WORSE_FLOOR, best)  # a new rounding with more flips is given up
    if best > HOPELESS_FRACTION * mesh.n_faces:
        if progress is not None:
            progress(f"{best} of {mesh.n_faces} triangles flipped: too many to repair")
        return y, w

    def keep(candidate: np.ndarray) -> int:
        nonlocal best, best_y
        count = flip_count(K @ candidate)
        if count < best:
            best, best_y = count, candidate
        return count

    stalled, last = 0, best
    for it in range(rounds):  # a few stiffening rounds
        if best == 0:
            break
        if it:
            stalled, last = (0 if best < last else stalled + 1), best
            if stalled >= STALL_ROUNDS:
                break  # the last rounds found nothing better
        if progress is not None:
            progress(f"stiffening round {it + 1}: {flip_count(K @ y)} flipped triangles")
        y, w = local_repair(mesh, K, solver.real_idx, y, b, w, backend=backend)
        if keep(y) == 0:
            break
        moved = integer_moves(solver, K, g, y)
        if keep(moved) == 0:
            break
        if not np.array_equal(moved, y):  # the moves may let a local repair finish
            y, w = local_repair(mesh, K, solver.real_idx, moved, b, w, backend=backend)
            if keep(y) == 0:
                break
        if it == rounds - 1:
            break
        w = stiffen(mesh, w, K @ y, b)
        sw = np.repeat(np.sqrt(w), 4)
        Kw = sp.diags_array(sw) @ K
        integer = solver.integer
        if release_solver or it > 0:  # the caller's solver, or one made here
            solver.release()
        solver = MixedIntegerSolver((Kw.T @ Kw).tocsr(), integer, backend)
        g = Kw.T @ (sw * b)
        y = solver.rounded(g, batch=batch)
        if keep(y) > min(RUNAWAY_FACTOR * best + RUNAWAY_SLACK, worse):
            break  # the weights ran away: later rounds start from thousands of folds
    return best_y, w
