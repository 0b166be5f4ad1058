"""The generated SMAL_r stand-in of ``benchmarks/smal_like.py``, built small (a template
of about 1,200 vertices, two species): the layout, closed single-component meshes, and
ground-truth maps that send each template vertex near where the deformation put it
(docs/correspondence.md, *The standard protocol*, measures fvf and pyFM on the full set).
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import fvf
from conftest import import_benchmark

cd = import_benchmark("correspondence_dataset")
smal_like = import_benchmark("smal_like")


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    pytest.importorskip("manifold3d")
    pytest.importorskip("pymeshlab")
    folder = tmp_path_factory.mktemp("smal_like")
    species = smal_like.make_smal_like(
        folder, n_species=2, seed=3, n_pairs=1, template_vertices=1200,
        species_vertices=(900, 1400),
    )  # fmt: skip
    return folder, species


def _mean_edge(V: np.ndarray, F: np.ndarray) -> float:
    return float(np.linalg.norm(V[F] - V[np.roll(F, -1, axis=1)], axis=2).mean())


def test_layout_and_pairs(small_set):
    folder, species = small_set
    names = [sp.name for sp in species]
    assert names == ["species_00", "species_01"]
    assert list(cd.dataset_shapes(folder)) == names
    (pair,) = cd.dataset_pairs(names, folder / "pairs.txt")
    assert sorted(pair) == names  # two different species
    assert (folder / "template.off").exists()


def test_meshes_are_closed_single_components(small_set):
    folder, species = small_set
    T, F_t = fvf.read_mesh(folder / "template.off")
    shapes = [fvf.read_mesh(folder / "shapes" / f"{sp.name}.off") for sp in species]
    for V, F in [(T, F_t), *shapes]:
        rep = fvf.mesh.mesh_report(V, F)
        assert rep["ok"], rep["problems"]
        topology = (rep["manifold"], rep["closed"], rep["components"], rep["genus"])
        assert topology == (True, True, 1, 0)
    if len(species) == 2:  # another vertex count than the template and each other
        assert len({len(T), *(len(sp.vertices) for sp in species)}) == 3


def test_ground_truth_maps_template_vertices_to_nearby_vertices(small_set):
    folder, species = small_set
    T, F_t = fvf.read_mesh(folder / "template.off")
    for sp in species:
        V, F = fvf.read_mesh(folder / "shapes" / f"{sp.name}.off")
        vts = cd.read_vts(folder / "corres" / f"{sp.name}.vts")
        assert vts.shape == (len(T),) and vts.max() < len(V)
        assert sp.deformed.shape == T.shape
        gap = np.linalg.norm(V[vts] - sp.deformed, axis=1)
        assert gap.max() < 2 * _mean_edge(V, F)
        # the deformation is not a rigid motion: the template's edges change length
        e_t = np.linalg.norm(T[F_t[:, 0]] - T[F_t[:, 1]], axis=1)
        e_d = np.linalg.norm(sp.deformed[F_t[:, 0]] - sp.deformed[F_t[:, 1]], axis=1)
        assert np.abs(np.log(e_d / e_t)).max() > 0.1


def test_deformation_is_the_identity_at_rest():
    T = np.random.default_rng(0).uniform(-0.5, 1.0, (50, 3))
    rest = dict.fromkeys(smal_like.species_parameters(np.random.default_rng(0)), 0.0)
    for key in ("elongation", "girth", "leg_length", "leg_thickness", "front_back"):
        rest[key] = 1.0
    rest.update(neck_length=1.0, head_size=1.0, ear_size=1.0, tail_length=1.0)
    assert np.allclose(smal_like.deform(T, rest), T)


def test_script_says_what_is_missing(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "pymeshlab", None)  # import pymeshlab raises
    assert smal_like.main(["--out", str(tmp_path / "x")]) == 2
    assert "pymeshlab" in capsys.readouterr().out
