"""Pieces of the integer rounding (fvf.param.rounding) and of the fold repair after it
(fvf.param.uv_folds), against dense references."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fvf.param.rounding import MixedIntegerSolver
from fvf.param.uv_folds import _Responses, face_distortion, flip_count, integer_moves


def test_face_distortion_is_the_singular_values_of_j_f_inverse():
    rng = np.random.default_rng(7)
    J = rng.standard_normal((500, 2, 2))
    F = rng.standard_normal((500, 2, 2))
    J[0] = F[0]  # no distortion
    J[1] = 2.0 * F[1]  # both singular values 2
    J[2] = np.array([[0.0, 1.0], [1.0, 0.0]]) @ F[2]  # a reflection: isometric, flipped
    sv = np.linalg.svd(J @ np.linalg.inv(F), compute_uv=False)
    expected = np.abs(sv - 1.0).sum(axis=1)
    got = face_distortion(J.ravel(), F.ravel())
    np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(got[:3], [0.0, 2.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("block", [None, 80])
def test_responses_rows_and_columns_equal_the_dense_response_matrix(block, monkeypatch):
    """R = K_i − K_r H_rr⁻¹ H_ri with H = KᵀK: rows (adjoint solves) and columns (direct
    solves, small entries dropped) both equal the dense matrix, also when the solves go in
    blocks of bounded memory (block=80 entries: two right-hand sides of 36 unknowns)."""
    from fvf.param import uv_folds as folds

    if block is not None:
        monkeypatch.setattr(folds, "SCHUR_BLOCK_ENTRIES", block)
    rng = np.random.default_rng(11)
    rows, p = 120, 40
    K = sp.random_array((rows, p), density=0.15, rng=rng, format="csr") + sp.eye_array(
        rows, p, format="csr"
    )
    K = sp.csr_array(K)
    integer = np.array([3, 9, 17, 30])
    solver = MixedIntegerSolver((K.T @ K).tocsr(), integer, backend="scipy")
    Kd = K.toarray()
    real = solver.real_idx
    H = Kd.T @ Kd
    R = Kd[:, integer] - Kd[:, real] @ np.linalg.solve(
        H[np.ix_(real, real)], H[np.ix_(real, integer)]
    )
    resp = _Responses(solver, K)
    picked = np.array([5, 77, 5, 119])
    np.testing.assert_allclose(resp.rows(picked), R[picked], atol=1e-10)
    for c, (idx, vals) in zip([2, 0], resp.columns(np.array([2, 0])), strict=True):
        kept = np.abs(R[:, c]) >= 1e-2 * np.abs(R[:, c]).max()
        np.testing.assert_array_equal(idx, np.flatnonzero(kept))
        np.testing.assert_allclose(vals, R[kept, c], atol=1e-10)


def test_moves_rank_candidates_on_a_bounded_set_of_flipped_faces(monkeypatch):
    """Rows of R cost four solves per face: a sweep ranks on at most MOVE_ROW_FACES flipped
    faces, those already solved first, then evenly spaced new ones (none when the known
    ones fill the budget); fewer flipped faces are all used."""
    from fvf.param import uv_folds as folds

    monkeypatch.setattr(folds, "MOVE_ROW_FACES", 5)
    rng = np.random.default_rng(3)
    K = sp.csr_array(sp.random_array((200, 30), density=0.2, rng=rng) + sp.eye_array(200, 30))
    solver = MixedIntegerSolver((K.T @ K).tocsr(), np.array([2, 7]), backend="scipy")
    R = _Responses(solver, K)
    bad = np.array([1, 4, 9, 16, 25, 36, 49])
    np.testing.assert_array_equal(folds._ranking_faces(bad[:5], R), bad[:5])
    np.testing.assert_array_equal(folds._ranking_faces(bad, R), [1, 9, 16, 25, 49])
    R.rows(np.array([16, 17, 18, 19, 36 * 4, 36 * 4 + 1]))  # face 4's rows and face 36's
    np.testing.assert_array_equal(folds._ranking_faces(bad, R), [1, 4, 16, 36, 49])
    R.rows((np.array([1, 9, 16, 25, 49])[:, None] * 4).ravel())
    np.testing.assert_array_equal(folds._ranking_faces(bad, R), [1, 4, 9, 16, 25, 36, 49])


def test_integer_moves_keep_the_real_unknowns_they_were_given():
    """Moves are chosen on the fit K y + R Δw of the y given (which need not minimize the
    solver's fit, e.g. after a local repair); the y returned has exactly that fit, its
    integers moved by Δw and its real unknowns changed by −H_rr⁻¹ H_ri Δw."""
    rng = np.random.default_rng(5)
    rows, p = 160, 48  # 40 faces of 4 rows
    K = sp.csr_array(
        sp.random_array((rows, p), density=0.2, rng=rng, format="csr")
        + sp.eye_array(rows, p, format="csr")
    )
    integer = np.array([2, 7, 11, 19, 23, 31])
    solver = MixedIntegerSolver((K.T @ K).tocsr(), integer, backend="scipy")
    b = rng.standard_normal(rows)
    g = K.T @ b
    y = solver.rounded(g, batch=0.05)
    y[solver.real_idx] += 0.3 * rng.standard_normal(solver.real_idx.size)  # not a minimizer
    out = integer_moves(solver, K, g, y)
    step = out[integer] - y[integer]
    assert np.count_nonzero(step) > 0 and np.array_equal(step, np.round(step))
    Kd, real = K.toarray(), solver.real_idx
    H = Kd.T @ Kd
    Z = np.linalg.solve(H[np.ix_(real, real)], H[np.ix_(real, integer)])
    np.testing.assert_allclose(out[real], y[real] - Z @ step, atol=1e-10)
    R = Kd[:, integer] - Kd[:, real] @ Z
    np.testing.assert_allclose(K @ out, K @ y + R @ step, atol=1e-10)
    assert flip_count(K @ out) < flip_count(K @ y)


def _lattice_reference(C, prefer):
    """integer_lattice's pivoting as first written: every statistic recomputed over all
    active rows at every step (dense, O(k² p)); the same choices, ties and arithmetic."""
    from fvf.param.rounding import _integer_kernel

    A = np.array(C, dtype=np.float64)
    k, p = A.shape
    pref = np.asarray(prefer, dtype=bool)
    active = np.ones(k, dtype=bool)
    pivots = []
    while True:
        rows = np.flatnonzero(active)
        if rows.size == 0:
            break
        sub = A[rows]
        nnz = (np.abs(sub) > 0.5).sum(axis=1)
        active[rows[nnz == 0]] = False
        unit = np.abs(np.abs(sub) - 1.0) < 1e-9
        r = c = -1
        for mask in (unit & pref[None, :], unit):
            has = mask.any(axis=1) & (nnz > 0)
            if has.any():
                cand = np.flatnonzero(has)
                i = cand[np.argmin(nnz[cand])]
                r, c = int(rows[i]), int(np.flatnonzero(mask[i])[0])
                break
        if r < 0:
            break
        A[r] /= A[r, c]
        others = np.flatnonzero(np.abs(A[:, c]) > 0.5)
        others = others[others != r]
        A[others] -= A[others, c][:, None] * A[r][None, :]
        pivots.append((r, c))
        active[r] = False
    free = np.setdiff1d(np.arange(p), [c for _, c in pivots])
    N = np.zeros((p, free.size))
    N[free, np.arange(free.size)] = 1.0
    for r, c in pivots:
        N[c] = -A[r, free]
    left = np.flatnonzero(active)
    if left.size:
        N = N @ _integer_kernel(np.round(A[left][:, free]).astype(np.int64))
    return np.round(N)


def test_integer_lattice_equals_the_dense_reference_and_spans_the_kernel():
    """Sparse constraint rows like the seams' (±1 entries, some rows with a 2: the parity
    conditions at ±1/4 cones): the same basis as the dense reference, C N = 0, N integer,
    and every small integer kernel vector is an integer combination of N's columns."""
    import itertools

    from fvf.param.rounding import integer_lattice

    rng = np.random.default_rng(3)
    for trial in range(40):
        k, p = (3, 6) if trial < 20 else (30, 48)
        C = np.zeros((k, p))
        for row in C:
            cols = rng.choice(p, size=rng.integers(2, 5), replace=False)
            row[cols] = rng.choice([-1.0, 1.0], size=cols.size)
            if rng.random() < 0.3:
                row[cols[0]] = 2.0 * np.sign(row[cols[0]])
        prefer = rng.random(p) < 0.5
        N = integer_lattice(C, prefer)
        np.testing.assert_array_equal(N, _lattice_reference(C, prefer))
        np.testing.assert_array_equal(integer_lattice(sp.csr_array(C), prefer), N)
        assert np.abs(C @ N).max() == 0 and np.array_equal(N, np.round(N))
        if p == 6:  # completeness, by enumeration of small kernel vectors
            for z in itertools.product(range(-2, 3), repeat=p):
                z = np.array(z, dtype=float)
                if np.abs(C @ z).max() == 0:
                    w = np.linalg.lstsq(N, z, rcond=None)[0]
                    assert np.allclose(N @ w, z) and np.allclose(w, np.round(w))


