"""The example scripts and the notebook run on a small mesh and print what they claim.

Every script of ``examples/`` runs as ``__main__`` (runpy) on a 162-vertex ellipsoid written to a
temporary OBJ (the scripts' optional mesh argument); its printed numbers are parsed and
checked against the figure's claim. Pictures are made and checked to exist when the
``[viz]`` extra (matplotlib) is importable; otherwise the script must say it skipped them.
The notebook's code cells run in order in one namespace (no Jupyter kernel), with
``FVF_EXAMPLE_MESH`` pointing to the same small mesh.
"""

from __future__ import annotations

import ast
import importlib.util
import json
import runpy
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import fvf

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SCRIPTS = sorted(
    p.name for p in EXAMPLES.glob("*.py") if p.name[0] != "_" and p.stem != "make_tour"
)
HAVE_VIZ = all(importlib.util.find_spec(name) for name in ("matplotlib", "PIL", "fvf.viz"))


@pytest.fixture(scope="module")
def small_mesh(tmp_path_factory) -> Path:
    """A 162-vertex irregular ellipsoid (closed, genus 0) as an OBJ file."""
    sphere = fvf.jittered_sphere(2, 0.3, seed=1)
    path = tmp_path_factory.mktemp("mesh") / "ellipsoid.obj"
    fvf.write_mesh(path, sphere.vertices * [1.3, 1.0, 0.8], sphere.faces)
    return path


def _run(script: str, *args: str, capsys, monkeypatch) -> tuple[str, dict]:
    """Run ``examples/<script> args`` as ``__main__`` in this process; (stdout, numbers).

    In-process (runpy) rather than a subprocess: the scripts share the imported library
    and the rendering backend, which keeps the whole file at a few tens of seconds.
    Warnings are shown, not raised, as when a user runs the script.
    """
    monkeypatch.setattr(sys, "argv", [str(EXAMPLES / script), *args])
    monkeypatch.syspath_prepend(str(EXAMPLES))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        runpy.run_path(str(EXAMPLES / script), run_name="__main__")
    out = capsys.readouterr().out
    numbers = {}
    for line in out.splitlines():
        if line.startswith("  ") and ": " in line:
            name, value = line.strip().split(": ", 1)
            try:
                numbers[name] = ast.literal_eval(value)
            except (ValueError, SyntaxError):
                numbers[name] = value
    return out, numbers


CLAIMS = {
    "fig03_flow.py": lambda r: (
        r["[A_V] D^V_v skew (norm-preserving)"] is True
        and r["relative A_V-norm drift at the last time"] < 1e-10
        and r["upwind flow stays in [min f0, max f0]"] is True
    ),
    "fig07_brackets_eigenfunctions.py": lambda r: (
        len(r["ratios"]) == 11 and r["median ratio on a jittered sphere (642 vertices)"] > 1.5
    ),
    "fig09_commutator_field.py": lambda r: (
        r["relative difference of the fitted smooth fields"] < 0.015
        and r["relative normal part ||u.N|| / ||u||"] < 0.1
    ),
    "fig10_rescaling.py": lambda r: r["bracket L2 after / before"] < 1.0,
    "fig11_acap.py": lambda r: (
        r["field 0 singularities, index sum (chi = 2)"][1] == 2
        and r["field 1 singularities, index sum (chi = 2)"][1] == 2
        and r["field 0 bracket energy"] < 0.1 * r["bracket energy of a random smooth gradient"]
    ),
    "fig12_interpolation.py": lambda r: (
        r["interpolant t = 1/2"] == [1, [1]] and r["average"][0] >= 3
    ),
    "fluid.py": lambda r: (
        r["relative energy drift"] < 1e-8 and r["relative enstrophy drift"] < 1e-8
    ),
}


def test_every_script_has_a_claim():
    assert sorted(CLAIMS) == SCRIPTS


