"""fvf.batch and ``fvf batch``: results equal the library's, failures are rows, nothing is
lost or repeated (atomic results, resume by content hash), workers that die are replaced.

The default tests share one local Dask cluster of 2 worker processes (module fixture);
the tests that kill workers, interrupt the command or start a separate scheduler and
workers are ``slow``.
"""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import fvf
import fvf.batch
from conftest import SHARED_MESHES, shared_mesh_path
from fvf.batch import driver as batch_driver
from fvf.batch.inputs import find_meshes, plan_inputs, read_pairs, unique_names
from fvf.batch.registry import resolve_tasks
from fvf.batch.runner import MeshJob, run_job, run_jobs
from fvf.batch.store import options_text, output_lock, write_summary
from fvf.cli.main import EXIT_BAD_INPUT, EXIT_OK, EXIT_PROBLEMS, EXIT_UNAVAILABLE, main

distributed = pytest.importorskip("distributed")

K = 6  # eigenpairs: small, so that the batch tests stay fast
SRC = str(Path(fvf.__file__).resolve().parents[1])
ENV = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
SHARED_SMALL = ["decimated-knight.off", "woody.obj", "spot.obj"]


# ---------------------------------------------------------------------------- corpus
def _write(path: Path, mesh) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    return path


def _nonmanifold():
    """An icosphere with a fin: a third triangle on one of its edges."""
    m = fvf.icosphere(1)
    a, b = m.faces[0, 0], m.faces[0, 1]
    V = np.vstack([m.vertices, 2.0 * m.vertices[m.faces[0]].mean(0)])
    F = np.vstack([m.faces, [[a, b, len(m.vertices)]]])
    return V, F


def make_corpus(folder: Path, shared: bool = True) -> dict[str, dict]:
    """Good and broken mesh files; returns {name: {"path", "good", "error"}}."""
    good = {
        "icosphere": _write(folder / "gen" / "icosphere.off", fvf.icosphere(2)),
        "torus": _write(folder / "gen" / "torus.obj", fvf.torus(20, 10)),
        "disk": _write(folder / "gen" / "disk.ply", fvf.disk(5, 5)),
    }
    corpus = {name: {"path": p, "good": True} for name, p in good.items()}
    if shared and SHARED_MESHES.is_dir():
        for name in SHARED_SMALL:
            corpus[Path(name).stem] = {"path": shared_mesh_path(name), "good": True}
    truncated = _write(folder / "bad" / "truncated.off", fvf.torus(20, 10))
    full = truncated.read_text()
    truncated.write_text(full[: len(full) // 2])  # cut in the middle of the vertex lines
    nonmanifold = folder / "bad" / "nonmanifold.off"
    fvf.write_mesh(nonmanifold, *_nonmanifold())
    notes = folder / "bad" / "notes.txt"
    notes.write_text("this is not a mesh\n")
    corpus["truncated"] = {"path": truncated, "good": False, "error": "MeshReadError"}
    corpus["nonmanifold"] = {"path": nonmanifold, "good": False, "error": "NonManifoldError"}
    corpus["notes"] = {"path": notes, "good": False, "error": "MeshReadError"}
    return corpus


def direct(path: Path, k: int = K) -> dict[str, np.ndarray]:
    """The default tasks' arrays, from the library called directly."""
    mesh = fvf.TriMesh(*fvf.read_mesh(path))
    lam, phi = fvf.laplace_basis(mesh, k)
    v = fvf.design_field(mesh)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fvf.FvfWarning)
        ids, index = fvf.singularities(mesh, v, zero="warn")
    return {
        "vertices": mesh.vertices,
        "faces": mesh.faces,
        "eigenvalues": lam,
        "eigenfunctions": phi,
        "v": v,
        "singularity_vertices": ids,
        "singularity_indices": index,
        "singularity_positions": fvf.singularity_positions(mesh, ids, "vertex"),
    }


def assert_same_results(result: Path, expected: dict[str, np.ndarray]) -> None:
    with np.load(result, allow_pickle=False) as data:
        for key, want in expected.items():
            got = data[key]
            assert got.shape == want.shape, key
            if key == "eigenfunctions":  # eigenvectors are defined up to sign
                signs = np.sign((got * want).sum(axis=0))  # one function per column
                got = got * signs[None, :]
            np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-11, err_msg=key)


def rows_by_mesh(table) -> dict[str, dict]:
    records = table.to_dict("records") if hasattr(table, "to_dict") else table
    return {r["mesh"]: r for r in records}


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def no_temporaries(out: Path) -> bool:
    return not [p for p in out.rglob(".*") if p.name != ".fvf-batch.lock"]


# ---------------------------------------------------------------------------- cluster
@pytest.fixture(scope="module")
def client():
    """A local cluster of 2 single-threaded worker processes, as fvf.batch starts it."""
    import dask

    with dask.config.set(batch_driver.local_cluster_config(retries=2)):
        cluster = distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
            memory_limit="4GB",
            silence_logs=40,
        )
        with distributed.Client(cluster) as c:
            yield c
        cluster.close()


# ---------------------------------------------------------------------------- without dask
def test_import_fvf_does_not_import_dask():
    code = (
        "import sys, fvf, fvf.batch; fvf.batch.registered_tasks(); "
        "bad = [m for m in ('dask', 'distributed', 'pandas', 'tqdm') if m in sys.modules]; "
        "sys.exit(1 if bad else 0)"
    )
    assert subprocess.run([sys.executable, "-c", code], env=ENV).returncode == 0


def test_missing_dask_is_a_missing_extra_error(monkeypatch, tmp_path):
    _write(tmp_path / "a.off", fvf.icosphere(1))
    monkeypatch.setitem(sys.modules, "distributed", None)
    monkeypatch.setitem(sys.modules, "dask", None)
    with pytest.raises(fvf.MissingExtraError, match=r"pip install 'fvf\[batch\]'"):
        fvf.batch.run([tmp_path / "a.off"], tmp_path / "out")
    status = main(["batch", str(tmp_path / "a.off"), "-o", str(tmp_path / "out")])
    assert status == EXIT_UNAVAILABLE
    assert not (tmp_path / "out").exists()  # nothing started, nothing written