def test_integer_lattice_sums_the_duplicate_entries_of_a_sparse_input():
    from fvf.param.rounding import integer_lattice

    C = sp.csr_array((np.array([1.0, 1.0, -1.0]), np.array([0, 0, 1]), np.array([0, 3])), (1, 2))
    np.testing.assert_array_equal(integer_lattice(C), integer_lattice(np.array([[2.0, -1.0]])))


def test_integer_lattice_of_no_conditions_is_the_identity():
    from fvf.param.rounding import integer_lattice

    for C in (np.zeros((0, 3)), sp.csr_array((0, 3)), np.zeros((2, 3))):
        np.testing.assert_array_equal(integer_lattice(C), np.eye(3))


def test_a_released_solver_keeps_its_integers_and_cannot_solve():
    rng = np.random.default_rng(3)
    K = sp.csr_array(
        sp.random_array((80, 30), density=0.2, rng=rng, format="csr")
        + sp.eye_array(80, 30, format="csr")
    )
    solver = MixedIntegerSolver((K.T @ K).tocsr(), np.array([4, 12]), backend="scipy")
    S = solver.S.copy()
    solver.release()
    np.testing.assert_array_equal(solver.integer, [4, 12])
    np.testing.assert_array_equal(solver.S, S)
    with pytest.raises(AttributeError):
        solver.real(K.T @ rng.standard_normal(80))


