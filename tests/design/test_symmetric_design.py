"""Symmetric design end to end: fvf.symmetry_map's self-map drives the cross field, its
cones and the quad mesh (the chapter's Fig. 1), on a shape whose mirror symmetry is known
exactly."""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from corpus import REFLECT, blob, mirror_index


@pytest.fixture(scope="module")
def scene():
    """The exactly mirror-symmetric blob, its symmetry map, and a cross field made
    asymmetric by one soft constraint at the far +x end."""
    shape = blob(3, symmetric=True)
    sym = fvf.symmetry_map(shape, k=40, k_fit=15)
    far = int(np.argmax(shape.face_centroids[:, 0]))
    u = fvf.design_field(shape, [far], [[0.0, 0.6, 0.8]], n=4)
    return shape, sym, u


def _unmirrored_cones(mesh, u, pi) -> tuple[np.ndarray, np.ndarray]:
    """Cones of the cross field u whose mirror vertex pi[i] is not a cone of the same
    index: (all of them, those not straddling the mirror plane, i.e. pi[i] is not joined
    to i by an edge)."""
    ids, ind = fvf.singularities(mesh, u, n=4)
    index = np.zeros(mesh.n_vertices)
    index[ids] = ind
    odd = ids[index[pi[ids]] != index[ids]]
    E = np.sort(mesh.edges, axis=1)
    pairs = {(int(a), int(b)) for a, b in E}
    straddling = np.array([(min(i, pi[i]), max(i, pi[i])) in pairs for i in odd], dtype=bool)
    return odd, odd[~straddling]


def test_symmetry_map_makes_the_cross_field_and_its_cones_symmetric(scene):
    """After symmetrizing with symmetry_map's map, the field is its own mirror image to
    round-off, and every cone has a mirror cone of the same index, except where a cone
    sits on the mirror plane between two mirror vertices: the discrete index places it at
    one of the two (docs/quads.md, Symmetric quads)."""
    shape, sym, u = scene
    pi = sym.p2p
    assert np.array_equal(pi, mirror_index(shape))  # the map found is the mirror
    odd, far = _unmirrored_cones(shape, u, pi)
    assert far.size > 4  # the constrained field is not symmetric
    w = fvf.symmetrize_cross_field(shape, u, pi)
    back = fvf.symmetrize_cross_field(shape, w, pi, iterations=1)
    z, zb = shape.to_complex(w) ** 4, shape.to_complex(back) ** 4
    assert np.abs(z - zb).max() < 1e-9  # its push-forward is the same cross field
    odd, far = _unmirrored_cones(shape, w, pi)
    assert far.size == 0 and odd.size <= 2, odd


def test_symmetric_field_gives_more_symmetric_quads(scene):
    shape, sym, u = scene
    plain = fvf.quad_mesh(shape, target_faces=300, field=u)
    symmetric = fvf.quad_mesh(
        shape, target_faces=300, field=fvf.symmetrize_cross_field(shape, u, sym.p2p)
    )
    mirror = lambda P: P * REFLECT  # noqa: E731
    e_plain = fvf.quad_symmetry_error(plain[0], plain[1], mirror)
    e_sym = fvf.quad_symmetry_error(symmetric[0], symmetric[1], mirror)
    q = fvf.quad_quality(shape, symmetric[0], symmetric[1])
    assert q.closed and q.manifold and q.euler_characteristic == 2
    assert e_sym[0] < 0.8 * e_plain[0], (e_sym, e_plain)  # medians in quad edge lengths