def test_cli_help_lists_the_tasks(capsys):
    assert main(["batch", "--help"]) == 0
    out = capsys.readouterr().out
    assert "example:" in out and "fvf batch" in out and "exit status" in out
    for name, task in fvf.batch.registered_tasks().items():
        assert f"{name} " in out and task.description[:30] in " ".join(out.split())


def test_find_meshes_files_folders_globs(tmp_path):
    a = _write(tmp_path / "a" / "x.off", fvf.icosphere(1))
    b = _write(tmp_path / "b" / "x.off", fvf.icosphere(1))
    c = _write(tmp_path / "b" / "deep" / "y.ply", fvf.icosphere(1))
    (tmp_path / "b" / "readme.txt").write_text("not a mesh")
    (tmp_path / "b" / ".hidden.off").write_text("OFF\n")
    found = find_meshes([tmp_path / "a", str(tmp_path / "b" / "**" / "*.ply"), tmp_path / "b"])
    assert found == [a.resolve(), c.resolve(), b.resolve()]  # each once, first seen first
    explicit = find_meshes([tmp_path / "b" / "readme.txt"])  # an explicit file is a job
    assert explicit == [(tmp_path / "b" / "readme.txt").resolve()]
    with pytest.raises(fvf.BatchInputError, match=r"nothere\.off.*no mesh file.*empty"):
        (tmp_path / "empty").mkdir()
        find_meshes([tmp_path / "nothere.off", tmp_path / "empty", a])


def test_unique_names_for_colliding_stems(tmp_path):
    paths = [
        tmp_path / "a" / "x.off",
        tmp_path / "b" / "x.off",
        tmp_path / "c" / "y.off",
        tmp_path / "c" / "y.obj",
        tmp_path / "d" / "Z.ply",
        tmp_path / "e" / "z.ply",
        tmp_path / "f" / "odd name!.off",
    ]
    names = unique_names(paths)
    assert names == ["a__x", "b__x", "y.off", "y.obj", "d__Z", "e__z", "odd_name_"]
    assert len({n.lower() for n in names}) == len(names)
    assert unique_names(paths) == names  # the same inputs give the same names


def test_read_pairs_and_its_errors(tmp_path):
    a = _write(tmp_path / "a.off", fvf.icosphere(1))
    b = _write(tmp_path / "sub" / "a.off", fvf.icosphere(1))
    (tmp_path / "map.txt").write_text("\n".join(map(str, range(42))))
    good = tmp_path / "pairs.csv"
    good.write_text("source,target,map\n# a comment\n\na.off,sub/a.off\na.off,sub/a.off,map.txt\n")
    rows = read_pairs(good)
    assert rows == [(a, b, None), (a, b, tmp_path / "map.txt")]
    meshes, pairs = plan_inputs([], good)
    assert meshes == [] and [p.name for p in pairs] == [
        "a--sub__a",
        "a--sub__a-" + pairs[1].name[-4:],
    ]
    bad = tmp_path / "bad.csv"
    bad.write_text("a.off\na.off,missing.off\n")
    with pytest.raises(fvf.BatchInputError, match=r"lines \[1\].*line 2: .*missing\.off"):
        read_pairs(bad)
    with pytest.raises(fvf.BatchInputError, match="cannot read the pairs file"):
        read_pairs(tmp_path / "none.csv")
    with pytest.raises(fvf.BatchInputError, match="mesh files .* or a pairs file"):
        plan_inputs([], None)


def test_resolve_tasks_orders_and_checks():
    names = [t.name for t in resolve_tasks(["singularities", "info", "repair"], {"k": 5})]
    assert names == ["repair", "info", "fields", "singularities"]  # raw first, needs before
    with pytest.raises(fvf.ParameterError, match="unknown batch task 'eigen'.*basis"):
        resolve_tasks(["eigen"], {})
    with pytest.raises(fvf.ParameterError, match="k .* integer >= 1"):
        resolve_tasks(["basis"], {"k": 0})
    if not fvf.batch.registry.accepts(fvf.design_field, "n"):
        with pytest.raises(fvf.ParameterError, match="n = 4 asks for N-fields"):
            resolve_tasks(["fields"], {"n": 4})
    resolve_tasks(["fields"], {"n": 1})  # n = 1 is an ordinary field
    if hasattr(fvf, "match"):
        assert fvf.batch.registered_tasks()["match"].kind == "pair"
    else:
        assert "match" not in fvf.batch.registered_tasks()
    assert ("quad" in fvf.batch.registered_tasks()) == hasattr(fvf, "quad_mesh")


def test_output_of_adapts_library_results():
    from collections import namedtuple

    from fvf.batch.tasks import output_of

    assert list(output_of(np.zeros(3), "q").arrays) == ["q"]
    Result = namedtuple("Result", "p2p error mesh name")
    out = output_of(Result(np.arange(4), 0.25, fvf.icosphere(0), "x"), "match")
    assert set(out.arrays) == {"match_p2p", "match_mesh_vertices", "match_mesh_faces"}
    assert out.figures == {"error": 0.25}
    out = output_of((np.ones(2), np.zeros((2, 2))), "quad")
    assert set(out.arrays) == {"quad_0", "quad_1"}


