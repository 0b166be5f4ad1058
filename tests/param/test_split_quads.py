"""Quads split from triangles (fvf.param.split_quads) and ``fvf.quad_mesh(fallback="split")``,
judged by the independent checker (tests/param/quadcheck.py)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fvf
import quadcheck
from fvf.param.split_quads import subdivided_for_split, triangle_quads


def _open_disk() -> fvf.TriMesh:
    """The icosphere's lower half: one boundary loop."""
    s = fvf.icosphere(2)
    keep = s.face_centroids[:, 2] < 0.1
    V, F = fvf.remove_unreferenced_vertices(s.vertices, s.faces[keep])[:2]
    return fvf.TriMesh(V, F)


@pytest.mark.parametrize("name", ["sphere", "torus", "disk"])
def test_three_quads_per_triangle_are_the_surface_itself(name):
    mesh = {"sphere": fvf.icosphere(1), "torus": fvf.torus(10, 6), "disk": _open_disk()}[name]
    V, Q, vf = triangle_quads(mesh)
    n, E, m = mesh.n_vertices, mesh.n_edges, mesh.n_faces
    assert V.shape == (n + E + m, 3) and Q.shape == (3 * m, 4)
    verdict = quadcheck.check(mesh.vertices, mesh.faces, V, Q)
    assert verdict.valid, verdict.reasons
    # each quad in its triangle's plane, counter-clockwise about its normal
    normals = np.cross(V[Q[:, 2]] - V[Q[:, 0]], V[Q[:, 3]] - V[Q[:, 1]])
    own = mesh.face_normals[np.repeat(np.arange(m), 3)]
    cos = np.einsum("qd,qd->q", normals, own) / np.linalg.norm(normals, axis=1)
    np.testing.assert_allclose(cos, 1.0, atol=1e-12)
    # every quad vertex lies on the triangle vertex_faces names
    T = mesh.vertices[mesh.faces[vf]]
    height = np.einsum("kd,kd->k", V - T[:, 0], mesh.face_normals[vf])
    np.testing.assert_allclose(height, 0.0, atol=1e-12)


def test_subdivision_brings_the_quads_closest_to_the_count_asked():
    mesh = fvf.icosphere(1)  # 80 triangles: 240, 960, 3,840, 15,360 quads at k = 0..3
    for asked, quads in ((200, 240), (1000, 960), (2000, 3840), (10_000, 15_360)):
        h = np.sqrt(mesh.total_area / asked)
        surface, parent = subdivided_for_split(mesh, h)
        assert 3 * surface.n_faces == quads
        # each new triangle lies in its parent
        c = surface.face_centroids
        T = mesh.vertices[mesh.faces[parent]]
        d = np.einsum("kd,kd->k", c - T[:, 0], mesh.face_normals[parent])
        np.testing.assert_allclose(d, 0.0, atol=1e-12)


def test_a_split_component_next_to_an_aligned_one(monkeypatch):
    """Two spheres, the second's attempts made to fail: with fallback="split" it is split
    from triangles (a warning says so), the first aligned; one valid mesh. With the
    default, the error, whose advice names the fallback."""
    import fvf.param.quadmesh as qm

    a, b = fvf.icosphere(2), fvf.icosphere(2)
    V = np.concatenate([a.vertices, b.vertices + [3.0, 0.0, 0.0]])
    F = np.concatenate([a.faces, b.faces + a.n_vertices])
    mesh = fvf.TriMesh(V, F)
    real = qm._mesh_closures

    def failing(part, *args):
        if part.label == 1:
            raise fvf.QuadMeshError("planted failure", attempts=("planted",))
        return real(part, *args)

    monkeypatch.setattr(qm, "_mesh_closures", failing)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        made = fvf.quad_mesh(mesh, target_faces=400, fallback="split")
    said = [w for w in caught if issubclass(w.category, fvf.QuadFallbackWarning)]
    assert len(said) == 1 and "component 1" in str(said[0].message)
    verdict = quadcheck.check(V, F, made.vertices, made.quads)
    assert verdict.valid, verdict.reasons
    assert made.split_components.tolist() == [1]
    assert made.parameterizations[0] is not None and made.parameterizations[1] is None
    assert "split from triangles" in made.summary()
    assert made.attempts[-1].startswith("component 1: fallback")
    with pytest.raises(fvf.QuadMeshError, match="planted"):
        fvf.quad_mesh(mesh, target_faces=400)  # the default: the error
    assert "fallback='split'" in qm._advice({"remesher": "pymeshlab"})


def test_fallback_is_checked():
    with pytest.raises(fvf.ParameterError, match="fallback"):
        fvf.quad_mesh(fvf.icosphere(1), target_faces=50, fallback="triangles")


