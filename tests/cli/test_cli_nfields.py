"""The fvf command with N-direction fields: design --n/--align and render --n."""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from fvf.cli.main import main


@pytest.fixture
def torus_file(tmp_path):
    mesh = fvf.torus(24, 12)
    path = tmp_path / "torus.obj"
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    return mesh, path


def test_design_cross_field_aligned(torus_file, tmp_path, capsys):
    mesh, path = torus_file
    out = tmp_path / "cross.npz"
    assert main(["design", str(path), "--n", "4", "--align", "curvature", "-o", str(out)]) == 0
    with np.load(out) as d:
        v, n, ind = d["v"], int(d["n"]), d["singularity_indices"]
    assert n == 4 and v.shape == (mesh.n_faces, 3) and ind.size == 0
    np.testing.assert_allclose(v, fvf.design_field(mesh, n=4, align="curvature"), atol=1e-12)
    assert "singularities: 0" in capsys.readouterr().out


def test_design_smoothest_cross_on_sphere_and_vector_default(tmp_path):
    mesh = fvf.icosphere(3)
    path = tmp_path / "s.obj"
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    assert main(["design", str(path), "--n", "4", "-o", str(tmp_path / "c.npz")]) == 0
    with np.load(tmp_path / "c.npz") as d:
        np.testing.assert_array_equal(d["singularity_indices"], np.full(8, 0.25))
    assert main(["design", str(path), "-o", str(tmp_path / "v.npz")]) == 0
    with np.load(tmp_path / "v.npz") as d:
        assert "n" not in d and d["singularity_indices"].dtype.kind == "i"
        assert d["singularity_indices"].sum() == 2


def test_design_with_curvature_smoothing(tmp_path, capsys):
    """--curvature-smoothing L is design_field(..., curvature_smoothing=L); on a flat-faced
    icosahedron it turns the 16 cones pinned to the 12 corners into a sphere's 8."""
    from fvf.mesh.shapes import _icosahedron, midpoint_subdivision

    X, F = _icosahedron()
    for _ in range(3):
        X, F = midpoint_subdivision(X, F)
    mesh = fvf.TriMesh(X, F)
    path = tmp_path / "ico.obj"
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    ell = 3 * mesh.mean_edge_length
    out = tmp_path / "c.npz"
    args = ["design", str(path), "--n", "4", "--curvature-smoothing", repr(ell), "-o", str(out)]
    assert main(args) == 0
    with np.load(out) as d:
        np.testing.assert_array_equal(d["singularity_indices"], np.full(8, 0.25))
        expected = fvf.design_field(fvf.TriMesh(*fvf.read_mesh(path)), n=4, curvature_smoothing=ell)
        np.testing.assert_allclose(d["v"], expected, atol=1e-12)
    bad = ["design", str(path), "--n", "4", "--curvature-smoothing", "-1", "-o", str(out)]
    assert main(bad) != 0 and "curvature_smoothing" in capsys.readouterr().err


def test_design_bad_n_exits_with_input_error(torus_file, tmp_path, capsys):
    _, path = torus_file
    code = main(["design", str(path), "--n", "0", "-o", str(tmp_path / "x.npz")])
    assert code != 0 and "integer >= 1" in capsys.readouterr().err
    code = main(
        ["design", str(path), "--n", "3", "--align", "curvature", "-o", str(tmp_path / "x")]
    )
    assert code != 0 and "even n" in capsys.readouterr().err


@pytest.mark.slow
def test_render_crosses_and_fractional_singularities(tmp_path):
    pytest.importorskip("matplotlib")
    mesh = fvf.icosphere(3)
    path = tmp_path / "s.obj"
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    assert main(["design", str(path), "--n", "4", "-o", str(tmp_path / "c.npz")]) == 0
    png = tmp_path / "c.png"
    args = ["render", str(path), str(tmp_path / "c.npz"), "--field", "v", "--singularities"]
    assert main([*args, "--backend", "matplotlib", "-o", str(png)]) == 0
    assert png.stat().st_size > 10_000


def test_scene_draws_n_strokes_per_face():
    pytest.importorskip("matplotlib")
    from fvf.viz.arrows import direction_set
    from fvf.viz.colors import index_color, index_label

    mesh = fvf.icosphere(2)
    _, U = fvf.smoothest_fields(mesh, 1, n=4)
    d = direction_set(mesh, U[0], 4)  # (4, m, 3): the strokes drawn for each face
    length = np.linalg.norm(d, axis=2)
    np.testing.assert_allclose(length, length[:1].repeat(4, axis=0))  # equal strokes
    # the four strokes of a face are its cross: pairwise orthogonal or opposite
    assert np.abs(np.einsum("ij,ij->i", d[0], d[1])).max() < 1e-12
    np.testing.assert_allclose(d[2], -d[0], atol=1e-12)
    assert index_label(0.25) == "+1/4" and index_label(-1 / 6) == "-1/6" and index_label(2) == "+2"
    assert index_color(0.25) != index_color(-0.25) != index_color(1)
