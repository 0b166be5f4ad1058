"""The distance to the mirror image (:func:`fvf.spectral.descriptors.mirror_distance`) and
the mirror fit of :func:`fvf.match` (docs/correspondence.md, *Flips on near-symmetric
shapes*).

A tail can be shaped like a lower leg; the kernel signatures then cannot tell them apart,
but the distance from a point to its own mirror image can: about 0 on the plane of
symmetry (a tail), large on a leg (the other leg is far). Planted: two quadrupeds of the
generated SMAL-like set on one small template (the true map is the identity), where the
fits without it send the tail to a front leg and a front leg to the tail.
"""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from conftest import import_benchmark
from fvf.spectral import candidates, correspondence
from fvf.spectral.descriptors import mirror_distance
from test_correspondence_flips import near_symmetric_body
from test_correspondence_turn import LONG_TAIL

smal_like = import_benchmark("smal_like")

# species_02 of the SMAL-like set, seed 0 (its species.json): long legs, long neck.
LONG_LEGS = {
    "elongation": 0.9263, "girth": 1.1557, "leg_length": 1.3452, "leg_thickness": 0.9296,
    "front_back": 0.9729, "neck_length": 1.4101, "head_size": 0.778, "ear_size": 0.9773,
    "tail_length": 1.4189, "neck_pitch": 9.176, "neck_yaw": 6.4036, "head_pitch": -16.9958,
    "tail_pitch": -7.9279, "tail_yaw": 10.7495, "front_left_swing": 21.002,
    "front_left_splay": 0.0326, "front_left_knee": 16.717, "front_right_swing": 15.919,
    "front_right_splay": -2.6147, "front_right_knee": 19.8431, "back_left_swing": -11.5123,
    "back_left_splay": -0.605, "back_left_knee": 18.1297, "back_right_swing": -11.945,
    "back_right_splay": 0.9193, "back_right_knee": 8.574,
}  # fmt: skip


@pytest.fixture(scope="module")
def symmetric():
    """The exactly symmetric body (about x = 0) and its mirror map, int64 (n,)."""
    from scipy.spatial import cKDTree

    mesh = near_symmetric_body(asym=0.0)
    X = mesh.vertices
    d, sigma = cKDTree(X).query(X * np.array([-1.0, 1.0, 1.0]))
    assert d.max() < 1e-9  # the icosphere is symmetric about x = 0 vertex for vertex
    basis = fvf.SpectralBasis(mesh, 40)
    return mesh, basis, sigma.astype(np.int64)


def test_mirror_distance_is_zero_on_the_plane_and_symmetric(symmetric):
    mesh, basis, sigma = symmetric
    m = mirror_distance(basis, sigma)
    x = mesh.vertices[:, 0]
    on_plane = sigma == np.arange(mesh.n_vertices)
    assert on_plane.sum() > 10 and np.all(np.abs(x[on_plane]) < 1e-12)
    assert np.all(m[on_plane] == 0.0)
    assert np.all(m[~on_plane] > 0.0)
    np.testing.assert_allclose(m[sigma], m, rtol=1e-12, atol=0)  # d(σx, x) = d(x, σx)
    # it grows with the distance from the plane: rank correlation with |x|
    rank = np.argsort(np.argsort(m)), np.argsort(np.argsort(np.abs(x)))
    assert np.corrcoef(*rank)[0, 1] > 0.95


def test_mirror_distance_is_the_biharmonic_distance(symmetric):
    """Against the sum written out with every term, from the eigenpairs directly."""
    mesh, basis, sigma = symmetric
    lam, phi = basis.eigenvalues[1:30], basis.eigenvectors[:, 1:30]
    i = np.arange(0, mesh.n_vertices, 37)
    want = [
        np.sqrt(sum((phi[v, j] - phi[sigma[v], j]) ** 2 / lam[j] ** 2 for j in range(29)))
        for v in i
    ]
    np.testing.assert_allclose(mirror_distance(basis, sigma, k=30)[i], want, rtol=1e-12)


