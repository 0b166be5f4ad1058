"""Nothing lost, nothing raw: outputs that could replace a good file or an input, inputs
that would hang, work without a bound, results silently put in the wrong place.

Each case either gives the right result or raises the documented typed error (exit
status of ``fvf``) quickly, leaving every file it did not mean to write as it was.
"""

from __future__ import annotations

import csv
import importlib
import os
import signal
import subprocess
import sys
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

import fvf
from fvf import errors
from fvf.batch import store
from fvf.cli.main import EXIT_BAD_INPUT, EXIT_WRITE_FAILED, main
from fvf.io.datafile import data_path, read_data, write_data


@pytest.fixture
def alarm():
    """Fail (instead of hanging forever) when a call takes more than 30 s."""

    def hang(signum, frame):
        raise TimeoutError("hung: more than 30 s")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(30)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


def _mesh_file(path: Path, mesh=None) -> Path:
    mesh = fvf.icosphere(1) if mesh is None else mesh
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    return path


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


# ---------------------------------------------------------------------------- data lost
@pytest.mark.parametrize("suffix", [".vtp", ".vtu"])
def test_vtk_truncated_write_keeps_the_old_file(suffix, tmp_path, monkeypatch):
    """A writer that leaves a truncated file (VTK reports a full disk on the console only)
    is caught by reading the file back; the previous good file stays, no temporary."""
    pytest.importorskip("pyvista")
    from fvf.io.formats import vtk

    mesh = fvf.icosphere(1)
    out = tmp_path / f"d{suffix}"
    fvf.write_mesh(out, mesh.vertices, mesh.faces)
    good = out.read_bytes()

    real_xml = vtk._vtk_xml
    monkeypatch.setattr(vtk, "_vtk_xml", lambda *a: real_xml(*a)[: len(good) // 2])
    monkeypatch.setattr(vtk, "_have", lambda module: module != "meshio")  # the VTK path
    with pytest.raises(errors.OutputWriteError, match="incomplete"):
        fvf.write_mesh(out, mesh.vertices, mesh.faces)
    assert out.read_bytes() == good
    assert _leftovers(tmp_path) == []


def test_vtu_through_meshio_verified(tmp_path, monkeypatch):
    meshio = pytest.importorskip("meshio")
    mesh = fvf.icosphere(1)
    out = tmp_path / "d.vtu"
    fvf.write_mesh(out, mesh.vertices, mesh.faces)
    good = out.read_bytes()

    def broken(path, *args, **kwargs):  # a writer that fails after writing half
        Path(path).write_bytes(good[: len(good) // 3])

    monkeypatch.setattr(meshio, "write", broken)
    with pytest.raises(errors.OutputWriteError):
        fvf.write_mesh(out, fvf.icosphere(2).vertices, fvf.icosphere(2).faces)
    assert out.read_bytes() == good
    assert _leftovers(tmp_path) == []


def test_vtk_on_a_full_disk(tmp_path):
    """On a real 64 KiB file system (root only; skipped elsewhere): exit 5, old file kept."""
    pytest.importorskip("pyvista")
    small = tmp_path / "small"
    small.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(small)], capture_output=True
    )
    if mounted.returncode != 0:
        pytest.skip("cannot mount a small tmpfs here")
    try:
        mesh = _mesh_file(tmp_path / "mesh.off", fvf.icosphere(4))
        fvf.write_mesh(small / "d.vtp", fvf.icosphere(0).vertices, fvf.icosphere(0).faces)
        good = (small / "d.vtp").read_bytes()
        code = subprocess.run(
            [sys.executable, "-m", "fvf", "design", str(mesh), "-o", str(small / "d.vtp")],
            capture_output=True,
            timeout=120,
            env={**os.environ, "PYTHONPATH": str(Path(fvf.__file__).parents[1])},
        )
        assert code.returncode == EXIT_WRITE_FAILED, code.stderr
        assert (small / "d.vtp").read_bytes() == good
        assert _leftovers(small) == []
    finally:
        subprocess.run(["umount", str(small)], capture_output=True)


def test_damaged_result_is_recomputed(tmp_path):
    """4 KB zeroed inside an array of a result: the key still reads, the CRC does not."""
    path = tmp_path / "r.npz"
    big = np.random.default_rng(1).normal(size=20000)
    np.savez(path, batch_key=np.array("k"), batch_summary=np.array('{"status": "ok"}'), x=big)
    assert store.stored_row(path, "k") == {"status": "ok"}
    with zipfile.ZipFile(path) as z:
        info = z.getinfo("x.npy")
    data = bytearray(path.read_bytes())
    start = info.header_offset + 30 + len(info.filename) + 20000  # inside x's data
    data[start : start + 4096] = bytes(4096)
    path.write_bytes(bytes(data))
    with np.load(path) as z:  # what was checked before: still looks fine
        assert str(z["batch_key"]) == "k"
    assert store.stored_row(path, "k") is None


def test_remove_temporaries_keeps_user_dot_files(tmp_path):
    (tmp_path / "meshes").mkdir()
    mine = [".summary.csv.swp", ".res.npz.bak", "meshes/.old.npz.keep", "meshes/.notes"]
    ours = [".summary.csv.0123456789abcdef.csv", "meshes/.a.npz.00ff00ff00ff00ff.npz"]
    for name in mine + ours:
        (tmp_path / name).write_text("x")
    assert store.remove_temporaries(tmp_path) == len(ours)
    assert all((tmp_path / n).exists() for n in mine)
    assert not any((tmp_path / n).exists() for n in ours)


def test_batch_pairs_file_in_the_output_is_refused(tmp_path):
    pytest.importorskip("distributed")
    a = _mesh_file(tmp_path / "a.off")
    out = tmp_path / "out"
    out.mkdir()
    pairs = out / "summary.csv"
    pairs.write_text(f"{a},{a}\n")
    before = pairs.read_bytes()
    code = main(["batch", "--pairs", str(pairs), "-o", str(out), "--tasks", "fmap", "--quiet"])
    assert code == EXIT_BAD_INPUT
    assert pairs.read_bytes() == before
    with pytest.raises(errors.InputOverwriteError, match="summary.csv"):
        fvf.batch.run([], out, pairs=pairs, tasks=["fmap"], progress=False)


def test_batch_result_over_an_input_is_refused(tmp_path):
    pytest.importorskip("distributed")
    out = tmp_path / "out"
    (out / "meshes").mkdir(parents=True)
    mesh = _mesh_file(tmp_path / "m.off")
    os.link(mesh, out / "meshes" / "m.npz")  # the result name of m is a hard link to it
    with pytest.raises(errors.InputOverwriteError, match="hard link"):
        fvf.batch.run([mesh], out, tasks=["info"], progress=False)


def _match_args(tmp_path: Path) -> list[str]:
    a = _mesh_file(tmp_path / "a.off")
    b = _mesh_file(tmp_path / "b.off")
    return ["match", str(a), str(b), "-o", str(tmp_path / "map.npz")]


@pytest.mark.parametrize(
    "option, input_name, png",
    [("--truth", "t_errors.png", "t.png"), ("--landmarks", "lmk.png", "lmk.png")],
)
def test_match_derived_picture_over_an_input(option, input_name, png, tmp_path, capsys):
    inp = tmp_path / input_name
    inp.write_text("0 0\n" if option == "--landmarks" else "0\n")
    before = inp.read_bytes()
    code = main([*_match_args(tmp_path), option, str(inp), "--png", str(tmp_path / png)])
    assert code == EXIT_BAD_INPUT
    assert "replace an input" in capsys.readouterr().err
    assert inp.read_bytes() == before
    assert not (tmp_path / "map.npz").exists()


# ---------------------------------------------------------------------------- hangs
def _fifo(path: Path) -> Path:
    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    os.mkfifo(path)
    return path


@pytest.mark.parametrize("option", ["--landmarks", "--truth"])
@pytest.mark.parametrize("kind", ["zero", "fifo"])
def test_match_special_files(option, kind, tmp_path, alarm, capsys):
    path = Path("/dev/zero") if kind == "zero" else _fifo(tmp_path / "pipe")
    if not path.exists():
        pytest.skip("no /dev/zero")
    assert main([*_match_args(tmp_path), option, str(path)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert str(path) in err and "not a regular file" in err


@pytest.mark.parametrize("kind", ["zero", "fifo"])
def test_batch_special_inputs(kind, tmp_path, alarm):
    pytest.importorskip("distributed")
    path = Path("/dev/zero") if kind == "zero" else _fifo(tmp_path / "pipe")
    with pytest.raises(errors.BatchInputError, match=str(path)):
        fvf.batch.run([path], tmp_path / "out", progress=False)
    with pytest.raises(errors.BatchInputError, match="not a regular file"):
        fvf.batch.run([], tmp_path / "out", pairs=path, tasks=["fmap"], progress=False)


def test_pair_map_fifo_is_refused(tmp_path, alarm):
    from fvf.batch.registry import PairContext

    a = _mesh_file(tmp_path / "a.off")
    pipe = _fifo(tmp_path / "map.txt")
    mesh = fvf.icosphere(1)

    class Side:
        def __init__(self):
            self.mesh, self.path = mesh, a

    ctx = PairContext(Side(), Side(), str(pipe), {})
    with pytest.raises(errors.BatchInputError, match="not a regular file"):
        ctx.point_map()


def test_recursive_glob_through_symlink_loops_is_bounded(tmp_path, alarm):
    from fvf.batch.inputs import find_meshes

    deep = tmp_path / "a" / "b"
    deep.mkdir(parents=True)
    _mesh_file(tmp_path / "a" / "m1.off")
    _mesh_file(deep / "m2.off")
    for i in range(6):  # 6 loops: following them is 6^depth paths
        os.symlink(tmp_path, deep / f"loop{i}")
    found = find_meshes([str(tmp_path / "**" / "*.off")])
    assert sorted(p.name for p in found) == ["m1.off", "m2.off"]


def test_absurd_worker_count_is_refused(tmp_path, capsys):
    pytest.importorskip("distributed")
    mesh = _mesh_file(tmp_path / "m.off")
    argv = ["batch", str(mesh), "-o", str(tmp_path / "out"), "--workers", "9" * 23]
    assert main(argv) == EXIT_BAD_INPUT
    assert "more than this machine" in capsys.readouterr().err
    with pytest.raises(errors.ParameterError):
        fvf.batch.run([mesh], tmp_path / "out", workers=10**6, progress=False)


def test_ideal_fluid_refuses_unbounded_runs(alarm):
    from fvf.flows.fluid import MAX_FLUID_WORK, ideal_fluid

    mesh = fvf.icosphere(2)
    omega = mesh.vertices[:, 2].copy()
    with pytest.raises(errors.ParameterError, match="MAX_FLUID_WORK"):
        ideal_fluid(mesh, omega, 0.01, steps=10**9)
    assert MAX_FLUID_WORK // mesh.n_vertices > 10**6  # ordinary runs are far below it
    assert len(ideal_fluid(mesh, omega, 0.01, steps=2).energy) == 3


# ---------------------------------------------------------------------------- silently wrong
def _strip(k: int = 8) -> fvf.TriMesh:
    """A closed band of 2k vertices and 2k faces: as many vertices as faces."""
    angle = 2 * np.pi * np.arange(k) / k
    ring = np.column_stack([np.cos(angle), np.sin(angle), np.zeros(k)])
    V = np.vstack([ring, ring + [0, 0, 1]])
    i = np.arange(k)
    j = (i + 1) % k
    F = np.vstack([np.column_stack([i, j, k + i]), np.column_stack([j, k + j, k + i])])
    return fvf.TriMesh(V, F)


@pytest.mark.parametrize("suffix", [".ply", ".vtp"])
def test_mesh_outputs_put_fields_on_faces_when_n_equals_m(suffix, tmp_path, rng):
    mesh = _strip()
    assert mesh.n_vertices == mesh.n_faces
    v = mesh.project_tangent(rng.normal(size=(mesh.n_faces, 3)))
    f = rng.normal(size=mesh.n_vertices)
    out = tmp_path / f"r{suffix}"
    if suffix == ".vtp":
        pytest.importorskip("pyvista")
    write_data(out, {"v": v, "f": f}, mesh=mesh, mesh_path=tmp_path / "x.off", command="t")
    if suffix == ".ply":
        vertex, face = fvf.io.read_ply_properties(out)
        assert set(face) == {"vx", "vy", "vz"} and set(vertex) == {"f"}
        data = read_data(out, mesh)
        np.testing.assert_array_equal(data.field("v", mesh), v)
        np.testing.assert_array_equal(data.functions("f", mesh), f)
    else:
        import pyvista

        grid = pyvista.read(out)
        assert "v" in grid.cell_data and "f" in grid.point_data
    kinds = {"f": "face"}  # explicit kinds win
    write_data(out, {"f": f}, mesh=mesh, mesh_path="x.off", command="t", kinds=kinds)
    if suffix == ".ply":
        assert set(fvf.io.read_ply_properties(out)[1]) == {"f"}


def test_summary_cells_are_not_formulas(tmp_path):
    rows = [
        {"mesh": "=HYPERLINK(1)", "status": "failed", "error": "-2+3", "n": -5, "m": 1.5},
        {"mesh": "@x", "status": "ok", "error": "+cmd", "n": 3, "m": -0.25, "warnings": "\tz"},
    ]
    store.write_summary(tmp_path / "s.csv", rows)
    with open(tmp_path / "s.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [r["mesh"] for r in table] == ["'=HYPERLINK(1)", "'@x"]
    assert [r["error"] for r in table] == ["'-2+3", "'+cmd"]
    assert [r["n"] for r in table] == ["-5", "3"]  # numbers stay numbers
    assert [r["m"] for r in table] == ["1.5", "-0.25"]
    assert table[1]["warnings"] == "'\tz"


def test_repair_checks_every_output_before_writing(tmp_path, capsys):
    mesh = _mesh_file(tmp_path / "m.off")
    (tmp_path / "fixed.maps.npz").mkdir()  # the maps cannot be written
    assert main(["repair", str(mesh), "-o", str(tmp_path / "fixed.off")]) == EXIT_WRITE_FAILED
    assert "nothing was written" in capsys.readouterr().err
    assert not (tmp_path / "fixed.off").exists()


def test_repair_fails_late_writes_neither(tmp_path, monkeypatch):
    """The mesh writer fails after the maps are ready: neither file appears."""
    mesh = _mesh_file(tmp_path / "m.off")

    def fail(*args, **kwargs):
        raise errors.OutputWriteError("disk full")

    monkeypatch.setattr(fvf, "write_mesh", fail)
    assert main(["repair", str(mesh), "-o", str(tmp_path / "fixed.off")]) == EXIT_WRITE_FAILED
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.off"]


def test_progress_callback_exception_propagates():
    class Cancel(RuntimeError):
        pass

    calls = []

    def cancel(stage, done, total):
        calls.append(stage)
        raise Cancel("user cancelled")

    with pytest.raises(Cancel, match="user cancelled"):
        fvf.SpectralBasis(fvf.icosphere(3), 10, progress=cancel)
    assert len(calls) == 1  # no fallback method ran after the cancel


# ---------------------------------------------------------------------------- the rest
def test_truth_out_of_range_is_refused_before_the_match(tmp_path, capsys, alarm):
    truth = tmp_path / "t.txt"
    n = fvf.icosphere(1).n_vertices
    truth.write_text("\n".join(str(i) for i in range(n - 1)) + f"\n{n + 5}\n")
    code = main([*_match_args(tmp_path), "--truth", str(truth)])
    assert code == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert str(truth) in err and f"line {n} is {n + 5}" in err
    assert not (tmp_path / "map.npz").exists()
    truth.write_text("0\n1\n")
    assert main([*_match_args(tmp_path), "--truth", str(truth)]) == EXIT_BAD_INPUT


def test_truth_all_missing_has_no_mean(tmp_path, capsys):
    truth = tmp_path / "t.txt"
    n = fvf.icosphere(1).n_vertices
    truth.write_text("-1\n" * n)
    args = [*_match_args(tmp_path), "--truth", str(truth), "--truth-missing", "-1", "--k", "10"]
    with _no_warning():
        assert main([*args, "--k-fit", "5"]) == 0
    assert "no vertex has a ground truth" in capsys.readouterr().out
    with np.load(tmp_path / "map.npz") as data:
        assert np.isnan(data["errors"]).all()


class _no_warning:
    """Fail on a RuntimeWarning such as numpy's "Mean of empty slice"."""

    def __enter__(self):
        import warnings

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("error", RuntimeWarning)

    def __exit__(self, *exc):
        return self._ctx.__exit__(*exc)


def test_repair_vertex_at_float_limit(alarm):
    mesh = fvf.icosphere(1)
    V = mesh.vertices.copy()
    V[0] = [1e308, -1.7e308, 1e308]
    with np.errstate(all="ignore"):
        try:
            result = fvf.repair_mesh(V, mesh.faces, tol=1e-6)
        except errors.MeshError:  # a typed refusal is acceptable; a SciPy crash is not
            return
    assert result.vertex_map.shape == (len(V),)


# ---------------------------------------------------------------------------- own results
def _rounded_cube(level: int = 3) -> fvf.TriMesh:
    """An icosphere pushed onto |x|^8 + |y|^8 + |z|^8 = 1: symmetric about the cube's
    diagonals, so the smoothest cross field vanishes on the faces at its 8 corners."""
    s = fvf.icosphere(level)
    V = s.vertices / (np.sum(s.vertices**8, axis=1) ** (1 / 8))[:, None]
    return fvf.TriMesh(V, s.faces)


def test_designed_cross_field_of_a_symmetric_shape_is_accepted_everywhere():
    mesh = _rounded_cube()
    u = fvf.design_field(mesh, n=4)
    length = np.linalg.norm(u, axis=1)
    assert length.min() > 1e-10 * length.max()  # every face has a direction
    ids, index = fvf.singularities(mesh, u, n=4)
    assert index.tolist() == [0.25] * 8  # the cube's corners
    corners = np.abs(mesh.vertices[ids])
    assert (corners > 0.6).all()
    cut = fvf.cut_graph(mesh, u, 4)
    fvf.comb(mesh, u, 4, cut)
    fvf.period_jumps(mesh, u, 4)


def test_zero_fill_reports_a_cone_on_a_zero_face():
    mesh = fvf.disk(6, 8)
    u = mesh.face_centroids * [1, 1, 0]  # a source at vertex 0
    fan = np.flatnonzero((mesh.faces == 0).any(axis=1))
    u[fan[0]] = 0.0  # a zero next to the source
    with pytest.raises(errors.FieldShapeError, match="zero='fill'"):
        fvf.singularities(mesh, u)
    ids, index = fvf.singularities(mesh, u, zero="fill")
    assert index.sum() == 1 and ids.size == 1
    assert ids[0] in mesh.faces[fan[0]]
    with pytest.warns(fvf.ZeroFieldWarning):  # nothing to fill from: as "warn"
        assert fvf.singularities(mesh, np.zeros((mesh.n_faces, 3)), zero="fill")[0].size == 0


def test_demo_reports_a_section_it_cannot_do(tmp_path, monkeypatch):
    from fvf.cli import demo as demo_module

    def fails(s, story):
        """A section this mesh does not allow."""
        story.begin("cannot", fails)
        raise errors.FieldShapeError("u is (numerically) zero at faces [1]")

    def needs_it(s, story):
        """A section that needs the failed section's result."""
        return s.missing

    mesh = _mesh_file(tmp_path / "m.off")
    stages = (demo_module.STAGES[0], fails, needs_it)
    report = demo_module.demo(str(mesh), tmp_path / "o", pictures=False, stages=stages)
    assert report["sections_not_done"] == [
        "cannot (not done)",
        "A section that needs the failed section's result (not done)",
    ]
    assert (tmp_path / "o" / "summary.json").exists()
    assert "FieldShapeError" in (tmp_path / "o" / "index.html").read_text()


def _float32_ply(path: Path, mesh: fvf.TriMesh) -> Path:
    V, F = mesh.vertices.astype("<f4"), mesh.faces
    header = (
        f"ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    faces = np.zeros(len(F), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"], faces["i"] = 3, F
    path.write_bytes(header.encode() + V.tobytes() + faces.tobytes())
    return path


def test_float32_input_gives_the_float64_answer(tmp_path):
    sphere = fvf.icosphere(3)
    tet = fvf.TriMesh(
        np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=np.float32),
        np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]]),
    )
    for mesh in (sphere, tet):
        read = fvf.TriMesh(*fvf.read_mesh(_float32_ply(tmp_path / "f.ply", mesh)))
        assert read.vertices.dtype == np.float64
        for n in (1, 4):
            u = fvf.design_field(read, n=n)
            length = np.linalg.norm(u, axis=1)
            assert length.min() > 1e-3 * length.max(), (mesh.n_faces, n)
            ids, index = fvf.singularities(read, u, n=n)
            assert index.sum() == pytest.approx(2.0)
    u32 = fvf.design_field(tet, n=4)
    u64 = fvf.design_field(fvf.TriMesh(tet.vertices.astype(np.float64), tet.faces), n=4)
    np.testing.assert_allclose(u32, u64, atol=1e-6)


def test_batch_task_failure_keeps_the_other_results(tmp_path, monkeypatch):
    from fvf.batch import registry
    from fvf.batch.runner import MeshJob, run_job
    from fvf.batch.store import options_text

    def boom(ctx):
        raise errors.QuadExtractionError("no quads here")

    quad = registry.lookup_task("quad")
    monkeypatch.setitem(registry._REGISTRY, "quad", registry.Task("quad", boom))
    late = registry.Task("late", lambda ctx: registry.TaskOutput(figures={"x": 1}), needs=("quad",))
    mesh = _mesh_file(tmp_path / "dog2.off")
    tasks = ("info", "fields", "singularities", "quad", late)
    opts = {"k": 5}
    result = tmp_path / "meshes" / "dog2.npz"
    job = MeshJob("dog2", str(mesh), str(result), tasks, opts, options_text(tasks[:4], opts), "t")
    row = run_job(job)
    assert row["status"] == "failed"
    assert row["error"] == (
        "task quad: QuadExtractionError: no quads here; task late: needs quad, which failed"
    )
    assert row["result"] == str(result) and result.exists()
    assert row["singularities_index_sum"] == pytest.approx(2.0) and row["info_problems"] == 0
    with np.load(result) as data:
        assert {"v", "singularity_indices", "info_report"} <= set(data.files)
        assert "quad_quads" not in data.files
    assert run_job(job)["status"] == "failed"  # a failed task is tried again, not skipped
    monkeypatch.setitem(registry._REGISTRY, "quad", quad)

    broken = tmp_path / "broken.off"
    broken.write_text("OFF\n3 1 0\n0 0 0\n")
    job = MeshJob("b", str(broken), str(tmp_path / "meshes" / "b.npz"), ("info",), {}, "{}", "t")
    row = run_job(job)
    assert row["status"] == "failed" and row["result"] == ""  # no file is named


@pytest.mark.parametrize("level, quads", [(3, 10**8), (0, 10**6)])
def test_quad_count_bounded_by_the_input(level, quads, tmp_path, alarm, capsys):
    mesh = _mesh_file(tmp_path / "m.off", fvf.icosphere(level))
    code = main(["quad", str(mesh), "--faces", str(quads), "-o", str(tmp_path / "q.obj")])
    assert code == EXIT_BAD_INPUT
    assert "quads per input triangle" in capsys.readouterr().err
    assert not (tmp_path / "q.obj").exists()


def test_quad_count_bounded_by_the_machine(monkeypatch, alarm):
    from fvf.numerics import budget

    monkeypatch.setattr(budget, "available_memory", lambda: 2**20)  # 1 MiB
    with pytest.raises(errors.ProblemSizeError, match="GiB of memory"):
        fvf.quad_mesh(fvf.icosphere(2), target_faces=1000)


def test_available_memory_is_a_positive_size():
    from fvf.numerics.budget import available_memory

    free = available_memory()
    assert free is None or free > 0


def test_symmetry_operators_memory_scales_with_k_not_descriptors(monkeypatch, rng):
    """The reduced operators of p descriptors on m faces once took (m, 3, p) and
    (m, p, k) arrays at once (5.6 GB on 1M vertices whatever --k); now blocks."""
    import tracemalloc

    from fvf.spectral import fmap_fit

    mesh = fvf.icosphere(4)
    basis = fvf.SpectralBasis(mesh, 10)
    F = rng.normal(size=(mesh.n_vertices, 40))
    whole = [fmap_fit.orientation_operators(basis, F), fmap_fit.descriptor_operators(basis, F)]
    monkeypatch.setattr(fmap_fit, "BLOCK_BYTES", 2**20)
    tracemalloc.start()
    try:
        blocked = []
        for op in (fmap_fit.orientation_operators, fmap_fit.descriptor_operators):
            tracemalloc.reset_peak()
            base = tracemalloc.get_traced_memory()[0]
            blocked.append(op(basis, F))
            peak = tracemalloc.get_traced_memory()[1] - base
            assert peak < mesh.n_faces * 40 * 10 * 8 / 2, (op.__name__, peak)
    finally:
        tracemalloc.stop()
    for a, b in zip(whole, blocked, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12 * np.abs(a).max())


def test_nearest_rows_memory_bounded_by_its_tile(monkeypatch, rng):
    """The exhaustive nearest-row search of ZoomOut's last step once held 1024 queries by
    all n points at a time (4 GB of distances on 1M vertices whatever --k); now tiles of
    TILE_BYTES, the same answers as a float64 search."""
    import tracemalloc

    zoomout = importlib.import_module("fvf.spectral.zoomout")  # the module, not fvf.zoomout

    monkeypatch.setattr(zoomout, "TILE_BYTES", 2**20)
    points = rng.normal(size=(100_000, 20))
    queries = points[rng.choice(points.shape[0], 300)] + 1e-3 * rng.normal(size=(300, 20))
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        got = zoomout.nearest_rows(points, queries, method="brute")
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    # the float32 copy and squared norms of the points, and a few tiles with temporaries
    assert peak < 0.5 * points.nbytes + 8 * points.shape[0] + 6 * 2**20, peak
    sq = np.einsum("ij,ij->i", points, points)
    assert np.array_equal(got, (sq[None, :] - 2.0 * queries @ points.T).argmin(axis=1))


def test_symmetry_map_memory_refused_beyond_the_machine(monkeypatch):
    """A mesh whose estimated peak exceeds the available memory is refused before any
    work, naming the size and what to try."""
    from fvf.numerics import budget

    monkeypatch.setattr(budget, "available_memory", lambda: 2**28)  # 256 MiB
    with pytest.raises(errors.ProblemSizeError, match=r"2562 vertices with k = 30.*coarser"):
        fvf.symmetry_map(fvf.icosphere(4), k=30)


@pytest.mark.slow
@pytest.mark.perf
def test_symmetry_map_memory_within_its_estimate():
    """fvf.symmetry_map's traced peak on 10k vertices stays under the estimate checked
    before the work (peak_bytes: a fixed part + n (per vertex + k per vertex-eigenpair),
    nothing in n^2), and the final all-vertex search reports its progress."""
    import tracemalloc

    from fvf.spectral.correspondence import PEAK_BYTES_FIXED, peak_bytes

    mesh = fvf.jittered_sphere(5, 0.2, seed=0)
    n, k = mesh.n_vertices, 20
    seen = []
    tracemalloc.start()
    try:
        fvf.symmetry_map(mesh, k=k, progress=lambda *a: seen.append(a))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < peak_bytes(n, k), (peak, peak_bytes(n, k))
    assert peak - PEAK_BYTES_FIXED / 2 < n * 12 * 2**10  # per vertex: a few KiB, not n
    assert ("nearest", n, n) in seen


def test_quad_cross_field_stage_reports_its_parts():
    """On 2M faces the cross field took 2 minutes with one line; its parts are reported."""
    seen = []
    fvf.quad_mesh(fvf.icosphere(3), target_faces=200, progress=lambda *a: seen.append(a[0]))
    parts = [s for s in seen if s.startswith("cross field: ")]
    assert "cross field: assemble: connection Laplacian" in parts
    assert "cross field: solve" in parts
    assert seen.index("cross field") < seen.index(parts[0])


def test_local_cluster_that_cannot_start_is_a_typed_error(tmp_path, monkeypatch, capsys):
    """Under a memory limit the workers' nannies fail ("Nanny failed to start."): a
    BatchInputError naming the cluster and what to try, exit 2 from the command."""
    distributed = pytest.importorskip("distributed")

    def failing(*args, **kwargs):
        raise RuntimeError("Nanny failed to start.")

    monkeypatch.setattr(distributed, "LocalCluster", failing)
    mesh = _mesh_file(tmp_path / "m.off")
    with pytest.raises(errors.BatchInputError, match=r"local Dask cluster of 2 worker.*--workers"):
        fvf.batch.run([mesh], tmp_path / "out", workers=2, progress=False)
    assert main(["batch", str(mesh), "-o", str(tmp_path / "o2"), "--workers", "2"]) == 2
    assert "Nanny failed to start" in capsys.readouterr().err


def test_local_cluster_that_never_starts_times_out(tmp_path, monkeypatch):
    """Workers that keep dying under ``ulimit -v`` (measured: about 420 MB for two) left
    LocalCluster waiting for ever: a BatchInputError after START_TIMEOUT."""
    import threading
    import time

    distributed = pytest.importorskip("distributed")
    from fvf.batch import driver

    never = threading.Event()
    monkeypatch.setattr(distributed, "LocalCluster", lambda *a, **k: never.wait())
    monkeypatch.setattr(driver, "START_TIMEOUT", 1.0)
    mesh = _mesh_file(tmp_path / "m.off")
    start = time.perf_counter()
    with pytest.raises(errors.BatchInputError, match="did not start within 1 s"):
        fvf.batch.run([mesh], tmp_path / "out", workers=2, progress=False)
    assert time.perf_counter() - start < 10
    never.set()


def test_silent_scheduler_times_out(tmp_path, monkeypatch, alarm):
    """A server that accepts the connection and never answers: BatchInputError after the
    connect timeout (was: silent for minutes)."""
    pytest.importorskip("distributed")
    import socket
    import threading
    import time

    from fvf.batch import driver

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held = []
    threading.Thread(target=lambda: held.append(server.accept()), daemon=True).start()
    monkeypatch.setattr(driver, "CONNECT_TIMEOUT", 1.0)
    mesh = _mesh_file(tmp_path / "m.off")
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    start = time.perf_counter()
    try:
        with pytest.raises(errors.BatchInputError, match="no answer within 1 s"):
            fvf.batch.run([mesh], tmp_path / "out", scheduler=address, progress=False)
    finally:
        server.close()
    assert time.perf_counter() - start < 15


@pytest.fixture
def read_only(tmp_path):
    """A folder nobody can write into: a read-only tmpfs (root), else mode 0o555."""
    folder = tmp_path / "ro"
    folder.mkdir()
    mounted = False
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        done = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(folder)],
            capture_output=True,
        )
        if done.returncode != 0:
            pytest.skip("root, and cannot mount a read-only tmpfs here")
        mounted = True
    else:
        folder.chmod(0o555)
    try:
        yield folder
    finally:
        if mounted:
            subprocess.run(["umount", str(folder)], capture_output=True)
        else:
            folder.chmod(0o755)