def test_results_written_meanwhile_are_found_by_their_stamps_not_the_clock(tmp_path):
    """After an interrupt the driver reads back the rows of results that changed since
    the batch started: by (inode, mtime, size), so a file system with coarse times (an
    mtime before the start) or another host's clock loses none; a result that was there
    before is not taken for new; one whose input is gone meanwhile is left to the rerun
    (no exception in the cleanup, which would skip writing the summary)."""
    tasks, opts = ("info",), {"k": K, "n": None}
    jobs = [
        MeshJob(f"m{i}", str(_write(tmp_path / f"m{i}.off", fvf.icosphere(1))),
                str(tmp_path / "out" / f"m{i}.npz"), tasks, opts, options_text(tasks, opts), "t")
        for i in range(4)
    ]  # fmt: skip
    run_job(jobs[2])  # done before the batch
    before = batch_driver._result_stamps(jobs)
    assert before[0] is None and before[2] is not None
    for j in (0, 1, 3):
        assert run_job(jobs[j])["status"] == "ok"
    os.utime(jobs[0].result, ns=(0, 0))  # a coarse or skewed clock: "written" in 1970
    os.remove(jobs[1].path)  # its input removed while the batch ran
    found = batch_driver._written_meanwhile(jobs, {3: {"mesh": "m3"}}, before)
    assert sorted(found) == [0] and found[0]["mesh"] == "m0" and found[0]["status"] == "ok"


def test_run_job_without_dask_resumes_by_content_hash(tmp_path):
    """The worker side alone: ok, then skipped; recomputed when input or options change."""
    path = _write(tmp_path / "m.off", fvf.icosphere(2))
    result = tmp_path / "out" / "m.npz"

    def job(k):
        tasks = ("info", "basis", "fields", "singularities")
        opts = {"k": k, "n": None}
        return MeshJob("m", str(path), str(result), tasks, opts, options_text(tasks, opts), "t")

    first = run_job(job(K))
    assert first["status"] == "ok", first
    assert (first["n"], first["m"], first["chi"]) == (162, 320, 2)
    assert first["singularities_index_sum"] == pytest.approx(2.0)  # Poincare-Hopf: chi
    assert first["info_problems"] == 0 and first["peak_mb"] > 10
    assert_same_results(result, direct(path))
    stamp = result.stat().st_mtime_ns
    again = run_job(job(K))
    assert again["status"] == "skipped" and result.stat().st_mtime_ns == stamp
    assert again["basis_lambda_1"] == first["basis_lambda_1"]  # the stored figures
    assert run_job(job(K + 1))["status"] == "ok"  # other options: recomputed
    assert np.load(result)["eigenvalues"].shape == (K + 1,)
    _write(path, fvf.icosphere(1))  # other contents, same name: recomputed
    assert run_job(job(K + 1))["n"] == 42


@pytest.mark.slow  # 6-8 s
def test_quad_task_is_fvf_quad_with_its_figures(tmp_path):
    """The quad task makes the quads fvf.quad_mesh makes by default (not from the fields
    task's field), stores them by name and puts fvf.quad_quality's scalars in the row."""
    mesh = fvf.mesh.builtin.spot()
    path = _write(tmp_path / "spot.off", mesh)
    V, Q = fvf.quad_mesh(fvf.TriMesh(*fvf.read_mesh(path)))

    def job(tasks, n):
        opts = {"n": n}
        result = str(tmp_path / "out" / f"{'-'.join(tasks)}.npz")
        return MeshJob("spot", str(path), result, tasks, opts, options_text(tasks, opts), "t")

    for tasks, n in ((("quad",), None), (("fields", "quad"), 4)):
        j = job(tasks, n)
        row = run_job(j)
        assert row["status"] == "ok", row
        with np.load(j.result) as data:
            np.testing.assert_array_equal(data["quad_quads"], Q)
            np.testing.assert_allclose(data["quad_vertices"], V, rtol=0, atol=1e-12)
        assert row["quad_n_quads"] == Q.shape[0] and row["quad_closed"] is True
        assert row["quad_n_folded"] == 0 and 0 <= row["quad_irregular_fraction"] < 0.1
        assert row["quad_euler_characteristic"] == 2


def test_quad_task_takes_the_quad_count_and_the_fallback(tmp_path):
    """``quads`` is the target of fvf.quad_mesh (the same quads as the call), ``fallback``
    passed on; a split-free result says 0 split components; bad values are refused."""
    from fvf.batch.registry import registered_tasks

    mesh = fvf.mesh.builtin.spot()
    path = _write(tmp_path / "spot.off", mesh)
    V, Q = fvf.quad_mesh(fvf.TriMesh(*fvf.read_mesh(path)), target_faces=300)
    opts = {"quads": 300, "fallback": "split"}
    result = str(tmp_path / "out" / "quad.npz")
    job = MeshJob("spot", str(path), result, ("quad",), opts, options_text(("quad",), opts), "t")
    row = run_job(job)
    assert row["status"] == "ok", row
    with np.load(result) as data:
        np.testing.assert_array_equal(data["quad_quads"], Q)
    assert row["quad_n_quads"] == Q.shape[0] and row["quad_split_components"] == 0
    check = registered_tasks()["quad"].check
    for bad in ({"quads": 0}, {"quads": 2.5}, {"fallback": "triangles"}):
        with pytest.raises(fvf.ParameterError):
            check(bad)


def test_run_job_failures_are_rows(tmp_path):
    corpus, rows = make_corpus(tmp_path, shared=False), {}
    for name, item in corpus.items():
        if item["good"]:
            continue
        tasks = ("info", "basis")
        job = MeshJob(name, str(item["path"]), str(tmp_path / "out" / f"{name}.npz"), tasks,
                      {"k": K}, options_text(tasks, {"k": K}), "t")  # fmt: skip
        row = rows[name] = run_job(job)
        assert row["status"] == "failed" and row["error"].startswith(item["error"]), row
        assert not Path(job.result).exists()
    assert rows["nonmanifold"]["info_problems"] == 1  # a failed row keeps what was found
    assert "fvf info" in rows["nonmanifold"]["error"]


