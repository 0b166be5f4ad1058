"""A planted end-for-end turn: two quadrupeds of the generated SMAL-like set
(``benchmarks/smal_like.py``) on one small template, so that the true map is the identity.
One has a long neck, the other a long tail; the fit at 15 and its mirror turn the body
end for end (front legs on back legs, neck on tail), a map that keeps the orientation.
:func:`fvf.match` finds the right map from the start turned by mesh 1's turned self-map,
and the geodesic distortion γ ranks it first; the mirror fit finds a better one
(docs/correspondence.md, *Flips on near-symmetric shapes*).
"""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from conftest import import_benchmark

smal_like = import_benchmark("smal_like")

# Two species of the set (seed 0, species_04 and species_05, as in its species.json).
LONG_TAIL = {
    "elongation": 1.0997, "girth": 1.0636, "leg_length": 0.748, "leg_thickness": 1.1748,
    "front_back": 0.983, "neck_length": 1.0589, "head_size": 0.7588, "ear_size": 0.8202,
    "tail_length": 1.6447, "neck_pitch": -23.8498, "neck_yaw": 4.4307, "head_pitch": 4.1606,
    "tail_pitch": 26.4082, "tail_yaw": 1.389, "front_left_swing": -9.1279,
    "front_left_splay": 1.8438, "front_left_knee": 14.7583, "front_right_swing": 8.6824,
    "front_right_splay": 2.7928, "front_right_knee": 15.9349, "back_left_swing": 17.2413,
    "back_left_splay": 0.1637, "back_left_knee": 21.3599, "back_right_swing": -1.8546,
    "back_right_splay": -1.3646, "back_right_knee": 0.704,
}  # fmt: skip
LONG_NECK = {
    "elongation": 0.9611, "girth": 1.0658, "leg_length": 0.9964, "leg_thickness": 1.1157,
    "front_back": 0.9743, "neck_length": 1.5915, "head_size": 0.972, "ear_size": 1.0124,
    "tail_length": 0.9123, "neck_pitch": -12.3993, "neck_yaw": -15.5838,
    "head_pitch": -12.4535, "tail_pitch": 12.1116, "tail_yaw": 3.0752,
    "front_left_swing": -16.1385, "front_left_splay": -2.1891, "front_left_knee": 14.5471,
    "front_right_swing": -21.0389, "front_right_splay": -0.442, "front_right_knee": 3.7858,
    "back_left_swing": -11.2339, "back_left_splay": -2.3979, "back_left_knee": 20.7015,
    "back_right_swing": 7.4419, "back_right_splay": 2.4889, "back_right_knee": 12.9945,
}  # fmt: skip


@pytest.fixture(scope="module")
def pair():
    pytest.importorskip("manifold3d")
    pytest.importorskip("pymeshlab")
    T, F = smal_like.template(1500)
    return fvf.TriMesh(smal_like.deform(T, LONG_TAIL), F), fvf.TriMesh(
        smal_like.deform(T, LONG_NECK), F
    )


def test_end_for_end_turn_is_undone(pair, monkeypatch):
    """The turned start reaches the right map (measured mean error 0.089), and the
    mirror fit a better one (0.027, the tail on the tail), into whose basin the turned
    start then falls; with the mirror fit's columns emptied (the plain fit again), the
    turned start is chosen."""
    from fvf.spectral import correspondence

    mesh_1, mesh_2 = pair
    truth = np.arange(mesh_2.n_vertices)  # one template: vertex i is vertex i
    plain = fvf.match(mesh_1, mesh_2, k=80, check_symmetry=False)
    assert fvf.mean_geodesic_error(mesh_1, plain, truth) > 0.3  # the fit alone: turned
    result = fvf.match_result(mesh_1, mesh_2, k=80)
    assert fvf.mean_geodesic_error(mesh_1, result.p2p_21, truth) < 0.05
    assert [c.name for c in result.alternatives if c.chosen] == ["mirror fit"]
    monkeypatch.setattr(
        correspondence, "mirror_descriptors", lambda basis, s: np.zeros((s.size, 0))
    )
    result = fvf.match_result(mesh_1, mesh_2, k=80)
    assert fvf.mean_geodesic_error(mesh_1, result.p2p_21, truth) < 0.15
    chosen = [c for c in result.alternatives if c.chosen]
    assert [c.name for c in chosen] == ["fit∘turn"]
    # γ is what separates them: the turned body is far from an isometry.
    others = [c.geodesic_distortion for c in result.alternatives if not c.chosen]
    assert chosen[0].geodesic_distortion < 0.8 * min(others)