@pytest.mark.parametrize(
    "bad, match",
    [(np.zeros(5, np.int64), r"shape \(642,\)"), (np.full(642, 0.5), "integer array")],
)
def test_mirror_distance_rejects_a_map_of_another_shape(symmetric, bad, match):
    with pytest.raises(fvf.FieldShapeError, match=match):
        mirror_distance(symmetric[1], bad)


def test_mirror_distance_names_images_off_the_mesh(symmetric):
    sigma = symmetric[2].copy()
    sigma[[3, 9]] = [-1, 642]
    with pytest.raises(fvf.FieldShapeError, match=r"entries at \[3, 9\]"):
        mirror_distance(symmetric[1], sigma)


def test_mirror_fit_runs_only_when_the_first_choice_is_not_decisive(monkeypatch, symmetric):
    """Both meshes' mirror columns are built for an undecided pair (the exact tie of
    the symmetric body with its mirror image), none for a decisive one (a body with
    itself)."""
    calls = []
    real = candidates.mirror_descriptors

    def spy(basis, sigma):
        calls.append(basis.mesh.n_vertices)
        return real(basis, sigma)

    monkeypatch.setattr(correspondence, "mirror_descriptors", spy)
    mesh = near_symmetric_body(asym=0.05)
    res = fvf.match_result(mesh, mesh, k=40, k_fit=15)
    assert res.confidence >= candidates.DECISIVE_CONFIDENCE and calls == []
    from corpus import mirror_image

    S = symmetric[0]
    res = fvf.match_result(S, mirror_image(S), k=40, k_fit=15)
    assert res.confidence < candidates.DECISIVE_CONFIDENCE
    assert calls == [S.n_vertices, S.n_vertices]


@pytest.fixture(scope="module")
def quadrupeds():
    pytest.importorskip("manifold3d")
    pytest.importorskip("pymeshlab")
    T, F = smal_like.template(1500)
    labels = smal_like.part_distances(T).argmin(axis=1)  # the part each vertex is on
    mesh_1 = fvf.TriMesh(smal_like.deform(T, LONG_LEGS), F)
    return mesh_1, fvf.TriMesh(smal_like.deform(T, LONG_TAIL), F), labels


def _part_images(labels: np.ndarray, p2p: np.ndarray) -> list[tuple[str, str, float]]:
    """For each template part: the part where most of its vertices land, and how many."""
    names = [p.name for p in smal_like.PARTS]
    out = []
    for j, name in enumerate(names):
        hits = np.bincount(labels[p2p[labels == j]], minlength=len(names))
        out.append((name, names[int(hits.argmax())], hits.max() / hits.sum()))
    return out


def test_tail_and_legs_are_not_swapped(quadrupeds, monkeypatch):
    """With the mirror fit every part lands mostly on itself (measured 0.75-1.00 of its
    vertices; mean error 0.060). Without it (its columns emptied, so that it is the plain
    fit again) the tail goes to the front right lower leg and the front left lower leg
    to the tail (mean error 0.21)."""
    mesh_1, mesh_2, labels = quadrupeds
    truth = np.arange(mesh_2.n_vertices)
    result = fvf.match_result(mesh_1, mesh_2, k=80)
    assert fvf.mean_geodesic_error(mesh_1, result.p2p_21, truth) < 0.1
    assert [c.name for c in result.alternatives if c.chosen] == ["mirror fit"]
    for part, image, share in _part_images(labels, result.p2p_21):
        assert image == part and share > 0.7, (part, image, share)
    monkeypatch.setattr(
        correspondence, "mirror_descriptors", lambda basis, s: np.zeros((s.size, 0))
    )
    without = fvf.match_result(mesh_1, mesh_2, k=80)
    assert fvf.mean_geodesic_error(mesh_1, without.p2p_21, truth) > 0.15
    images = {part: image for part, image, _ in _part_images(labels, without.p2p_21)}
    assert images["tail"] != "tail" and images["front_left_lower"] == "tail"