def test_run_jobs_flushes_the_group_once_and_fails_it_on_a_disk_error(tmp_path, monkeypatch):
    """A group of jobs: results renamed into place as they finish, flushed together at the
    end; if that flush fails, the group's new results are removed and their rows failed."""
    import errno

    import fvf.io.atomic as atomic

    tasks, opts = ("info", "basis"), {"k": K}
    paths = [_write(tmp_path / f"m{i}.off", fvf.icosphere(1 + i % 2)) for i in range(3)]
    jobs = [
        MeshJob(
            p.stem,
            str(p),
            str(tmp_path / "out" / f"{p.stem}.npz"),
            tasks,
            opts,
            options_text(tasks, opts),
            "t",
        )  # fmt: skip
        for p in paths
    ]
    flushed, real = [], atomic._fsync_file
    monkeypatch.setattr(atomic, "_fsync_file", lambda p: (flushed.append(Path(p)), real(p)))
    rows = run_jobs(jobs)
    assert [r["status"] for r in rows] == ["ok"] * 3
    assert flushed == [Path(j.result) for j in jobs]  # the finals, after the group: no temps
    flushed.clear()
    assert [r["status"] for r in run_jobs(jobs)] == ["skipped"] * 3 and flushed == []

    def broken(path):
        raise OSError(errno.EIO, "Input/output error")

    Path(jobs[1].result).unlink()
    monkeypatch.setattr(atomic, "_fsync_file", broken)
    rows = run_jobs(jobs)
    assert [r["status"] for r in rows] == ["skipped", "failed", "skipped"]
    assert rows[1]["error"].startswith("OutputWriteError") and "m1.npz" in rows[1]["error"]
    assert not Path(jobs[1].result).exists()  # removed: the rerun recomputes it


def test_output_lock(tmp_path):
    with output_lock(tmp_path / "out"):
        with pytest.raises(fvf.BatchOutputError, match=r"in use by another fvf batch \(host"):
            with output_lock(tmp_path / "out"):
                pass
    with output_lock(tmp_path / "out"):  # released
        pass
    (tmp_path / "file").write_text("x")
    with pytest.raises(fvf.BatchOutputError, match="not a folder"):
        with output_lock(tmp_path / "file"):
            pass


def test_summary_csv_columns(tmp_path):
    rows = [
        {"mesh": "a", "status": "ok", "n": 3, "seconds": 0.1, "basis_lambda_1": 1.5},
        {"mesh": "b", "status": "failed", "error": "MeshReadError: x", "fields_x": 2},
    ]
    columns = write_summary(tmp_path / "s.csv", rows)
    assert columns[: len(fvf.batch.SUMMARY_COLUMNS)] == list(fvf.batch.SUMMARY_COLUMNS)
    assert columns[-2:] == ["basis_lambda_1", "fields_x"]
    back = read_csv(tmp_path / "s.csv")
    assert back[0]["seconds"] == "0.1" and back[1]["n"] == "" and back[1]["fields_x"] == "2"


def test_small_jobs_travel_in_groups_large_ones_alone():
    chunks = batch_driver.chunks
    assert list(chunks([1000, 10, 10, 10, 10, 500], capacity=1)) == [(0,), (5,), (1, 2, 3, 4)]
    sizes = [10] * 40
    groups = list(chunks(sizes, capacity=2))  # 400 bytes for 2 threads: 8 groups of 5
    assert [len(g) for g in groups] == [5] * 8
    assert sorted(i for g in groups for i in g) == list(range(40))
    many = list(chunks([1] * 100, capacity=1))  # never more than CHUNK_MAX per task
    assert max(len(g) for g in many) == batch_driver.CHUNK_MAX
    big = batch_driver.CHUNK_BYTES
    assert list(chunks([big, big, 3 * big], capacity=1)) == [(2,), (0,), (1,)]


def test_progress_line_counts_and_eta():
    import io

    from fvf.batch.progress import Progress

    stream = io.StringIO()  # not a terminal: plain lines, at most every 5 s and at the end
    progress = Progress(3, file=stream)
    progress.note("fvf batch: Dask dashboard at http://127.0.0.1:1/status")
    for status in ("ok", "failed", "skipped"):
        progress.update({"status": status})
    progress.close()
    lines = stream.getvalue().splitlines()
    assert lines[0].endswith("/status")
    assert lines[-1].startswith("fvf batch: 3/3 done (1 skipped, 1 failed), 0:00:0")
    assert lines[-1].endswith("ETA 0:00:00") and len(lines) == 3  # first line and last
    silent = io.StringIO()
    Progress(1, enabled=False, file=silent).update({"status": "ok"})
    assert silent.getvalue() == ""


class _FakeClient:
    """What fvf.batch.driver._prepare asks of a client."""

    def __init__(self, workers, trim=None):
        self._workers = workers
        self._trim = trim  # each worker's MALLOC_TRIM_THRESHOLD_
        self.dashboard_link = "http://127.0.0.1:1/status"

    def wait_for_workers(self, n, timeout):
        if not self._workers:
            raise TimeoutError

    def run(self, func):
        return {i: self._trim for i in range(len(self._workers))}

    def scheduler_info(self):
        return {"services": {}, "workers": dict(enumerate(self._workers))}


def test_one_mesh_per_worker_on_foreign_clusters():
    prepare = batch_driver._prepare
    assert prepare(_FakeClient([{"nthreads": 1}] * 2), print, False) is None
    declared = [{"nthreads": 4, "resources": {"MESH": 1}}] * 2
    assert prepare(_FakeClient(declared), print, False) == {"MESH": 1}
    with pytest.warns(fvf.BatchWarning, match="1 of the cluster's 2 workers run several"):
        assert prepare(_FakeClient([{"nthreads": 1}, {"nthreads": 8}]), print, False) is None
    with pytest.raises(fvf.BatchInputError, match="no worker"):
        prepare(_FakeClient([]), print, False)


