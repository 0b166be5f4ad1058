"""The fvf command, run as a user would (a subprocess)."""

import subprocess
import sys


def run(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "fvf.cli", *args], capture_output=True, text=True, cwd=cwd
    )


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