def _commands_writing_to(ro: Path, mesh: Path, data: Path) -> list[list[str]]:
    m, d, here = str(mesh), str(data), mesh.parent
    k = ["--k", "20", "--k-fit", "8"]
    return [
        ["repair", m, "-o", f"{ro}/r.off"],
        ["flow", m, d, "--t", "0.1", "-o", f"{ro}/f.npz"],
        ["flow", m, d, "--t", "0.1", "-o", f"{mesh.parent}/f.npz", "--png", f"{ro}/f.png"],
        ["bracket", m, d, "--first", "v", "--second", "u", "-o", f"{ro}/b.npz"],
        ["transport", m, d, "--t", "0.1", "--field", "v", "--transported", "u", "-o", f"{ro}/t"],
        ["design", m, "-o", f"{ro}/d.npz"],
        ["quad", m, "--faces", "300", "-o", f"{ro}/q.obj"],
        ["quad", m, "--faces", "300", "-o", f"{mesh.parent}/q.obj", "--uv", f"{ro}/uv.obj"],
        ["match", m, m, *k, "-o", f"{ro}/m.npz"],
        ["match", m, m, *k, "-o", f"{here}/m.npz", "--png", f"{ro}/m.png"],
        ["symmetry", m, *k, "-o", f"{ro}/y.npz"],
        ["symmetry", m, *k, "-o", f"{here}/y.npz", "--png", f"{ro}/y.png"],
        ["render", m, d, "--field", "v", "-o", f"{ro}/p.png"],
        ["demo", "--mesh", m, "--out", f"{ro}/demo"],
        ["demo", "--mesh", m, "--out", str(ro)],
        ["batch", m, "-o", f"{ro}/out", "--workers", "1", "--quiet"],
        ["batch", m, "-o", str(ro), "--workers", "1", "--quiet"],
    ]  # fmt: skip


