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

import numpy as np
import pytest

import fvf
from conftest import import_benchmark

bench_correspondence = import_benchmark("bench_correspondence")
cd = import_benchmark("correspondence_dataset")


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


# ---------------------------------------------------------------------------- fast paths
def _float64_nearest(points, queries):
    sq = np.einsum("ij,ij->i", points, points)
    return (sq[None, :] - 2.0 * queries @ points.T).argmin(axis=1)


@pytest.mark.parametrize("dim", [13, 60, 200])
def test_brute_nearest_rows_equal_a_float64_search(dim):
    """The float32 screen with the float64 decision gives the float64 answer, also with
    exact ties (duplicated points: the first index wins) and near-ties that float32 cannot
    tell apart (squared distances 1e-6 apart at magnitudes 1e4) but float64 can."""
    from fvf.spectral.zoomout import nearest_rows

    rng = np.random.default_rng(dim)
    P = 10.0 * rng.standard_normal((1500, dim))
    P[1000:1200] = P[:200]  # exact duplicates
    P[1200:1300] = P[200:300] + 1e-4 * rng.standard_normal((100, dim))  # near-ties
    Q = np.vstack(
        [P[:400] + 1e-7 * rng.standard_normal((400, dim)), rng.standard_normal((200, dim))]
    )
    got = nearest_rows(P, Q, method="brute", block=128)
    assert np.array_equal(got, _float64_nearest(P, Q))
    assert np.all(got[:200] < 1000)  # the first of two exact duplicates


def test_zoomout_on_samples_matches_the_least_squares_definition():
    """ZoomOut on samples fits each C from one QR; the same C as a least-squares solve."""
    from fvf.spectral.zoomout import _zoomout_on_samples, nearest_rows

    mesh = fvf.jittered_sphere(3, 0.3, seed=1)
    b = fvf.SpectralBasis(mesh, 30)
    s = np.arange(0, mesh.n_vertices, 3)
    C0 = np.eye(10)
    C = _zoomout_on_samples(C0, b, b, [(20, 20), (30, 30)], (s, s), False)
    P = b.eigenvectors[s]
    ref = C0
    for k in (20, 30):
        kc = ref.shape[0]
        p = nearest_rows(P[:, :kc] @ ref.T, P[:, :kc])
        ref = np.linalg.lstsq(P[:, :k], P[p, :k], rcond=None)[0]
    assert np.allclose(C, ref, atol=1e-10)