def test_workers_with_dask_malloc_trim_get_a_note():
    """Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers, which also turns off
    glibc's adaptive mmap threshold (fvf's jobs take ~40 % more CPU): a foreign cluster's
    workers that have it are named in a note; a local cluster's workers do not have it."""
    notes = []
    batch_driver._prepare(_FakeClient([{"nthreads": 1}], trim="65536"), notes.append, False)
    assert len(notes) == 1 and "MALLOC_TRIM_THRESHOLD_" in notes[0]
    notes.clear()
    batch_driver._prepare(_FakeClient([{"nthreads": 1}]), notes.append, False)
    assert notes == []
    import dask
    from distributed.nanny import _get_env_variables

    with dask.config.set(batch_driver.local_cluster_config(retries=0)):
        environ = _get_env_variables("distributed.nanny.pre-spawn-environ")
    assert "MALLOC_TRIM_THRESHOLD_" not in environ and environ["OMP_NUM_THREADS"] == "1"


# ---------------------------------------------------------------------------- on a cluster
@pytest.fixture(scope="module")
def batch(client, tmp_path_factory):
    """One batch over generated, shared and broken meshes on the 2-worker cluster."""
    root = tmp_path_factory.mktemp("batch")
    corpus = make_corpus(root)
    out = root / "out"
    inputs = [root / "gen", *(v["path"] for v in corpus.values() if "gen" not in str(v["path"]))]
    table = fvf.batch.run(inputs, out, k=K, client=client, progress=False)
    return corpus, out, inputs, table


def test_batch_results_equal_the_library(batch):
    corpus, out, _, table = batch
    rows = rows_by_mesh(table)
    assert len(rows) == len(corpus)
    for name, item in corpus.items():
        row = rows[name]
        assert row["path"] == str(Path(item["path"]).resolve())
        if item["good"]:
            assert row["status"] == "ok", row
            assert_same_results(out / "meshes" / f"{name}.npz", direct(item["path"]))
            mesh = fvf.TriMesh(*fvf.read_mesh(item["path"]))
            assert (row["n"], row["m"], row["chi"]) == (
                mesh.n_vertices,
                mesh.n_faces,
                mesh.euler_characteristic,
            )
            assert row["seconds"] > 0 and row["peak_mb"] > 10
        else:
            assert row["status"] == "failed" and row["error"].startswith(item["error"]), row
            assert not (out / "meshes" / f"{name}.npz").exists()
    assert no_temporaries(out)
    on_disk = {r["mesh"]: r for r in read_csv(out / "summary.csv")}
    assert on_disk.keys() == rows.keys()
    assert all(on_disk[m]["status"] == rows[m]["status"] for m in rows)


def test_batch_result_is_a_cli_data_file(batch):
    """A mesh result is a data file of the fvf command (mesh copy, provenance)."""
    from fvf.io.datafile import read_data

    corpus, out, _, _ = batch
    path = corpus["torus"]["path"]
    data = read_data(out / "meshes" / "torus.npz", fvf.TriMesh(*fvf.read_mesh(path)))
    assert str(data["mesh_path"]) == str(Path(path).resolve())
    assert data.field("v", fvf.TriMesh(*fvf.read_mesh(path))).shape == (400, 3)
    assert data.functions("eigenfunctions", fvf.TriMesh(*fvf.read_mesh(path))).shape == (200, K)


def test_batch_rerun_skips_and_resumes(batch, client):
    corpus, out, inputs, _ = batch
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "meshes").glob("*.npz")}
    table = rows_by_mesh(fvf.batch.run(inputs, out, k=K, client=client, progress=False))
    good = [n for n, v in corpus.items() if v["good"]]
    assert all(table[n]["status"] == "skipped" for n in good)
    assert all(table[n]["status"] == "failed" for n in corpus if n not in good)  # retried
    assert stamps == {p.name: p.stat().st_mtime_ns for p in (out / "meshes").glob("*.npz")}
    # an interrupted batch: two results missing, a worker's temporary file left behind
    lost = good[:2]
    for name in lost:
        (out / "meshes" / f"{name}.npz").unlink()
    (out / "meshes" / f".{lost[0]}.npz.abc123.npz").write_bytes(b"half a zip")
    table = rows_by_mesh(fvf.batch.run(inputs, out, k=K, client=client, progress=False))
    assert {n for n in good if table[n]["status"] == "ok"} == set(lost)
    assert all(table[n]["status"] == "skipped" for n in good if n not in lost)
    assert no_temporaries(out)
    for name in lost:
        assert_same_results(out / "meshes" / f"{name}.npz", direct(corpus[name]["path"]))
    # a result rewritten by hand without one of its arrays (its key kept): computed again
    edited = out / "meshes" / f"{good[2]}.npz"
    with np.load(edited, allow_pickle=False) as data:
        kept = {k: data[k] for k in data.files if k != "eigenvalues"}
    np.savez(edited, **kept)
    table = rows_by_mesh(fvf.batch.run(inputs, out, k=K, client=client, progress=False))
    assert table[good[2]]["status"] == "ok"
    assert all(table[n]["status"] == "skipped" for n in good if n != good[2])
    assert_same_results(edited, direct(corpus[good[2]]["path"]))