def _fit_with_flips(m: int, flipped: int) -> np.ndarray:
    """A fit (4m,) whose first ``flipped`` faces have det ≤ 0 (rows s_x, s_y, t_x, t_y)."""
    J = np.tile([1.0, 0.0, 0.0, 1.0], (m, 1))
    J[:flipped, 3] = -1.0
    return J.ravel()


@pytest.mark.parametrize(
    ("first", "second", "roundings"),
    [(10, 32, 2), (10, 33, 1), (40, 40, 2), (40, 41, 1), (10, 105, 1)],
)
def test_repair_gives_up_after_a_rounding_worse_than_its_start(
    first, second, roundings, monkeypatch
):
    """A re-rounding of the stiffened fit that leaves more flips than the repair started
    with and more than WORSE_FLOOR (32) ends the repair: no later rounding is made. With
    the local steps doing nothing, the rounding counts are scripted."""
    from types import SimpleNamespace

    from fvf.param import uv_folds as folds

    assert folds.WORSE_FLOOR == 32
    m = 400
    made = []
    script = iter([second, 5, 5, 5, 5, 5, 5])

    class Solver:
        integer = real_idx = np.arange(0)

        def __init__(self, *args):
            made.append(1)

        def rounded(self, g, batch):
            return _fit_with_flips(m, next(script))

        def release(self):
            pass

    monkeypatch.setattr(folds, "MixedIntegerSolver", Solver)
    monkeypatch.setattr(folds, "local_repair", lambda mesh, K, real, y, b, w, backend: (y, w))
    monkeypatch.setattr(folds, "integer_moves", lambda solver, K, g, y: y)
    monkeypatch.setattr(folds, "stiffen", lambda mesh, w, fit, b: w)
    K = sp.eye_array(4 * m, format="csr")
    y0 = _fit_with_flips(m, first)
    best, _ = folds.repair_folds(SimpleNamespace(n_faces=m), K, Solver(), y0, y0, rounds=3)
    assert len(made) - 1 == roundings  # the caller's solver, then one per re-rounding
    assert flip_count(K @ best) == min(first, second, 5 if roundings > 1 else first)