def test_read_only_output_folder_exits_5_for_every_command(read_only, tmp_path, capsys, alarm):
    from fvf.cli.registry import registered_commands

    work = tmp_path / "in"
    work.mkdir()
    mesh = _mesh_file(work / "s.off", fvf.icosphere(2))
    sphere = fvf.icosphere(2)
    c = sphere.face_centroids
    data = work / "d.npz"
    np.savez(
        data,
        v=sphere.project_tangent(np.cross(c, [0, 0, 1])),
        u=sphere.project_tangent(np.cross(c, [1, 0, 0])),
        f=sphere.vertices[:, 0],
    )
    runs = _commands_writing_to(read_only, mesh, data)
    writing = set(registered_commands()) - {"info", "view"}
    assert writing == {argv[0] for argv in runs}  # a new command joins this sweep
    before = sorted(work.iterdir())
    for argv in runs:
        assert main(argv) == EXIT_WRITE_FAILED, (argv, capsys.readouterr().err)
        assert "OutputWriteError" in capsys.readouterr().err
        assert list(read_only.iterdir()) == [] and sorted(work.iterdir()) == before, argv


def _sweep_inputs(folder: Path) -> dict[str, Path]:
    """Every kind of input a command reads, generated: a PLY mesh (a PLY is also a data
    output, so ``-o`` can name it), a data file, constraints, features, landmarks, truth."""
    sphere = fvf.icosphere(2)
    c = sphere.face_centroids
    paths = {
        "mesh": _mesh_file(folder / "s.ply", sphere),
        "mesh2": _mesh_file(folder / "s2.ply", sphere),
        "data": folder / "d.npz",
        "constraints": folder / "c.npz",
        "features": folder / "feat.txt",
        "landmarks": folder / "lmk.txt",
        "truth": folder / "t.txt",
    }
    v = sphere.project_tangent(np.cross(c, [0, 0, 1]))
    np.savez(paths["data"], v=v, u=sphere.project_tangent(np.cross(c, [1, 0, 0])))
    np.savez(paths["constraints"], constraint_faces=np.array([0]), directions=v[:1])
    e = sphere.edges[0]
    paths["features"].write_text(f"{e[0]} {e[1]}\n")
    paths["landmarks"].write_text("0 0\n5 5\n")
    paths["truth"].write_text("\n".join(map(str, range(sphere.n_vertices))) + "\n")
    return paths