def test_batch_pairs(client, tmp_path):
    """fmap over pairs: the identity map of a registered pair, and a map file."""
    torus = fvf.torus(16, 8)
    a = _write(tmp_path / "a.off", torus)
    b = _write(tmp_path / "b.off", fvf.TriMesh(torus.vertices * [1.0, 1.0, 1.5], torus.faces))
    perm = np.random.default_rng(3).permutation(torus.n_vertices)  # c's vertex j = a's perm[j]
    inverse = np.argsort(perm)  # a's vertex i = c's vertex inverse[i]
    c = _write(tmp_path / "c.off", fvf.TriMesh(torus.vertices[perm], inverse[torus.faces]))
    np.savetxt(tmp_path / "a_to_c.txt", inverse, fmt="%d")
    lines = ["a.off,b.off", "a.off,c.off,a_to_c.txt", "b.off,a.off,a.off", "a.off,d.off"]
    (tmp_path / "pairs.csv").write_text("\n".join(lines))
    with pytest.raises(fvf.BatchInputError, match=r"line 4: .*d\.off"):
        fvf.batch.run([], tmp_path / "out", pairs=tmp_path / "pairs.csv", client=client)
    (tmp_path / "pairs.csv").write_text("\n".join(lines[:3]))
    table = rows_by_mesh(
        fvf.batch.run(
            [], tmp_path / "out", pairs=tmp_path / "pairs.csv", tasks=["fmap"], k=K,
            client=client, progress=False,
        )
    )  # fmt: skip
    meshes = {n: fvf.TriMesh(*fvf.read_mesh(p)) for n, p in zip("abc", (a, b, c), strict=True)}
    for pair, p2p in (("a--b", np.arange(torus.n_vertices)), ("a--c", inverse)):
        row = table[pair]
        assert row["status"] == "ok" and row["kind"] == "pair", row
        C = fvf.functional_map(meshes[pair[-1]], meshes["a"], p2p, K)
        with np.load(tmp_path / "out" / "pairs" / f"{pair}.npz") as data:
            np.testing.assert_allclose(np.abs(data["fmap"]), np.abs(C), atol=1e-9)
            np.testing.assert_array_equal(data["p2p"], p2p)
    assert table["a--c"]["fmap_orthogonality"] < 1e-6  # an exact isometry: C is orthogonal
    assert table["b--a"]["status"] == "failed"  # a mesh file as a map: a row, not a crash
    assert table["b--a"]["error"].startswith("BatchInputError")  # typed, like every map problem


def test_batch_match_task_recovers_a_permutation(client, tmp_path):
    """The default pair task is fvf.match: on a shape without symmetry and a copy with its
    vertices permuted, match_p2p is the permutation (source -> target), as fvf.match gives."""
    sphere = fvf.icosphere(3)
    x, y, z = sphere.vertices.T
    r = 1 + 0.25 * y + 0.2 * z + 0.15 * np.cos(2.5 * y) * z + 0.3 * x * y + 0.2 * x**3
    shape = fvf.TriMesh(sphere.vertices * np.array([2.0, 1.2, 0.8]) * r[:, None], sphere.faces)
    perm = np.random.default_rng(5).permutation(shape.n_vertices)  # t's vertex j = s's perm[j]
    _write(tmp_path / "s.off", shape)
    _write(tmp_path / "t.off", fvf.TriMesh(shape.vertices[perm], np.argsort(perm)[shape.faces]))
    (tmp_path / "pairs.csv").write_text("s.off,t.off\n")
    out = tmp_path / "out"
    table = rows_by_mesh(
        fvf.batch.run([], out, pairs=tmp_path / "pairs.csv", k=40, client=client, progress=False)
    )
    row = table["s--t"]
    assert row["status"] == "ok" and row["match_seconds_bases"] >= 0, row
    with np.load(out / "pairs" / "s--t.npz") as data:
        np.testing.assert_array_equal(data["match_p2p"], np.argsort(perm))  # s's i -> t's vertex
        assert data["match_C"].shape == (40, 40)


def test_cli_batch_exit_status(client, tmp_path):
    """``fvf batch`` on a running cluster (--scheduler): 0, 1 with failures, 2 bad input."""
    address = client.scheduler.address
    good = _write(tmp_path / "in" / "good.off", fvf.icosphere(1))
    bad = tmp_path / "in" / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n")
    args = ["batch", "--scheduler", address, "--tasks", "info,basis", "--k", "4", "--quiet"]
    assert main([*args, str(good), "-o", str(tmp_path / "o1")]) == EXIT_OK
    assert main([*args, str(tmp_path / "in"), "-o", str(tmp_path / "o2")]) == EXIT_PROBLEMS
    rows = {r["mesh"]: r for r in read_csv(tmp_path / "o2" / "summary.csv")}
    assert rows["good"]["status"] == "skipped" or rows["good"]["status"] == "ok"
    assert rows["bad"]["status"] == "failed" and "MeshReadError" in rows["bad"]["error"]
    assert main([*args, str(tmp_path / "missing"), "-o", str(tmp_path / "o3")]) == EXIT_BAD_INPUT
    assert main([*args[:4], "eigen", str(good), "-o", str(tmp_path / "o4")]) == EXIT_BAD_INPUT
    local_only = [*args, "--workers", "2", str(good), "-o", str(tmp_path / "o5")]
    assert main(local_only) == EXIT_BAD_INPUT


# ---------------------------------------------------------------------------- slow
def _die(ctx):
    """A task that kills its worker process on meshes named 'killer*' (a native crash)."""
    if ctx.path.stem.startswith("killer"):
        os.kill(os.getpid(), signal.SIGKILL)
    return fvf.batch.TaskOutput(figures={"alive": 1})


def _corpus_files(folder: Path, count: int, level: int = 3) -> list[Path]:
    return [
        _write(folder / f"m{i:02d}.off", fvf.jittered_sphere(level, 0.2, seed=i))
        for i in range(count)
    ]


def _held(ctx):
    """A task reporting how many tasks its worker holds (running or waiting to run)."""
    state = distributed.get_worker().state
    time.sleep(0.05)  # long enough for the scheduler to hand out whatever it would
    return fvf.batch.TaskOutput(figures={"tasks": len(state.executing) + len(state.ready)})


def test_workers_hold_only_the_task_they_run(client, tmp_path):
    """No worker holds a task waiting behind the one it runs, so a dying worker takes only
    its own task down (Dask's scheduler would send a worker every task submitted for it:
    it queues only large groups of like tasks, and these are not)."""
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    files = _corpus_files(tmp_path / "in", 12, level=1)
    held = fvf.batch.Task("held", _held)
    rows = fvf.batch.run(files, tmp_path / "out", tasks=[held], client=client, progress=False,
                         as_frame=False)  # fmt: skip
    assert [r["status"] for r in rows] == ["ok"] * 12
    assert {r["held_tasks"] for r in rows} == {1}


