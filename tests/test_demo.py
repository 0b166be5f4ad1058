"""The ``fvf demo`` story, run as a user would (a subprocess), and in process."""

import importlib.util
import json
import re
import subprocess
import sys

import numpy as np
import pytest

import fvf

HAS_VIZ = all(importlib.util.find_spec(m) for m in ("matplotlib", "PIL"))


def run(*args, cwd=None, env=None):
    return subprocess.run(
        [sys.executable, "-m", "fvf.cli", *args], capture_output=True, text=True, cwd=cwd, env=env
    )


@pytest.fixture(scope="module")
def small_mesh(tmp_path_factory):
    path = tmp_path_factory.mktemp("mesh") / "sphere.obj"
    mesh = fvf.jittered_sphere(2, 0.2, seed=3)
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    return path


@pytest.mark.slow
def test_demo_on_builtin_mesh(tmp_path):  # about 45 s with pictures on 2 cores
    r = run("demo", "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    report = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert report["n_vertices"] == 2930 and report["n_faces"] == 5856
    assert report["max |D^F_v X - v| (Lemma 9)"] < 1e-10
    assert report["relative A_V-norm drift of J grad h flow"] < 1e-10
    if HAS_VIZ:
        assert len(report["pictures"]) >= 20 and report["seconds"] < 180
    else:
        assert "skipped" in r.stdout  # pictures are reported as skipped, never faked


@pytest.mark.skipif(not HAS_VIZ, reason="needs pip install 'fvf[viz]'")
def test_demo_writes_every_picture_report_and_gif(small_mesh, tmp_path):
    from PIL import Image

    out = tmp_path / "out"
    r = run("demo", "--mesh", str(small_mesh), "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "[fvf demo] Fig. 12" in r.stdout and "interpolation frames" in r.stdout
    report = json.loads((out / "summary.json").read_text())
    assert "skipped" not in report and report["backend"] in ("polyscope-egl", "matplotlib")
    names = report["pictures"]
    for fig in (
        "fig03_flow_0",
        "fig03_lic",
        "fig07_vertex_bracket",
        "fig07_mixed_bracket",
        "fig09_commutator",
        "fig10_before",
        "fig10_after",
        "fig11_acap_0",
        "fig12_strip",
        "fig12_interpolation.gif",
    ):
        assert any(n.startswith(fig) for n in names), fig
    page = (out / "index.html").read_text()
    for name in names:
        assert (out / name).stat().st_size > 1000
        assert f"src='{name}'" in page
    for name in [n for n in names if n.endswith(".png") and "strip" not in n]:
        img = np.asarray(Image.open(out / name).convert("RGB"))
        assert img.shape[2] == 3 and img.shape[:2] in ((480, 640), (360, 480))
        assert 0.05 < (img < 245).any(2).mean() < 0.9, name  # a mesh is drawn, not blank
    gif = Image.open(out / "fig12_interpolation.gif")
    assert gif.n_frames >= 7
    # every stage shows its numbers and the code that made them
    assert "Fig. 10 bracket L2 after/before rescaling" in page
    assert page.count("<details>") == 9 and "fvf.acap_fields(" in page
    assert re.search(r"roughness vertex/mixed bracket \(median\)</td><td>[0-9.]+", page)


def test_demo_without_pictures_reports_them_skipped(small_mesh, tmp_path):
    from fvf.cli.demo import demo

    report = demo(str(small_mesh), tmp_path / "o", pictures=False)
    assert report["pictures"] == [] and report["skipped"]
    assert all("pictures were turned off" in s for s in report["skipped"])
    assert report["max |D^F_v X - v| (Lemma 9)"] < 1e-10
    page = (tmp_path / "o" / "index.html").read_text()
    assert "skipped:" in page and "<img" not in page


def test_demo_without_the_viz_extra_says_how_to_get_it(small_mesh, tmp_path, monkeypatch):
    import fvf.cli.demo

    real = importlib.util.find_spec
    monkeypatch.setattr(
        fvf.cli.demo.importlib.util,
        "find_spec",
        lambda name, *a: None if name in ("matplotlib", "PIL") else real(name, *a),
    )
    report = fvf.cli.demo.demo(str(small_mesh), tmp_path / "o")
    assert report["skipped"] and all("pip install 'fvf[viz]'" in s for s in report["skipped"])
    assert report["Fig. 11 ACAP singularity counts"]


def test_demo_bad_mesh_one_line_error(tmp_path):
    bad = tmp_path / "broken.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 9\n")
    r = run("demo", "--mesh", str(bad), "--out", str(tmp_path / "o"))
    assert r.returncode == 2
    assert r.stderr.startswith("fvf: error:") and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    r = run("demo", "--mesh", str(tmp_path / "missing.off"))
    assert r.returncode == 2 and "Traceback" not in r.stderr