def _sweep_commands(p: dict[str, Path], out: Path) -> list[tuple[list[str], dict[str, str]]]:
    """(argv with its inputs, {output option: a fresh path}) of every writing command."""
    m, d = str(p["mesh"]), str(p["data"])
    k = ["--k", "20", "--k-fit", "8"]
    return [
        (["repair", m], {"-o": f"{out}/r.ply"}),
        (["flow", m, d, "--t", "0.1"], {"-o": f"{out}/f.npz", "--png": f"{out}/f.png"}),
        (["bracket", m, d, "--first", "v", "--second", "u"], {"-o": f"{out}/b.npz"}),
        (["transport", m, d, "--t", "0.1", "--field", "v", "--transported", "u"],
         {"-o": f"{out}/t.npz"}),
        (["design", m, "--constraints", str(p["constraints"])], {"-o": f"{out}/d.npz"}),
        (["quad", m, d, "--faces", "300", "--field", "v", "--features", str(p["features"])],
         {"-o": f"{out}/q.obj", "--uv": f"{out}/uv.obj", "--png": f"{out}/q.png"}),
        (["match", m, str(p["mesh2"]), *k, "--landmarks", str(p["landmarks"]), "--truth",
          str(p["truth"])], {"-o": f"{out}/m.npz", "--png": f"{out}/m.png"}),
        (["symmetry", m, *k], {"-o": f"{out}/y.npz", "--png": f"{out}/y.png"}),
        (["render", m, d, "--field", "v"], {"-o": f"{out}/p.png"}),
    ]  # fmt: skip