@pytest.mark.slow
def test_killed_worker_job_is_retried_and_a_killer_mesh_fails(tmp_path):
    """SIGKILL of a busy worker: its job reruns elsewhere and the batch completes; a mesh
    that kills every worker it touches ends as a failed row (KilledWorker), not a hang."""
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    files = _corpus_files(tmp_path / "in", 10, level=4)
    killer = _write(tmp_path / "in" / "killer.off", fvf.icosphere(1))
    out = tmp_path / "out"
    die = fvf.batch.Task("die", _die)
    import dask

    with dask.config.set(batch_driver.local_cluster_config(retries=1)):
        cluster = distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=":0",
            silence_logs=40,
        )  # fmt: skip
        with distributed.Client(cluster) as c:
            pids, killed = c.run(os.getpid), []

            def kill_a_busy_worker():
                deadline = time.monotonic() + 120
                while not list((out / "meshes").glob("*.npz")) and time.monotonic() < deadline:
                    time.sleep(0.02)
                while not killed and time.monotonic() < deadline:
                    busy = [a for a, keys in c.processing().items() if keys and a in pids]
                    if busy:
                        killed.append(pids[busy[0]])
                        os.kill(pids[busy[0]], signal.SIGKILL)
                    time.sleep(0.01)

            killer_thread = threading.Thread(target=kill_a_busy_worker, daemon=True)
            killer_thread.start()
            rows = rows_by_mesh(
                fvf.batch.run(files, out, ["info", "basis", die], k=K, client=c, progress=False)
            )
            killer_thread.join(timeout=60)
            assert killed and killed[0] not in c.run(os.getpid).values()  # a new process
            # a job whose worker died after its result file was renamed into place finds
            # that whole file on the retry: "skipped", with the stored figures
            statuses = [(r["mesh"], r["status"], r["error"]) for r in rows.values()]
            assert len(rows) == 10, statuses
            assert all(r["status"] in ("ok", "skipped") for r in rows.values()), statuses
            assert sum(r["status"] == "ok" for r in rows.values()) >= 9, statuses  # one kill
            tiny = [_write(tmp_path / "tiny" / f"t{i}.off", fvf.icosphere(1)) for i in range(5)]
            sizes = [os.path.getsize(p) for p in [killer, *tiny, *files[:2]]]
            assert any(0 in g and len(g) > 1 for g in batch_driver.chunks(sizes, 2))
            rows = rows_by_mesh(
                fvf.batch.run([killer, *tiny, *files[:2]], out, ["info", "basis", die], k=K,
                              client=c, progress=False)
            )  # fmt: skip
        cluster.close()
    assert rows["killer"]["status"] == "failed"
    assert rows["killer"]["error"].startswith("KilledWorker: the worker process died")
    assert rows["m00"]["status"] == "skipped" and rows["m01"]["status"] == "skipped"
    assert all(rows[f"t{i}"]["status"] in ("ok", "skipped") for i in range(5))  # its group
    for f in files:
        assert_ok_file(out / "meshes" / f"{f.stem}.npz")


def assert_ok_file(path: Path, k: int = K) -> None:
    with np.load(path, allow_pickle=False) as data:
        assert data["eigenvalues"].shape == (k,)
        assert np.isfinite(data["eigenfunctions"]).all()


def _interrupted_batch(tmp_path: Path, results: int, presses: int, group: bool = False) -> tuple:
    """``fvf batch`` on 40 meshes (enough that it cannot end first), Ctrl-C ``presses``
    times 0.3 s apart once ``results`` result files exist, to the driver or (``group``) to
    its whole process group as a terminal sends it: (files, out, cmd, exit status,
    stderr)."""
    files = _corpus_files(tmp_path / "in", 40)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "fvf.cli", "batch", str(tmp_path / "in"), "-o", str(out),
           "--workers", "2", "--k", "30", "--tasks", "info,basis,fields,singularities"]  # fmt: skip
    proc = subprocess.Popen(
        cmd,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=group,
        preexec_fn=(lambda: signal.signal(signal.SIGINT, signal.SIG_DFL)) if group else None,
    )
    deadline = time.monotonic() + 120
    while len(list((out / "meshes").glob("*.npz"))) < results and time.monotonic() < deadline:
        time.sleep(0.05)
    for i in range(presses):
        if group:
            os.killpg(proc.pid, signal.SIGINT)
        else:
            proc.send_signal(signal.SIGINT)
        if i + 1 < presses:
            time.sleep(0.3)
    _, err = proc.communicate(timeout=120)
    return files, out, cmd, proc.returncode, err.decode()


@pytest.mark.slow
def test_sigint_then_rerun_resumes(tmp_path):
    """SIGINT to ``fvf batch`` mid-run: exit 130, whole files only; the rerun computes only
    the meshes without a result and leaves the finished ones untouched."""
    files, out, cmd, rc, err = _interrupted_batch(tmp_path, results=2, presses=1)
    assert rc == 130, err
    done = {p.stem: p.stat().st_mtime_ns for p in (out / "meshes").glob("*.npz")}
    assert 2 <= len(done) < len(files), "interrupt the batch before it finishes"
    assert no_temporaries(out)
    for name in done:
        assert_ok_file(out / "meshes" / f"{name}.npz", k=30)
    rerun = subprocess.run(cmd, env=ENV, capture_output=True, timeout=300)
    assert rerun.returncode == EXIT_OK, rerun.stderr.decode()
    rows = {r["mesh"]: r for r in read_csv(out / "summary.csv")}
    assert {m for m, r in rows.items() if r["status"] == "skipped"} == set(done)
    assert {m for m, r in rows.items() if r["status"] == "ok"} == {f.stem for f in files} - set(
        done
    )
    assert done == {n: (out / "meshes" / f"{n}.npz").stat().st_mtime_ns for n in done}


