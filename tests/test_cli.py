"""The fvf command, run as a user would (a subprocess)."""

import json
import subprocess
import sys


def run(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "fvf.cli", *args], capture_output=True, text=True, cwd=cwd
    )


def test_demo_on_builtin_mesh(tmp_path):
    r = run("demo", "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    report = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert report["n_vertices"] == 2930 and report["n_faces"] == 5856
    assert report["max |D^F_v X - v| (Lemma 9)"] < 1e-10
    assert report["relative A_V-norm drift of J grad h flow"] < 1e-10
    assert "skipped" in r.stdout  # unbuilt stages are reported, never faked


def test_demo_bad_mesh_one_line_error(tmp_path):
    bad = tmp_path / "broken.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 9\n")
    r = run("demo", "--mesh", str(bad), "--out", str(tmp_path / "o"))
    assert r.returncode == 2
    assert r.stderr.startswith("fvf: error:") and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    r = run("demo", "--mesh", str(tmp_path / "missing.off"))
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_info_reports_every_problem(tmp_path):
    from conftest import shared_mesh_path

    r = run("info", str(shared_mesh_path("stanford-bunny.obj")))
    assert r.returncode == 1
    assert "unreferenced_vertices: 1113" in r.stdout and "boundary_loops: 5" in r.stdout
    assert "needle_faces: 1" in r.stdout and "remove_unreferenced_vertices" in r.stdout
    r = run("info", str(shared_mesh_path("fertility.off")))
    assert r.returncode == 0 and "genus: 4" in r.stdout and "no problems found" in r.stdout


def test_mesh_report_on_broken_meshes():
    import numpy as np

    from fvf.diagnostics import mesh_report

    X = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1], [9, 9, 9]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    flipped = F.copy()
    flipped[2] = flipped[2, ::-1]
    rep = mesh_report(X, flipped)
    assert not rep["ok"] and rep["unreferenced_vertices"] == 1
    assert any("OrientationError" in p for p in rep["problems"])
    assert any("Unreferenced" in p for p in rep["problems"])
    rep = mesh_report(X[:4], F[:, :2])
    assert rep["problems"] and "MeshShapeError" in rep["problems"][0]
    rep = mesh_report(X[:4], F)
    assert rep["ok"] and rep["genus"] == 0 and rep["problems"] == []