#: Commands whose -o is a data file: ``.npz`` is appended to a name without a data suffix.
_DATA_OUTPUTS = {"flow", "bracket", "transport", "design", "match", "symmetry"}


def test_every_output_named_after_every_input_is_refused(tmp_path, capsys, alarm):
    """Each output option of each command, named after each of its inputs (a derived
    name too: ``--png NAME`` writes NAME_errors beside NAME), is refused before any work
    (exit 2), and every input keeps its bytes."""
    from fvf.cli.registry import registered_commands

    folder = tmp_path / "in"
    folder.mkdir()
    p = _sweep_inputs(folder)
    out = tmp_path / "out"
    out.mkdir()
    commands = _sweep_commands(p, out)
    assert {argv[0] for argv, _ in commands} == set(registered_commands()) - {
        "info", "view", "demo", "batch"  # no outputs; a folder of own names; own tests
    }  # fmt: skip
    before = {path: path.read_bytes() for path in p.values()}
    cases = 0
    for argv, outputs in commands:
        used = [path for path in p.values() if str(path) in argv]
        for option in outputs:
            for path in used:
                if option == "-o" and argv[0] in _DATA_OUTPUTS and data_path(path) != path:
                    continue  # -o lmk.txt writes lmk.txt.npz: another file
                named = {**outputs, option: str(path)}
                full = argv + [x for o, name in named.items() for x in (o, name)]
                assert main(full) == EXIT_BAD_INPUT, (full, capsys.readouterr().err)
                assert "replace an input" in capsys.readouterr().err, full
                assert {q: q.read_bytes() for q in p.values()} == before, full
                assert list(out.iterdir()) == [], full
                cases += 1
    # derived names: match's --png NAME also writes NAME_errors.SUFFIX
    for victim in ("truth", "landmarks"):
        argv, outputs = commands[6]
        twin = p[victim].with_name("x_errors.png")
        p[victim].rename(twin)
        full = [twin if a == str(p[victim]) else a for a in argv]
        full = [str(a) for a in full] + ["-o", outputs["-o"], "--png", str(folder / "x.png")]
        assert main(full) == EXIT_BAD_INPUT, full
        assert "replace an input" in capsys.readouterr().err
        twin.rename(p[victim])
        assert {q: q.read_bytes() for q in p.values()} == before
    assert cases > 25