@pytest.mark.slow
def test_three_sigints_end_quietly(tmp_path):
    """Ctrl-C pressed three times: exit 130 with one line, no traceback from the shutdown
    (the Dask cluster's atexit hooks), whole files only and the summary written (the
    presses after the first do not cut the cleanup short, nor meet the default handler
    the interpreter restores before tearing its modules down)."""
    _, out, _, rc, err = _interrupted_batch(tmp_path, results=1, presses=3)
    assert rc == 130, err
    assert "Traceback" not in err and "interrupted" in err, err
    assert no_temporaries(out)
    assert (out / "summary.csv").exists()


@pytest.mark.slow
def test_ctrl_c_in_a_terminal_ends_with_one_line_and_every_result_in_the_summary(tmp_path):
    """Ctrl-C as a terminal sends it, to the driver and its Dask workers alike: one line,
    no worker's traceback of it (the workers ignore SIGINT, fvf.batch.worker_start), and
    every result written before the cluster closed has its row in summary.csv (those that
    finished while the others were cancelled used to be left out)."""
    _, out, _, rc, err = _interrupted_batch(tmp_path, results=2, presses=1, group=True)
    assert rc == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert err.strip().endswith("fvf: interrupted; no output was half-written"), err
    written = {p.stem for p in (out / "meshes").glob("*.npz")}
    rows = {r["mesh"] for r in read_csv(out / "summary.csv")}
    assert written and rows == written


@pytest.fixture
def python_sigint():
    """Python's own SIGINT handler for the test: a process started in the background by a
    non-interactive shell inherits SIGINT ignored, and an ignored press reaches nothing."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_sigint_while_the_cluster_starts_is_an_interrupt(tmp_path, monkeypatch, python_sigint):
    """Ctrl-C while the local cluster starts: exit 130, not "could not start a local Dask
    cluster" (exit 2) when its workers die of the same Ctrl-C (a terminal sends it to the
    whole process group); a cluster that did start is closed, not left to the exit hooks."""
    _corpus_files(tmp_path / "in", 2)
    closed = []

    class Started:
        def close(self):
            closed.append(True)

    def dying(**kwargs):  # the press reaches fvf, then its workers die of it
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.5)
        raise RuntimeError("Nanny failed to start.")

    def starting(**kwargs):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.5)
        return Started()

    argv = ["batch", str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--workers", "1"]
    for fake in (dying, starting):
        monkeypatch.setattr(distributed, "LocalCluster", fake)
        assert main([*argv, "--tasks", "info"]) == 130
    assert closed == [True]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.slow
def test_scheduler_and_workers_started_separately(tmp_path):
    """``fvf batch --scheduler`` against ``dask scheduler`` and two ``dask worker`` processes
    started here on 127.0.0.1: the same rows and results as the library called directly
    (and as the local cluster of the default tests)."""
    import json

    corpus = make_corpus(tmp_path / "in")
    bindir = Path(sys.executable).parent
    scheduler_file = tmp_path / "scheduler.json"
    quiet = {"env": ENV, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    procs = [
        subprocess.Popen(
            [
                bindir / "dask",
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--dashboard-address",
                "127.0.0.1:0",
                "--scheduler-file",
                str(scheduler_file),
            ],
            **quiet,
        )  # fmt: skip
    ]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        bindir / "dask",
                        "worker",
                        address,
                        "--nthreads",
                        "1",
                        "--host",
                        "127.0.0.1",
                        "--memory-limit",
                        "4GB",
                        "--resources",
                        "MESH=1",
                    ],
                    **quiet,
                )  # fmt: skip
            )
        out = tmp_path / "out"
        inputs = [str(v["path"]) for v in corpus.values()]
        args = ["batch", *inputs, "-o", str(out), "--scheduler", address, "--k", str(K)]
        assert main([*args, "--quiet"]) == EXIT_PROBLEMS  # the broken files
        rows = {r["mesh"]: r for r in read_csv(out / "summary.csv")}
        assert rows.keys() == corpus.keys()
        for name, item in corpus.items():
            if item["good"]:
                assert rows[name]["status"] == "ok", rows[name]
                assert_same_results(out / "meshes" / f"{name}.npz", direct(item["path"]))
            else:
                assert rows[name]["status"] == "failed"
                assert rows[name]["error"].startswith(item["error"])
        assert no_temporaries(out)
    finally:
        for p in reversed(procs):
            p.send_signal(signal.SIGINT)
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()


@pytest.mark.parametrize("limit", ["1KB", "10", 1000, "100MiB"])
def test_a_memory_limit_no_worker_can_start_in_is_refused_at_once(limit, tmp_path):
    """At 1 KB each local worker was killed as it started, over and over: the batch never
    ended. A limit below MIN_WORKER_MEMORY is a ParameterError before any work."""
    from fvf.batch.driver import MIN_WORKER_MEMORY, run

    ball = fvf.icosphere(1)
    fvf.write_mesh(tmp_path / "b.obj", ball.vertices, ball.faces)
    with pytest.raises(fvf.ParameterError, match=f"below the {MIN_WORKER_MEMORY // 2**20} MiB"):
        run([tmp_path / "b.obj"], tmp_path / "out", memory_limit=limit)
    assert not (tmp_path / "out").exists()


def test_a_vertex_map_of_the_wrong_kind_is_named_as_such(tmp_path):
    """A (162, 2) table was reported as 'got int64 (324,)' (flattened first), an .npz
    archive named .npy as 'got <U1 (1,)'."""
    from fvf.batch.registry import MeshContext, PairContext

    ball = fvf.icosphere(1)
    ctx = MeshContext(tmp_path / "b.obj", ball.vertices, ball.faces, {})
    np.save(tmp_path / "two.npy", np.zeros((ball.n_vertices, 2), np.int64))
    np.savez(tmp_path / "arch.npz", p2p=np.arange(ball.n_vertices))
    (tmp_path / "arch.npz").rename(tmp_path / "arch.npy")
    cases = {"two.npy": r"shape \(42,\); got int64 \(42, 2\)", "arch.npy": "an .npz archive"}
    for name, said in cases.items():
        with pytest.raises(fvf.BatchInputError, match=said):
            PairContext(ctx, ctx, tmp_path / name, {}).point_map()
