"""Nested-dissection ordering (fvf.ordering): a valid permutation that reduces fill."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import fvf
from fvf.numerics.ordering import nested_dissection


def _is_permutation(p, n):
    return p.dtype == np.int64 and np.array_equal(np.sort(p), np.arange(n))


def _grid_laplacian(k):
    T = sp.diags_array([-np.ones(k - 1), 2 * np.ones(k), -np.ones(k - 1)], offsets=[-1, 0, 1])
    I = sp.eye_array(k)
    return (sp.kron(T, I) + sp.kron(I, T)).tocsc()


def _factor_nnz(K, perm=None):
    if perm is not None:
        K = sp.csc_array(K)[perm][:, perm]
    spec = "NATURAL"
    lu = spla.splu(
        sp.csc_matrix(K), permc_spec=spec, diag_pivot_thresh=0.0, options=dict(SymmetricMode=True)
    )
    return lu.L.nnz + lu.U.nnz


@pytest.mark.parametrize("n", [0, 1, 5])
def test_tiny_and_diagonal(n):
    assert _is_permutation(nested_dissection(sp.eye_array(n, format="csr")), n)


def test_disconnected_and_leafless():
    L = fvf.stiffness(fvf.icosphere(3))
    two = sp.block_diag([L, L, sp.eye_array(7)], format="csr")  # two spheres + 7 isolated
    for leaf in (2, 16, 10_000):
        assert _is_permutation(nested_dissection(two, leaf_size=leaf), two.shape[0])


def test_fill_on_a_grid_is_far_below_a_random_order_and_near_minimum_degree(rng):
    K = _grid_laplacian(80)  # 6400 unknowns, 5-point stencil
    n = K.shape[0]
    nd = _factor_nnz(K, nested_dissection(K))
    random = _factor_nnz(K, rng.permutation(n))
    mmd = spla.splu(
        sp.csc_matrix(K),
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options=dict(SymmetricMode=True),
    )
    mmd = mmd.L.nnz + mmd.U.nnz
    assert nd < 0.2 * random
    assert nd < 1.5 * mmd


def test_twins_stay_together():
    """Unknowns with equal neighbourhoods (two per node here) are eliminated together."""
    L = fvf.stiffness(fvf.icosphere(2))
    K = sp.kron(L, np.array([[2.0, 1.0], [1.0, 2.0]]), format="csr")
    p = nested_dissection(K)
    assert _is_permutation(p, K.shape[0])
    assert np.all(p[0::2] // 2 == p[1::2] // 2)
    # non-adjacent twins (same open neighbourhood), as in a real connection Laplacian:
    # diagonal blocks d I, off-diagonal blocks dense 2 x 2 rotations
    D = sp.diags_array(L.diagonal())
    K0 = (sp.kron(L - D, np.array([[0.6, -0.8], [0.8, 0.6]])) + sp.kron(D, np.eye(2))).tocsr()
    p0 = nested_dissection(K0)
    assert np.all(p0[0::2] // 2 == p0[1::2] // 2)


def test_rejects_non_square():
    with pytest.raises(ValueError, match="square"):
        nested_dissection(sp.random_array((3, 4), density=0.5, random_state=0))
