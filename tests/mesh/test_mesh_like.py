"""One entrance: every function taking a mesh takes a :data:`fvf.MeshLike`, paths too."""

from __future__ import annotations

import inspect
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fvf
from fvf.mesh import convert
from fvf.mesh.builtin import spot_path

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def sphere_file(tmp_path_factory) -> Path:
    mesh = fvf.icosphere(2)
    path = tmp_path_factory.mktemp("meshlike") / "sphere.off"
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    return path


@pytest.mark.parametrize("kind", [str, Path])
def test_as_mesh_reads_a_path(kind, sphere_file):
    mesh = fvf.as_mesh(kind(sphere_file))
    V, F = fvf.read_mesh(sphere_file)
    assert isinstance(mesh, fvf.TriMesh)
    assert np.array_equal(mesh.vertices, V) and np.array_equal(mesh.faces, F)


def test_every_function_taking_a_mesh_takes_a_path(sphere_file):
    mesh = fvf.icosphere(2)
    d = mesh.face_edge_vectors[[0, 7], 0]
    expected = fvf.design_field(mesh, [0, 7], d)
    assert np.allclose(fvf.design_field(str(sphere_file), [0, 7], d), expected)
    assert np.allclose(fvf.design_field(sphere_file, [0, 7], d), expected)
    f = mesh.vertices[:, 2]
    assert np.allclose(fvf.gradient(sphere_file, f), fvf.gradient(mesh, f))
    assert fvf.SpectralBasis(sphere_file, 4).eigenvalues.shape == (4,)


def test_a_bad_path_is_the_file_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        fvf.as_mesh(tmp_path / "missing.obj")
    bad = tmp_path / "two_triangles.obj"  # a vertex used by nothing is fine; NaN is not
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n")
    with pytest.raises((fvf.MeshError, ValueError)) as info:
        fvf.as_mesh(bad)
    assert "two_triangles.obj" in str(info.value)


def test_without_a_reader_a_path_says_what_to_do(monkeypatch, sphere_file):
    monkeypatch.setattr(convert, "_PATH_READER", [])
    with pytest.raises(TypeError, match="no mesh file reader"):
        fvf.as_mesh(sphere_file)


def test_the_reader_is_fvf_io_read_mesh():
    """Installed by the file layer on import (the mesh layer never imports it)."""
    import fvf.io

    assert convert._PATH_READER == [fvf.io.read_mesh]


def test_signatures_say_mesh_like():
    """Every public function (and class) taking a mesh shows ``mesh: MeshLike``."""
    checked = 0
    for name in fvf.__all__:
        obj = getattr(fvf, name)
        fn = obj.__init__ if inspect.isclass(obj) else obj
        if not callable(fn) or not hasattr(fn, "__wrapped__"):
            continue
        params = inspect.signature(fn).parameters
        if "mesh" in params and "mesh" in inspect.signature(fn.__wrapped__).parameters:
            assert params["mesh"].annotation == "MeshLike", name
            checked += 1
    assert checked > 50
    assert inspect.signature(fvf.design_field).parameters["mesh"].annotation == "MeshLike"


def test_mesh_like_names_what_as_mesh_takes():
    assert fvf.MeshLike is convert.MeshLike
    assert fvf.as_mesh(spot_path()).n_vertices == 2930


@pytest.mark.slow
def test_mypy_accepts_mesh_like_calls():
    """tests/typing/ (in mypy's ``files``) type-checks: fvf.design_field((V, F)), paths."""
    pytest.importorskip("mypy")
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "tests/typing"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "MYPYPATH": str(ROOT / "src")},
    )
    assert out.returncode == 0, out.stdout + out.stderr