@pytest.mark.parametrize("scale", [1e300, 1e-300, 1e200])
def test_repair_at_extreme_scales_keeps_every_face(scale):
    """1e300-scaled coordinates overflowed the area test (faces removed as "zero area")
    and 1e-300 underflowed it (every face removed); the rule is scale-free."""
    mesh = fvf.icosphere(1)
    with _no_warning():
        reference = fvf.repair_mesh(mesh.vertices, mesh.faces)
        result = fvf.repair_mesh(mesh.vertices * scale, mesh.faces)
    np.testing.assert_array_equal(result.faces, reference.faces)
    assert result.log == reference.log == ()
    inside_out = mesh.faces[:, ::-1]
    with _no_warning():
        expected = fvf.repair_mesh(mesh.vertices, inside_out, ["orient_faces"]).faces
        flipped = fvf.repair_mesh(mesh.vertices * scale, inside_out, ["orient_faces"]).faces
    np.testing.assert_array_equal(flipped, expected)


def test_progress_with_the_wrong_signature_is_refused_before_work():
    with pytest.raises(errors.ParameterError, match=r"progress\(stage, done, total\)"):
        fvf.SpectralBasis(fvf.icosphere(2), 5, progress=lambda stage: None)
    fvf.SpectralBasis(fvf.icosphere(2), 5, progress=lambda *a, **k: None)  # any (s, d, t)


