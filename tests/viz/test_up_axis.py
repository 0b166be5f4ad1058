"""The automatic up axis of pictures (fvf.viz.detect_up_axis): generated bodies and
four-legged animals and the shared scans, stored y-up, z-up and x-up."""

from __future__ import annotations

import numpy as np
import pytest

import fvf

viz = pytest.importorskip("fvf.viz")
scene = pytest.importorskip("fvf.viz.scene")
camera = pytest.importorskip("fvf.viz.camera")


def _ellipsoids(parts: list[tuple[tuple, tuple]]) -> tuple[np.ndarray, np.ndarray]:
    """Icosphere ellipsoids (centre, radii), one closed component each."""
    base = fvf.icosphere(2)
    V = np.vstack([base.vertices * np.array(r) + np.array(c) for c, r in parts])
    F = np.vstack([base.faces + i * base.n_vertices for i in range(len(parts))])
    return V, F


def body() -> tuple[np.ndarray, np.ndarray]:
    """A standing body, y-up, left-right along x: feet, legs, a trunk, arms, a head."""
    return _ellipsoids(
        [
            ((-0.14, 0.05, 0.05), (0.08, 0.05, 0.15)),
            ((0.14, 0.05, 0.05), (0.08, 0.05, 0.15)),
            ((-0.14, 0.5, 0.0), (0.1, 0.45, 0.1)),
            ((0.14, 0.5, 0.0), (0.1, 0.45, 0.1)),
            ((0.0, 1.3, 0.0), (0.3, 0.45, 0.16)),
            ((-0.42, 1.25, 0.0), (0.07, 0.4, 0.07)),
            ((0.42, 1.25, 0.0), (0.07, 0.4, 0.07)),
            ((0.0, 1.95, 0.02), (0.13, 0.16, 0.14)),
        ]
    )


def animal() -> tuple[np.ndarray, np.ndarray]:
    """A four-legged animal, y-up, facing +z, left-right along x: trunk, legs, neck, head."""
    legs = [((sx * 0.22, 0.3, sz * 0.6), (0.08, 0.32, 0.08)) for sx in (-1, 1) for sz in (-1, 1)]
    return _ellipsoids(
        [
            ((0.0, 0.8, 0.0), (0.3, 0.28, 0.85)),
            *legs,
            ((0.0, 1.1, 0.85), (0.1, 0.25, 0.1)),
            ((0.0, 1.3, 1.05), (0.12, 0.12, 0.22)),
        ]
    )


def stored(V: np.ndarray, up: str) -> np.ndarray:
    """The y-up points ``V`` turned so that ``up`` is up (proper rotations)."""
    x, y, z = V.T
    return {
        "y": V,
        "z": np.stack([x, -z, y], 1),  # about x
        "x": np.stack([y, -x, z], 1),  # about z: left-right along y
        "-x": np.stack([-y, x, z], 1),
    }[up]


def _centroid(V, F):
    mesh = fvf.TriMesh(V, F)
    return mesh, mesh.face_areas @ mesh.face_centroids / mesh.total_area


@pytest.mark.parametrize("shape", [body, animal])
@pytest.mark.parametrize("up", ["y", "z", "x", "-x"])
def test_generated_scans_are_found_upright(shape, up):
    V, F = shape()
    mesh, c = _centroid(stored(V, up), F)
    assert viz.detect_up_axis(mesh.vertices, c) == up
    assert scene.build_scene(mesh).views[0].up == up
    assert scene.build_scene(mesh, up="-y").views[0].up == "-y"  # up= overrides


def test_mirror_axis_is_the_left_right_axis():
    V, F = body()
    assert camera.mirror_axis(V) == 0
    assert camera.mirror_axis(stored(V, "x")) == 1
    assert camera.mirror_axis(fvf.icosphere(2).vertices) is None  # symmetric every way
    rng = np.random.default_rng(5)
    assert camera.mirror_axis(rng.standard_normal((500, 3)) * [1, 2, 3]) is None


@pytest.mark.parametrize(
    "name",
    ["spot.obj", "lion-00.off", "faust_r_tr_reg_001.off", "decimated-knight.off"],
)
def test_shared_scans_turned_x_up_are_found_x_up(name):
    from conftest import shared_mesh_path

    mesh = fvf.TriMesh(*fvf.read_mesh(shared_mesh_path(name)))
    c = mesh.face_areas @ mesh.face_centroids / mesh.total_area
    assert viz.detect_up_axis(mesh.vertices, c) == "y"
    for up in ("x", "-x", "z"):
        assert viz.detect_up_axis(stored(mesh.vertices, up), stored(c[None], up)[0]) == up


def test_an_x_up_body_is_drawn_standing(tmp_path):
    pytest.importorskip("matplotlib")
    Image = pytest.importorskip("PIL.Image")
    V, F = body()
    mesh = fvf.TriMesh(stored(V, "x"), F)
    info = viz.render(mesh, tmp_path / "b.png", size=(400, 400), backend="matplotlib")
    assert info.extra["up"] == "x"
    img = np.asarray(Image.open(info.path).convert("RGB")).astype(int)
    ys, xs = np.nonzero((img < 240).any(2))
    assert np.ptp(ys) > 1.5 * np.ptp(xs)


@pytest.mark.parametrize("legs", [(10.0, 10.0), (1.0, 1.0)])
def test_a_wedge_with_equal_legs_across_y_gets_an_up_axis(legs):
    """A CAD wedge 20 long on y, its right-triangle legs equal on x and z: mirror plane
    across y, and x and z tie for the thinnest extent (no candidate was left: a crash)."""
    a, b = legs
    tri = np.array([[0.0, 0.0], [a, 0.0], [0.0, b]])  # (x, z)
    V = np.array([[x, y, z] for y in (0.0, 20.0) for x, z in tri])
    assert camera.detect_up_axis(V) in ("y", "z", "x", "-x")
    cube = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
    assert camera.detect_up_axis(cube) in ("y", "z", "x", "-x")
