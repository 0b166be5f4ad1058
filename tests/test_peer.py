"""Instant Meshes as the reference remesher (fvf.peers): its typed errors, and its
quad count when the bench/test-only package is installed."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import fvf
from fvf.peers import has_instant_meshes, instant_meshes


@pytest.mark.parametrize("bad", [31, 100.0, True, "many"])
def test_bad_quad_count(bad):
    with pytest.raises(fvf.ParameterError, match="quads must be an integer >= 32"):
        instant_meshes(fvf.icosphere(2), bad)


def test_missing_package_is_a_typed_error_with_the_fix(monkeypatch):
    monkeypatch.setitem(sys.modules, "pynanoinstantmeshes", None)  # import fails
    assert not has_instant_meshes()
    with pytest.raises(fvf.MissingExtraError, match="pip install pynanoinstantmeshes"):
        instant_meshes(fvf.icosphere(2), 100)


def test_quads_near_the_count_asked_for():
    if not has_instant_meshes():
        pytest.skip("pynanoinstantmeshes is not installed (bench/test-only peer)")
    mesh = fvf.icosphere(4)
    V, Q = instant_meshes(mesh, 800)
    assert V.dtype == np.float64 and Q.dtype == np.int64 and Q.shape[1] == 4
    assert abs(Q.shape[0] - 800) <= 0.3 * 800
    q = fvf.quad_quality(mesh, V, Q)
    assert q.closed and q.manifold and q.euler_characteristic == 2