def test_pyvista_triangle_strips_are_triangles():
    pv = pytest.importorskip("pyvista")
    sphere = pv.Sphere()
    mesh = fvf.as_mesh(sphere.strip())
    assert mesh.n_faces == sphere.n_cells and mesh.is_closed


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".off", ".stl"])
def test_non_ascii_output_paths(suffix, tmp_path):
    mesh = _mesh_file(tmp_path / "s.off")
    folder = tmp_path / "résumé"
    folder.mkdir()
    out = folder / f"fïxé_ü{suffix}"
    assert main(["repair", str(mesh), "-o", str(out)]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fvf.VerticesWeldedWarning)  # STL's corners
        V, F = fvf.read_mesh(out)
    assert F.shape == (80, 3)
    if suffix == ".ply":
        data = folder / "dé.ply"
        assert main(["design", str(out), "-o", str(data)]) == 0
        assert read_data(data, fvf.TriMesh(V, F)).field("v", fvf.TriMesh(V, F)).shape == (80, 3)


def _fvf_command(*argv: str) -> list[str]:
    return [sys.executable, "-m", "fvf", *argv]


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(Path(fvf.__file__).parents[1])}


def test_full_stdout_and_closed_pipe_keep_the_work(tmp_path):
    """`fvf repair … >/dev/full` and `fvf quad … 2>&1 | head -1` lose their messages,
    not their files, and exit with the status of the work."""
    mesh = _mesh_file(tmp_path / "s.off", fvf.icosphere(2))
    if os.path.exists("/dev/full"):
        with open("/dev/full", "w") as full:
            done = subprocess.run(
                _fvf_command("repair", str(mesh), "-o", str(tmp_path / "r.off")),
                stdout=full, stderr=subprocess.PIPE, env=_env(), timeout=120,
            )  # fmt: skip
        assert done.returncode == 0, done.stderr
        assert (tmp_path / "r.off").exists() and (tmp_path / "r.maps.npz").exists()
    out = tmp_path / "q.obj"
    proc = subprocess.Popen(
        _fvf_command("quad", str(mesh), "--faces", "300", "-o", str(out)),
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=_env(),
    )  # fmt: skip
    assert proc.stdout is not None
    proc.stdout.readline()  # head -1
    proc.stdout.close()
    assert proc.wait(timeout=120) == 0
    assert sum(line.startswith("f ") for line in out.read_text().splitlines()) > 200


def test_batch_results_folder_that_is_a_file(tmp_path, capsys):
    pytest.importorskip("distributed")
    mesh = _mesh_file(tmp_path / "s.off")
    out = tmp_path / "out"
    out.mkdir()
    (out / "meshes").write_text("mine")
    argv = ["batch", str(mesh), "-o", str(out), "--workers", "1", "--quiet"]
    assert main(argv) == EXIT_BAD_INPUT
    assert "meshes is a file" in capsys.readouterr().err
    assert (out / "meshes").read_text() == "mine"


def test_long_output_names_are_written(tmp_path):
    """A 250-character name is valid; its temporary (``.NAME.<hex>.npz``) was not."""
    name = "a" * 250
    mesh = _mesh_file(tmp_path / f"{name}.off")
    assert main(["design", str(mesh), "-o", str(tmp_path / f"{name}.npz")]) == 0
    assert (tmp_path / f"{name}.npz").exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_ply_times_are_times_when_there_are_as_many_as_vertices(tmp_path):
    """A flow with T = n times wrote ``f_t_j`` as vertex j's history and the times as a
    vertex function; (n, 3) functions came out as a vector ``fx fy fz``."""
    mesh = _strip()
    n = mesh.n_vertices
    fvf.write_mesh(tmp_path / "m.off", mesh.vertices, mesh.faces)
    v = mesh.project_tangent(np.cross(mesh.face_centroids, [0, 0, 1]))
    np.savez(tmp_path / "d.npz", v=v, f=mesh.vertices[:, 2].copy())
    times = [str(x) for x in np.linspace(0, 0.5, n)]
    base = ["flow", str(tmp_path / "m.off"), str(tmp_path / "d.npz"), "--t", *times]
    assert main([*base, "-o", str(tmp_path / "a.npz")]) == 0
    assert main([*base, "-o", str(tmp_path / "a.ply")]) == 0
    vertex, face = fvf.io.read_ply_properties(tmp_path / "a.ply")
    assert "t" not in vertex and set(face) == {"vx", "vy", "vz"}
    with np.load(tmp_path / "a.npz") as ref:
        for i in (0, 3, n - 1):
            np.testing.assert_array_equal(vertex[f"f_t_{i}"], ref["f_t"][i])  # time i
    np.savez(tmp_path / "f3.npz", f=np.arange(3.0 * n).reshape(n, 3), v=v)
    three = ["flow", str(tmp_path / "m.off"), str(tmp_path / "f3.npz"), "--t", "0.1"]
    assert main([*three, "-o", str(tmp_path / "b.ply")]) == 0
    vertex, _ = fvf.io.read_ply_properties(tmp_path / "b.ply")
    assert {"f_0", "f_1", "f_2", "f_t_0_0", "f_t_0_1", "f_t_0_2"} <= set(vertex)
    np.testing.assert_array_equal(vertex["f_1"], np.arange(3.0 * n).reshape(n, 3)[:, 1])


