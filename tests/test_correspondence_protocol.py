"""The standard correspondence protocol of ``benchmarks/bench_correspondence.py --dataset``
on the small generated set of ``benchmarks/correspondence_dataset.py`` (FAUST_r layout:
``shapes/*.off``, ``corres/*.vts`` with 1-based indices).

The set's ``.vts`` files are exact (every copy keeps the template's vertices, shuffled),
so the protocol is checked against maps whose errors are known: the true map scores 0 at
every template point, and a map that sends everything to one vertex scores the mean
distance to it.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import fvf


def _benchmarks() -> Path:
    for parent in Path(__file__).resolve().parents:
        if (parent / "benchmarks" / "correspondence_dataset.py").exists():
            return parent / "benchmarks"
    raise FileNotFoundError("benchmarks/correspondence_dataset.py")


sys.path.insert(0, str(_benchmarks()))
import bench_correspondence  # noqa: E402
import correspondence_dataset as cd  # noqa: E402


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    folder = tmp_path_factory.mktemp("faust_r_like")
    names = cd.make_dataset(folder, n_shapes=3, level=3, seed=0)
    return folder, names


def test_generated_set_has_the_layout_and_exact_correspondences(dataset):
    folder, names = dataset
    assert names == ["shape_000", "shape_001", "shape_002"]
    shapes = cd.dataset_shapes(folder)
    assert list(shapes) == names
    body = cd.generated_body(3)
    edge = np.linalg.norm(np.diff(body.vertices[body.edges], axis=1), axis=2).mean()
    vts = {n: cd.read_vts(folder / "corres" / f"{n}.vts") for n in names}
    lines = (folder / "corres" / "shape_000.vts").read_text().split()
    assert min(int(x) for x in lines) == 1  # 1-based on disk
    for n in names:
        V, F = fvf.read_mesh(shapes[n])
        assert vts[n].shape == (body.n_vertices,)
        # the template's vertices, moved rigidly and by at most a few edge lengths
        D = V[vts[n]]
        d_body = np.linalg.norm(body.vertices[0] - body.vertices[1:], axis=1)
        d_copy = np.linalg.norm(D[0] - D[1:], axis=1)
        assert np.abs(d_body - d_copy).max() < 0.25 * np.ptp(body.vertices, axis=0).max()
        assert np.linalg.norm(D[body.edges[:, 0]] - D[body.edges[:, 1]], axis=1).mean() < 2 * edge
    n_1 = len(fvf.read_mesh(shapes["shape_001"])[0])
    assert n_1 > body.n_vertices  # the subdivided copy: another vertex count


def test_errors_of_known_maps(dataset):
    folder, names = dataset
    shapes = cd.dataset_shapes(folder)
    a, b = names[0], names[1]
    vts_a, vts_b = (cd.read_vts(folder / "corres" / f"{n}.vts") for n in (a, b))
    p1 = fvf.mesh.prepared.prepare_mesh(*fvf.read_mesh(shapes[a]))
    n_b = len(fvf.read_mesh(shapes[b])[0])
    truth = np.zeros(n_b, dtype=np.int64)
    truth[vts_b] = vts_a
    assert np.all(cd.pair_errors(p1, truth, vts_a, vts_b) == 0)
    const = np.full(n_b, vts_a[0])
    e = cd.pair_errors(p1, const, vts_a, vts_b)
    ref = fvf.geodesic_errors(p1.mesh, np.full(vts_a.size, vts_a[0]), vts_a)
    assert np.allclose(e, 100 * ref) and e.mean() > 10


def test_pairs_from_a_file_and_all_pairs(dataset, tmp_path):
    folder, names = dataset
    assert cd.dataset_pairs(names) == [
        ("shape_000", "shape_001"),
        ("shape_000", "shape_002"),
        ("shape_001", "shape_002"),
    ]
    assert cd.dataset_pairs(names, max_pairs=1) == [("shape_000", "shape_001")]
    f = tmp_path / "pairs.txt"
    f.write_text("# test pairs\nshape_002 shape_000\n")
    assert cd.dataset_pairs(names, f) == [("shape_002", "shape_000")]
    f.write_text("shape_002 nobody\n")
    with pytest.raises(ValueError, match="not two shapes"):
        cd.dataset_pairs(names, f)


def test_command_prints_the_table_and_writes_the_curve(dataset, tmp_path, capsys):
    """``--dataset DIR`` with fvf only (pyFM takes several seconds per pair): a row per
    pair, the summary table, the CSV curve and the JSON rows."""
    folder, _ = dataset
    curve, rows = tmp_path / "curve.csv", tmp_path / "rows.json"
    code = bench_correspondence.main(
        ["--dataset", str(folder), "--k", "30", "--no-pyfm", "--max-pairs", "2"]
        + ["--curve", str(curve), "--json", str(rows)]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert "shape_000 <- shape_001" in out and "shape_000 <- shape_002" in out
    assert "| fvf | 2 |" in out and "pairs > 5" in out
    table = list(csv.reader(curve.open()))
    assert table[0] == ["threshold", "fvf"] and len(table) == 102
    frac = np.array([float(r[1]) for r in table[1:]])
    assert np.all(np.diff(frac) >= 0) and 0 <= frac[0] <= frac[-1] <= 1
    data = json.loads(rows.read_text())
    assert [r["pair"] for r in data] == ["shape_000 shape_001", "shape_000 shape_002"]
    assert all(r["method"] == "fvf" and r["mean_error"] >= 0 for r in data)
