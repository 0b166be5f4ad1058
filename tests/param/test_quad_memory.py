"""Memory of the quad pipeline's large stages: the dense blocks they form are bounded by a
few columns or a chunk of points, with the results of forming them all at once."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import scipy.sparse as sp

import fvf
from fvf.numerics.cholesky import available_backends, factor_hermitian
from fvf.param import quad_folds, quad_validity, quality, rounding
from fvf.param.extraction import extract_quads
from fvf.param.rounding import SOLVE_COLUMNS, MixedIntegerSolver, solved_columns
from fvf.param.uv_folds import _Responses
from test_quads import torus_uv


def _grid_laplacian(n: int) -> sp.csr_array:
    """The 5-point Laplacian of an n × n grid plus a small shift: SPD, (n², n²)."""
    d = sp.diags_array([-1.0, 2.0, -1.0], offsets=[-1, 0, 1], shape=(n, n))
    eye = sp.eye_array(n)
    return sp.csr_array(sp.kron(d, eye) + sp.kron(eye, d) + 1e-3 * sp.eye_array(n * n))


@pytest.mark.parametrize("backend", list(available_backends()))
@pytest.mark.parametrize("width", [1, 6, 33, 35])
def test_solved_columns_equal_one_solve_of_the_whole_block(backend, width):
    """Groups of SOLVE_COLUMNS (a multiple of the 4 right-hand sides CHOLMOD's solves take
    together) give every column bit for bit what one solve of the block gives: splitting
    the block changes the memory, not the quads."""
    assert SOLVE_COLUMNS % 4 == 0
    K = _grid_laplacian(40)
    fac = factor_hermitian(K, backend)
    rng = np.random.default_rng(3)
    B = sp.random_array((K.shape[0], width), density=0.02, rng=rng, format="csc")
    whole = fac.solve(B.toarray())
    got = np.empty_like(whole)
    widths = []
    for cols, X in solved_columns(fac, B):
        got[:, cols] = X
        widths.append(X.shape[1])
    assert max(widths) <= SOLVE_COLUMNS and sum(widths) == width
    np.testing.assert_array_equal(got, whole)


def test_response_columns_are_formed_a_few_at_a_time(monkeypatch):
    """_Responses.columns never passes more than SOLVE_COLUMNS right-hand sides to the
    factor, however wide its block, and its peak numpy memory stays near a few dense
    columns of 4m rows (it held the block's width twice: 33 columns of 3·10⁶ rows at 750k
    faces, 1.6 GB)."""
    rng = np.random.default_rng(5)
    n = 60  # grid unknowns: a fit y ↦ gradient rows, 2 n (n − 1) of them plus y itself
    d = sp.diags_array([-1.0, 1.0], offsets=[0, 1], shape=(n - 1, n))
    eye = sp.eye_array(n)
    K = sp.csr_array(sp.vstack([sp.kron(d, eye), sp.kron(eye, d), 0.05 * sp.eye_array(n * n)]))
    integer = np.sort(rng.choice(n * n, size=40, replace=False))
    solver = MixedIntegerSolver((K.T @ K).tocsr(), integer, backend="auto")
    wide = _Responses(solver, K)
    assert wide._block >= 40  # one block of all the columns
    cols = wide.columns(np.arange(40))
    monkeypatch.setattr(rounding, "SOLVE_COLUMNS", 40)  # the block solved at once
    once = _Responses(solver, K).columns(np.arange(40))
    for (i, v), (j, w) in zip(cols, once, strict=True):
        np.testing.assert_array_equal(i, j)
        np.testing.assert_array_equal(v, w)
    monkeypatch.undo()

    widths = []
    solve = solver.fac.solve
    monkeypatch.setattr(solver.fac, "solve", lambda B: widths.append(B.shape[1]) or solve(B))
    resp = _Responses(solver, K)
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        resp.columns(np.arange(40))
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert max(widths) <= SOLVE_COLUMNS
    kept = sum(i.nbytes + v.nbytes for i, v in resp._cols.values())
    dense = 8 * SOLVE_COLUMNS * (K.shape[0] + K.shape[1])  # R and Z of one group
    assert peak <= kept + 4 * dense, (peak, kept, dense)


def test_surface_samples_in_chunks_are_the_same_points(monkeypatch):
    """surface_samples samples the triangle sides SIDE_CHUNK at a time: the same points,
    and a peak of about twice the result (the pieces and their concatenation), not the
    five dense (p, 3) temporaries of sampling every side at once."""
    mesh = fvf.torus(96, 48)
    step = 0.25 * mesh.mean_edge_length
    whole = quality.surface_samples(mesh.vertices, mesh.faces, step)
    monkeypatch.setattr(quality, "SIDE_CHUNK", 1000)
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        parts = quality.surface_samples(mesh.vertices, mesh.faces, step)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(parts, whole)
    assert peak <= 2.5 * whole.nbytes, peak / whole.nbytes


def test_hausdorff_with_chunked_queries_is_unchanged(monkeypatch):
    """The gate's Hausdorff distance, one tree at a time and queries in chunks, equals
    both trees queried at once."""
    mesh = fvf.torus(48, 24)
    qm = extract_quads(mesh, torus_uv(mesh, 12, 6, (0.3, 0.2)))
    V, Q = qm.vertices, qm.quads
    edge = float(np.linalg.norm(V[Q] - V[np.roll(Q, -1, axis=1)], axis=2).mean())
    step = quality.HAUSDORFF_STEP * edge
    tris = np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]])
    a = quality.surface_samples(V, tris, step)
    b = quality.surface_samples(mesh.vertices, mesh.faces, step)
    from scipy.spatial import cKDTree

    expected = max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max()) / edge
    monkeypatch.setattr(quality, "QUERY_CHUNK", 777)
    assert quad_validity.check_quad_mesh(mesh, V, Q).hausdorff == expected


def test_reference_normals_in_chunks_of_quads_are_unchanged(monkeypatch):
    """N_q gathered BALL_CHUNK quads at a time equals all quads at once (the samples
    within each quad's radius are Python lists: at 20,000 quads on 750k faces they took
    0.7 GB together)."""
    mesh = fvf.torus(48, 24)
    qm = extract_quads(mesh, torus_uv(mesh, 12, 6, (0.3, 0.2)))
    tree = quad_folds.cKDTree(mesh.face_centroids)
    whole = quad_folds.reference_normals(mesh, qm.vertices, qm.quads, tree)
    monkeypatch.setattr(quad_folds, "BALL_CHUNK", 7)
    parts = quad_folds.reference_normals(mesh, qm.vertices, qm.quads, tree)
    np.testing.assert_array_equal(parts, whole)