def test_info_tells_touching_from_cut_and_names_needles(tmp_path, capsys):
    s = fvf.icosphere(2)
    touching = tmp_path / "touch.off"  # two closed spheres meeting at one point
    fvf.write_mesh(touching, np.vstack([s.vertices, s.vertices + [2, 0, 0]]),
                   np.vstack([s.faces, s.faces + s.n_vertices]))  # fmt: skip
    assert main(["info", str(touching)]) == 0
    out = capsys.readouterr().out
    assert "touches itself" in out and "To weld them" not in out
    soup = tmp_path / "soup.off"  # a cut: an unwelded disk
    d = fvf.disk(3, 6)
    fvf.write_mesh(
        soup, d.vertices[d.faces].reshape(-1, 3), np.arange(3 * d.n_faces).reshape(-1, 3)
    )
    main(["info", str(soup)])
    assert "To weld them" in capsys.readouterr().out
    V = s.vertices.copy()
    a, b, c = s.faces[0]
    V[c] = 0.5 * (V[a] + V[b]) + 0.0035 * (V[c] - 0.5 * (V[a] + V[b]))  # a 0.4 degree needle
    needle = tmp_path / "needle.off"
    fvf.write_mesh(needle, V, s.faces)
    main(["info", str(needle)])
    assert "faces [0] (1 in all) are needles" in capsys.readouterr().out


def test_info_fix_for_a_nonmanifold_edge_is_what_repair_does(tmp_path, capsys):
    t = fvf.icosphere(0)
    a, b, _ = t.faces[0]
    fin = tmp_path / "fin.off"  # a third face on edge (a, b)
    fvf.write_mesh(fin, np.vstack([t.vertices, [[3, 3, 3]]]),
                   np.vstack([t.faces, [[a, b, t.n_vertices]]]))  # fmt: skip
    assert main(["info", str(fin)]) == 1
    assert "Fixed by `fvf repair` (step split_nonmanifold_edges)" in capsys.readouterr().out
    fixed = tmp_path / "fin_fixed.off"
    assert main(["repair", str(fin), "-o", str(fixed)]) == 0
    assert main(["info", str(fixed)]) == 0


@pytest.mark.parametrize("text", ["0.5", "nan", "1e3", "99999999999999999999999"])
def test_non_integer_truth_and_pair_maps_name_file_and_line(text, tmp_path, capsys):
    from fvf.batch.registry import PairContext

    n = fvf.icosphere(1).n_vertices
    bad = tmp_path / "t.txt"
    bad.write_text("# truth\n" + "0\n" * 3 + f"{text}\n" + "0\n" * (n - 4))
    assert main([*_match_args(tmp_path), "--truth", str(bad)]) == EXIT_BAD_INPUT
    assert f"{bad}: the ground truth must be 1 integer(s) per line; line 5 is" in (
        capsys.readouterr().err
    )
    mesh = fvf.icosphere(1)

    class Side:
        def __init__(self):
            self.mesh, self.path = mesh, tmp_path / "a.off"

    with pytest.raises(ValueError, match="line 5"):
        PairContext(Side(), Side(), str(bad), {}).point_map()


def test_cannot_start_a_thread_is_explained(tmp_path, monkeypatch, capsys):
    """Under a small ``ulimit -v`` Python says "can't start new thread"; fvf says which
    limit and what to do, on the command line and in batch rows."""
    from fvf.batch import runner

    def no_thread(*args, **kwargs):
        raise RuntimeError("can't start new thread")

    mesh = _mesh_file(tmp_path / "m.off")
    monkeypatch.setattr(fvf, "design_field", no_thread)
    assert main(["design", str(mesh), "-o", str(tmp_path / "d.npz")]) == 4
    assert "ulimit -v" in capsys.readouterr().err
    assert "ulimit -v" in runner._one_line(RuntimeError("can't start new thread"))


def test_laplace_basis_counts_a_tiny_components_zero_eigenvalue():
    s, t = fvf.icosphere(2), fvf.icosphere(0)
    V = np.vstack([s.vertices, t.vertices * 1e-3 + [5, 0, 0]])
    F = np.vstack([s.faces, t.faces + s.n_vertices])
    basis = fvf.laplace_basis(fvf.TriMesh(V, F), 5)
    lam = np.asarray(basis.eigenvalues if hasattr(basis, "eigenvalues") else basis[0])
    assert np.abs(lam[:2]).max() < 1e-8 and lam[2] > 1.0


_TEARDOWN_PRESS = """
import os, subprocess, sys, time
from fvf.cli.main import _exit_on_next_interrupt

class SlowTeardown:  # a module global: deleted while the interpreter tears modules down
    def __del__(self):
        sys.stderr.write("teardown\\n")
        time.sleep(3.0)

keep = SlowTeardown()
_exit_on_next_interrupt()  # as after an interrupted command
subprocess.Popen(["sh", "-c", f"sleep 1; kill -INT {os.getpid()}"])
sys.exit(130)
"""


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="POSIX signals")
def test_a_press_while_the_interpreter_tears_down_is_exit_130(tmp_path):
    """After its exit hooks the interpreter resets every Python-level SIGINT handler
    (fvf's quiet-exit one included) to the system default, then tears its modules down
    (long with Dask loaded): a Ctrl-C then killed ``fvf batch`` by SIGINT. fvf's last
    exit hook leaves SIGINT ignored instead, so the status stays 130."""
    script = tmp_path / "teardown.py"
    script.write_text(_TEARDOWN_PRESS)
    done = subprocess.run(
        [sys.executable, str(script)], env=_env(), capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 130, (done.returncode, done.stderr)
    assert "teardown" in done.stderr and "Traceback" not in done.stderr
