"""The ``fvf demo`` story, run as a user would (a subprocess)."""

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