def test_the_command_writes_the_split_component(monkeypatch, tmp_path, capsys):
    import fvf.param.quadmesh as qm
    from fvf.cli.main import main
    from fvf.io.meshfile import read_quad_mesh

    s = fvf.icosphere(2)
    src = tmp_path / "sphere.obj"
    fvf.write_mesh(src, s.vertices, s.faces)

    def failing(part, *args):
        raise fvf.QuadMeshError("planted failure", attempts=("planted",))

    monkeypatch.setattr(qm, "_mesh_closures", failing)
    out = tmp_path / "q.obj"
    assert main(["quad", str(src), "--faces", "200", "-o", str(out)]) == 4
    assert not out.exists()
    uv = tmp_path / "uv.obj"
    split = ["--fallback", "split", "--uv", str(uv)]
    assert main(["quad", str(src), "--faces", "200", *split, "-o", str(out)]) == 0
    printed = capsys.readouterr()
    assert "split from triangles" in printed.out and "not written" in printed.err
    assert not uv.exists()
    V, Q = read_quad_mesh(out)
    assert quadcheck.check(s.vertices, s.faces, V, np.asarray(Q)).valid


@pytest.mark.slow
def test_a_knife_edged_boolean_is_valid_with_the_fallback(tmp_path):
    """Part 19 of ``benchmarks/random_parts.py --family mixed`` (a second part of knife
    edges 0.2-0.6 quad edges thick, left by intersecting a thin plate) as ``fvf quad``
    reads its STL soup: every attempt on that part fails (the typed error by default);
    with fallback="split" it is split from triangles and the other part aligned, one mesh
    valid by quadcheck (about 9 s)."""
    pytest.importorskip("manifold3d")
    from conftest import import_benchmark

    parts = import_benchmark("random_parts")
    solid, _ = parts.mixed(19)
    m = solid.to_mesh()
    V = np.asarray(m.vert_properties, np.float64)[:, :3]
    F = np.asarray(m.tri_verts, np.int64)
    with warnings.catch_warnings():  # the STL soup's weld, said and expected
        warnings.simplefilter("ignore", fvf.VerticesWeldedWarning)
        V, F = parts._through_stl(V, F, tmp_path / "part19.stl")
    with pytest.warns(fvf.QuadFallbackWarning, match="component 1"):
        made = fvf.quad_mesh(fvf.TriMesh(V, F), target_faces=2000, fallback="split")
    assert made.split_components.tolist() == [1]
    verdict = quadcheck.check(V, F, made.vertices, made.quads)
    assert verdict.valid, verdict.reasons


def test_the_gate_refuses_two_corners_at_one_point():
    """A quad whose distinct vertices lie at one point is degenerate: the gate says so (as
    the independent checker does), and a split fallback on triangles too thin to split
    into distinct points ends in the error, not in a mesh."""
    from fvf.param.quad_validity import check_quad_mesh

    mesh = fvf.icosphere(1)
    V, Q, _ = triangle_quads(mesh)
    assert check_quad_mesh(mesh, V, Q).valid
    W = V.copy()
    W[Q[0, 1]] = W[Q[0, 0]]  # two corners of quad 0 at one point
    verdict = check_quad_mesh(mesh, W, Q)
    assert not verdict.valid and "two corners at one point" in str(verdict)
    assert not quadcheck.check(mesh.vertices, mesh.faces, W, Q).valid


def test_a_split_fallback_on_a_needle_triangle_is_the_error(monkeypatch):
    import fvf.param.quadmesh as qm

    s = fvf.icosphere(2)
    a, b, c = s.faces[0]
    V = s.vertices.copy()
    mid = 0.5 * (V[b] + V[c])
    side = (V[c] - V[b]) / np.linalg.norm(V[c] - V[b])
    up = V[a] - mid - ((V[a] - mid) @ side) * side
    V[a] = mid + 2e-12 * up / np.linalg.norm(up)  # 1e-12 of the extent off its base

    def failing(part, *args):
        raise fvf.QuadMeshError("planted failure", attempts=("planted",))

    monkeypatch.setattr(qm, "_mesh_closures", failing)
    with pytest.raises(fvf.QuadMeshError, match="planted"):
        fvf.quad_mesh(fvf.TriMesh(V, s.faces), target_faces=400, fallback="split")


def test_a_split_result_says_it_has_no_parameterization(monkeypatch):
    import fvf.param.quadmesh as qm

    def failing(part, *args):
        raise fvf.QuadMeshError("planted failure", attempts=("planted",))

    monkeypatch.setattr(qm, "_mesh_closures", failing)
    with pytest.warns(fvf.QuadFallbackWarning):
        made = fvf.quad_mesh(fvf.icosphere(1), target_faces=100, fallback="split")
    with pytest.raises(fvf.ParameterError, match="no parameterization"):
        _ = made.parameterization
    with (
        pytest.warns(fvf.QuadFallbackWarning),
        pytest.warns(DeprecationWarning),
        pytest.raises(fvf.ParameterError, match="split"),
    ):
        fvf.quad_mesh(
            fvf.icosphere(1), target_faces=100, fallback="split", return_parameterization=True
        )