@pytest.mark.parametrize("script", SCRIPTS)
def test_example_runs_and_measures(script, small_mesh, tmp_path, capsys, monkeypatch):
    out, numbers = _run(
        script, str(small_mesh), "--out", str(tmp_path), capsys=capsys, monkeypatch=monkeypatch
    )
    assert "ellipsoid.obj (162 vertices, 320 faces)" in out
    assert CLAIMS[script](numbers), out
    pictures = list(tmp_path.glob("*.png"))
    if HAVE_VIZ:
        assert len(pictures) == 1 and "picture: wrote" in out, out
        from PIL import Image

        with Image.open(pictures[0]) as image:
            rgb = np.asarray(image.convert("RGB"), dtype=float)
        assert rgb.shape[0] >= 200 and rgb.shape[1] >= 300
        drawn = (np.abs(rgb - 255).sum(axis=2) > 30).mean()  # not white background
        assert 0.05 < drawn < 0.9, (script, drawn)
        assert rgb.reshape(-1, 3).std(axis=0).max() > 20  # colour varies
    else:
        assert not pictures and "skipped" in out, out


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS)
def test_example_on_its_default_mesh(script, capsys, monkeypatch):
    """The scripts as a user runs them first: no mesh argument (Spot, or the icosphere of
    Fig. 12), numbers only."""
    out, numbers = _run(script, "--no-pictures", capsys=capsys, monkeypatch=monkeypatch)
    assert "(2930 vertices, 5856 faces)" in out or "icosphere(4)" in out
    assert CLAIMS[script](numbers), out


def test_no_pictures_flag(small_mesh, tmp_path, capsys, monkeypatch):
    args = str(small_mesh), "--no-pictures", "--out", str(tmp_path)
    out, numbers = _run("fig10_rescaling.py", *args, capsys=capsys, monkeypatch=monkeypatch)
    assert "skipped (--no-pictures)" in out and not list(tmp_path.glob("*"))
    assert numbers["bracket L2 after / before"] < 1.0


def _load_make_tour():
    spec = importlib.util.spec_from_file_location("make_tour", EXAMPLES / "make_tour.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_notebook_is_nbformat4_without_outputs_and_up_to_date():
    text = (EXAMPLES / "tour.ipynb").read_text()
    assert text == _load_make_tour().text(), "run python examples/make_tour.py"
    nb = json.loads(text)
    assert nb["nbformat"] == 4 and isinstance(nb["metadata"], dict)
    ids = [cell["id"] for cell in nb["cells"]]
    assert len(set(ids)) == len(ids)
    for cell in nb["cells"]:
        assert cell["cell_type"] in ("markdown", "code")
        assert isinstance(cell["source"], list)
        if cell["cell_type"] == "code":
            assert cell["outputs"] == [] and cell["execution_count"] is None
    try:
        import nbformat
    except ImportError:  # not a dependency; validated when present
        return
    nbformat.validate(nbformat.reads(text, as_version=4))


def test_notebook_code_cells_run_in_order(small_mesh, monkeypatch):
    monkeypatch.setenv("FVF_EXAMPLE_MESH", str(small_mesh))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = json.loads((EXAMPLES / "tour.ipynb").read_text())
    namespace: dict = {}
    with warnings.catch_warnings():  # shown, not raised, as in a notebook
        warnings.simplefilter("default")
        for i, cell in enumerate(nb["cells"]):
            if cell["cell_type"] == "code":
                code = compile("".join(cell["source"]), f"tour.ipynb cell {i}", "exec")
                exec(code, namespace)
    assert namespace["n"] == 162
    assert namespace["lemma9"] < 1e-12 and np.abs(namespace["div_v"]).max() < 1e-10
    assert namespace["norm_drift"] < 1e-10
    assert namespace["acap"].shape == (2, 320, 3)
    assert all(index.sum() == 2 for _, index in namespace["singular"])  # Poincaré–Hopf
    assert namespace["halfway"].shape == (320, 3) and namespace["change"] > 0
    if HAVE_VIZ:
        assert [p.exists() for p in namespace["pictures"]] == [True, True]
