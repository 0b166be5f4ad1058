"""fvf's guarantees about files (docs/files.md): outputs are whole or absent, inputs are
never replaced, and interrupted or failing writes leave nothing behind.

The data-loss cases run through real processes (SIGINT during a large write, a full disk
simulated with RLIMIT_FSIZE, two writers racing for one output, outputs onto inputs); a
property test interrupts sequences of ``fvf`` commands at random points (a trace function
raises KeyboardInterrupt at the k-th executed line) and checks every output.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fvf
from fvf.cli.main import (
    EXIT_BAD_INPUT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_WRITE_FAILED,
    main,
)
from fvf.errors import InputOverwriteError, OutputWriteError
from fvf.io.atomic import (
    atomic_path,
    atomic_write_text,
    check_not_input,
    deferred_fsync,
    same_file,
)
from fvf.io.datafile import read_data, write_data

SRC = str(Path(fvf.__file__).resolve().parents[1])


def temporaries(folder: Path) -> list[str]:
    """Leftover temporary files of atomic_path (hidden ``.<name>.<hex><suffix>``)."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """An icosphere (162 vertices) as OBJ, fields, constraints."""
    d = tmp_path_factory.mktemp("files")
    mesh = fvf.icosphere(2)
    fvf.write_mesh(d / "ico.obj", mesh.vertices, mesh.faces)
    C = mesh.face_centroids
    v = mesh.project_tangent(np.cross([0, 0, 1.0], C))
    u = mesh.project_tangent(np.cross([1.0, 0, 0], C))
    np.savez(d / "fields.npz", f=mesh.vertices[:, 0], v=v, u=u)
    np.savez(d / "c.npz", constraint_faces=[0, 200], directions=mesh.face_edge_vectors[[0, 200], 0])
    return d, mesh


# ---------------------------------------------------------------------------- atomic_path
def test_atomic_path_replaces_whole_or_not_at_all(tmp_path):
    out = tmp_path / "a.npz"
    with atomic_path(out) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".npz" and tmp.exists()
        np.savez(tmp, x=np.arange(3))
        assert not out.exists()  # nothing at the target until the rename
    assert np.load(out)["x"].tolist() == [0, 1, 2] and temporaries(tmp_path) == []
    before = out.read_bytes()
    for exc in (RuntimeError("boom"), KeyboardInterrupt()):
        with pytest.raises(type(exc)), atomic_path(out) as tmp:
            tmp.write_bytes(b"half")
            raise exc
        assert out.read_bytes() == before and temporaries(tmp_path) == []


def _count_fsyncs(monkeypatch) -> list[str]:
    """Record what os.fsync flushes (file or folder name), calling the real one."""
    flushed, real = [], os.fsync

    def fsync(fd):
        flushed.append(os.path.basename(os.readlink(f"/proc/self/fd/{fd}")))
        real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    return flushed


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
def test_deferred_fsync_renames_at_once_and_flushes_at_the_end(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    flushed = _count_fsyncs(monkeypatch)
    atomic_write_text(tmp_path / "alone.txt", "x")
    assert len(flushed) == 2 and flushed[1] == tmp_path.name  # the file, then its folder
    assert flushed[0].startswith(".alone.txt.")  # the temporary file, before its rename
    flushed.clear()
    names = ["a.txt", "b.txt", "sub/c.txt", "a.txt"]
    with deferred_fsync() as pending:
        for i, name in enumerate(names):
            atomic_write_text(tmp_path / name, f"v{i}")
            assert (tmp_path / name).read_text() == f"v{i}"  # whole and in place already
        assert flushed == [] and temporaries(tmp_path) == []
        assert pending == [tmp_path / n for n in names]
    # each file once (a.txt was written twice), then each folder once
    assert flushed == ["a.txt", "b.txt", "c.txt", tmp_path.name, "sub"]
    assert (tmp_path / "a.txt").read_text() == "v3"


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
def test_deferred_fsync_is_per_thread_and_skipped_on_errors(tmp_path, monkeypatch):
    import threading

    flushed = _count_fsyncs(monkeypatch)
    with deferred_fsync():
        other = threading.Thread(target=atomic_write_text, args=(tmp_path / "t.txt", "t"))
        other.start()
        other.join()
        assert len(flushed) == 2  # the other thread is outside the block: flushed at once
        atomic_write_text(tmp_path / "mine.txt", "m")
        assert len(flushed) == 2
    assert flushed[2:] == ["mine.txt", tmp_path.name]
    flushed.clear()
    with pytest.raises(RuntimeError), deferred_fsync():
        atomic_write_text(tmp_path / "late.txt", "l")
        raise RuntimeError("boom")
    assert flushed == [] and (tmp_path / "late.txt").read_text() == "l"  # renamed, whole


def test_deferred_fsync_failure_names_the_file(tmp_path, monkeypatch):
    import errno

    def broken(fd):
        raise OSError(errno.EIO, "Input/output error")

    with pytest.raises(OutputWriteError, match=r"x\.txt.*Input/output error"):
        with deferred_fsync():
            atomic_write_text(tmp_path / "x.txt", "x")
            monkeypatch.setattr(os, "fsync", broken)


def test_atomic_path_keeps_the_mode_and_replaces_links(tmp_path):
    target = tmp_path / "input.txt"
    target.write_text("input")
    out = tmp_path / "out.txt"
    out.write_text("old")
    out.chmod(0o640)
    atomic_write_text(out, "new")
    assert out.read_text() == "new" and (out.stat().st_mode & 0o777) == 0o640
    link = tmp_path / "link.txt"
    link.symlink_to(target)
    atomic_write_text(link, "through?")
    assert not link.is_symlink() and link.read_text() == "through?"
    assert target.read_text() == "input"  # the link was replaced, not written through
    hard = tmp_path / "hard.txt"
    os.link(target, hard)
    atomic_write_text(hard, "through?")
    assert target.read_text() == "input" and hard.read_text() == "through?"


def test_atomic_path_write_failures_are_typed(tmp_path):
    with pytest.raises(OutputWriteError, match="does not exist"):
        atomic_write_text(tmp_path / "missing" / "a.txt", "x")
    os.mkdir(tmp_path / "adir")
    with pytest.raises(OutputWriteError, match="adir"):
        atomic_write_text(tmp_path / "adir", "x")
    assert temporaries(tmp_path) == []


def test_same_file_and_check_not_input(tmp_path):
    a = tmp_path / "a.npz"
    a.write_bytes(b"a")
    (tmp_path / "sym.npz").symlink_to(a)
    os.link(a, tmp_path / "hard.npz")
    (tmp_path / "sub").mkdir()
    (tmp_path / "dirlink").symlink_to(tmp_path)
    assert same_file(a, a) == f"the input {a}"
    assert "symbolic link" in same_file(tmp_path / "sym.npz", a)
    assert "hard link" in same_file(tmp_path / "hard.npz", a)
    assert same_file(tmp_path / "dirlink" / "a.npz", a) is not None
    assert same_file(tmp_path / "sub" / ".." / "a.npz", a) is not None
    assert same_file(tmp_path / "new.npz", a) is None
    with pytest.raises(InputOverwriteError, match="-o .*sym.npz is a symbolic link"):
        check_not_input(tmp_path / "sym.npz", [None, a], option="-o")
    check_not_input(tmp_path / "sym.npz", [a], force=True)
    check_not_input(tmp_path / "new.npz", [a, None])


def test_write_data_refuses_its_inputs(work, tmp_path):
    d, mesh = work
    fields = d / "fields.npz"
    before = fields.read_bytes()
    kwargs = {"mesh": mesh, "mesh_path": d / "ico.obj", "command": "test"}
    (tmp_path / "mesh.npz").symlink_to(d / "ico.obj")
    for out in (fields, d / "fields", tmp_path / "mesh.npz"):
        with pytest.raises(InputOverwriteError):
            write_data(out, {"x": np.zeros(2)}, inputs=[fields], **kwargs)
    assert fields.read_bytes() == before and (tmp_path / "mesh.npz").is_symlink()
    (tmp_path / "link.npz").symlink_to(fields)
    with pytest.raises(InputOverwriteError):
        write_data(tmp_path / "link.npz", {"x": np.zeros(2)}, inputs=[fields], **kwargs)
    path = write_data(
        tmp_path / "link.npz", {"x": np.zeros(2)}, inputs=[fields], overwrite_inputs=True, **kwargs
    )
    assert fields.read_bytes() == before and np.load(path)["x"].shape == (2,)


def test_write_mesh_is_atomic(tmp_path, monkeypatch):
    mesh = fvf.icosphere(1)
    for suffix in (".obj", ".off", ".ply"):
        out = tmp_path / f"m{suffix}"
        out.write_bytes(b"OLD")
        monkeypatch.setattr(Path, "write_bytes", _fail_half, raising=True)
        monkeypatch.setattr(Path, "write_text", _fail_half, raising=True)
        with pytest.raises(OutputWriteError, match="No space left.*unchanged"):
            fvf.write_mesh(out, mesh.vertices, mesh.faces)
        monkeypatch.undo()
        assert out.read_bytes() == b"OLD" and temporaries(tmp_path) == []
        fvf.write_mesh(out, mesh.vertices, mesh.faces)
        V, F = fvf.read_mesh(out)
        assert np.array_equal(V, mesh.vertices) and np.array_equal(F, mesh.faces)


def _fail_half(self, data, *args, **kwargs):
    """A write that stops half-way with ENOSPC (a full disk)."""
    import errno

    with open(self, "wb") as fh:
        fh.write((data.encode() if isinstance(data, str) else data)[: len(data) // 2])
    raise OSError(errno.ENOSPC, "No space left on device")


def test_spectral_cache_is_atomic_and_never_trusted_blindly(tmp_path):
    mesh = fvf.icosphere(2)
    basis = fvf.SpectralBasis(mesh, 6, cache_dir=tmp_path)
    (path,) = tmp_path.glob("lb-*.npz")
    again = fvf.SpectralBasis(mesh, 6, cache_dir=tmp_path)
    assert np.array_equal(again.eigenvectors, basis.eigenvectors)
    path.write_bytes(path.read_bytes()[:100])  # a cache file cut short (older versions)
    rebuilt = fvf.SpectralBasis(mesh, 6, cache_dir=tmp_path)
    assert np.allclose(rebuilt.eigenvalues, basis.eigenvalues)
    assert np.load(path)["eigenvectors"].shape == (162, 6) and temporaries(tmp_path) == []


def test_trimesh_leaves_the_callers_arrays_alone():
    ico = fvf.icosphere(1)
    V, F = ico.vertices.copy(), ico.faces.copy()
    mesh = fvf.TriMesh(V, F)
    assert V.flags.writeable and F.flags.writeable
    V[0, 0] += 1.0  # the user's next edit works ...
    F[0] = F[0, ::-1]
    assert mesh.vertices[0, 0] == ico.vertices[0, 0]  # ... and does not reach the mesh
    assert np.array_equal(mesh.faces, ico.faces)
    assert not mesh.vertices.flags.writeable and not mesh.faces.flags.writeable


# ---------------------------------------------------------------------------- the command
def test_output_onto_an_input_is_refused(work, tmp_path, capsys):
    d, _ = work
    fields = d / "fields.npz"
    before = fields.read_bytes()
    (tmp_path / "link.npz").symlink_to(fields)
    os.link(fields, tmp_path / "hard.npz")
    flow = ["flow", str(d / "ico.obj"), str(fields), "--t", "1", "-o"]
    cases = [
        (flow + [str(fields)], "is the input"),
        (flow + [str(d / "fields")], "is the input"),  # .npz appended
        (flow + [str(tmp_path / "link.npz")], "symbolic link"),
        (flow + [str(tmp_path / "hard.npz")], "hard link"),
        (flow + [str(tmp_path / "x"), "--png", str(d / "ico.obj")], "--png"),
        (["design", str(d / "ico.obj"), "--constraints", str(d / "c.npz"), "-o", str(d / "c")], ""),
    ]
    for argv, words in cases:
        assert main(argv) == EXIT_BAD_INPUT, argv
        err = capsys.readouterr().err
        assert "InputOverwriteError" in err and words in err and "--force" in err
    assert fields.read_bytes() == before and not (tmp_path / "x.npz").exists()
    assert main(flow + [str(tmp_path / "link.npz"), "--force"]) == EXIT_OK
    assert fields.read_bytes() == before and not (tmp_path / "link.npz").is_symlink()
    copy = tmp_path / "copy.npz"
    copy.write_bytes(before)
    argv = ["flow", str(d / "ico.obj"), str(copy), "--t", "1", "-o", str(copy), "--force"]
    assert main(argv) == EXIT_OK and "f_t" in np.load(copy)


def run_fvf(*args, cwd, **kwargs):
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run(
        [sys.executable, "-m", "fvf.cli", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        **kwargs,
    )


def _limit_file_size():
    import resource

    resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))


def test_full_disk_subprocess(work, tmp_path):
    """RLIMIT_FSIZE stops the write half-way: status 5, the old output intact, no litter."""
    d, _ = work
    out = tmp_path / "out.npz"
    out.write_bytes(b"OLD")
    r = run_fvf(
        "flow", str(d / "ico.obj"), str(d / "fields.npz"), "--t", "0", "1", "2", "-o", str(out),
        cwd=tmp_path, preexec_fn=_limit_file_size,
    )  # fmt: skip
    assert r.returncode == EXIT_WRITE_FAILED, r.stderr
    assert "OutputWriteError" in r.stderr and "unchanged" in r.stderr
    assert out.read_bytes() == b"OLD" and temporaries(tmp_path) == []


@pytest.mark.slow
def test_onto_input_subprocess(work, tmp_path):
    d, _ = work
    data = tmp_path / "fields.npz"
    data.write_bytes((d / "fields.npz").read_bytes())
    (tmp_path / "link.npz").symlink_to(data)
    before = data.read_bytes()
    r = run_fvf("bracket", str(d / "ico.obj"), "fields.npz", "-o", "link.npz", cwd=tmp_path)
    assert r.returncode == EXIT_BAD_INPUT and "symbolic link" in r.stderr
    assert data.read_bytes() == before and (tmp_path / "link.npz").is_symlink()


_WRITER = """
import sys, numpy as np
from fvf.io.datafile import write_data
from fvf.mesh.shapes import icosphere
mesh = icosphere(0)
big = np.full(int(sys.argv[2]), float(sys.argv[3]))
print("ready", flush=True)
write_data(sys.argv[1], {"big": big}, mesh=mesh, mesh_path="m.obj", command=sys.argv[3])
"""


def _writer(out: Path, size: int, value: float) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.Popen(
        [sys.executable, "-c", _WRITER, str(out), str(size), str(value)],
        cwd=out.parent,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def test_sigint_during_a_large_write(tmp_path):
    """Ctrl-C while a 160 MB output is being written: the old file stays, no temporary."""
    out = tmp_path / "out.npz"
    out.write_bytes(b"OLD")
    p = _writer(out, 20_000_000, 1.0)
    assert p.stdout.readline().strip() == "ready"
    deadline = time.monotonic() + 60
    while not temporaries(tmp_path) and p.poll() is None and time.monotonic() < deadline:
        time.sleep(0.0005)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    interrupted = "KeyboardInterrupt" in err
    assert temporaries(tmp_path) == []
    if interrupted:
        assert out.read_bytes() == b"OLD"
    else:  # the write won the race: then the file is complete
        assert np.load(out)["big"].shape == (20_000_000,)


@pytest.mark.slow
def test_two_writers_race_for_one_output(tmp_path):
    """Two processes write the same output at once: it ends whole, one of the two."""
    out = tmp_path / "out.npz"
    for _ in range(3):
        writers = [_writer(out, 5_000_000, value) for value in (1.0, 2.0)]
        for p in writers:
            _, err = p.communicate(timeout=120)
            assert p.returncode == 0, err
        data = np.load(out)
        assert data["big"].shape == (5_000_000,)
        assert float(data["big"][0]) == float(data["big"][-1]) in (1.0, 2.0)
        assert str(data["command"]) in ("1.0", "2.0") and temporaries(tmp_path) == []


@pytest.mark.slow
def test_two_cli_writers_race_for_one_output(work, tmp_path):
    """Two ``fvf flow`` processes with one -o: the output is one of the two, complete."""
    d, _ = work
    args = [str(d / "ico.obj"), str(d / "fields.npz"), "-o", "out.npz"]
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "fvf.cli", "flow", *args, "--t", t],
            cwd=tmp_path,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )  # fmt: skip
        for t in ("1", "2")
    ]
    for p in procs:
        p.communicate(timeout=120)
        assert p.returncode == 0
    data = np.load(tmp_path / "out.npz")
    assert data["t"].tolist() in ([1.0], [2.0]) and data["f_t"].shape == (1, 162)
    assert temporaries(tmp_path) == []


# ---------------------------------------------------------------------------- interrupted
_COMMANDS = {
    "flow": ["flow", "ico.obj", "fields.npz", "--t", "0", "0.5", "--method", "cayley"],
    "upwind": ["flow", "ico.obj", "fields.npz", "--t", "0.3", "--method", "upwind"],
    "bracket": ["bracket", "ico.obj", "fields.npz"],
    "transport": ["transport", "ico.obj", "fields.npz", "--t", "0.25"],
    "design": ["design", "ico.obj", "--constraints", "c.npz", "--soft", "10"],
}
_RESULT = {"flow": "f_t", "upwind": "f_t", "bracket": "commutator", "transport": "u_t"}
#: command -> (lines a full run executes, line counts (entering atomic_path, at its
#: os.replace, leaving it))
_LINES: dict[str, tuple[int, tuple[int, int, int]]] = {}
_SEEN: set[str] = set()


def _rename_line() -> int:
    """The line number of the rename in fvf.io.atomic.atomic_path."""
    import inspect

    import fvf.io.atomic

    lines, first = inspect.getsourcelines(inspect.unwrap(fvf.io.atomic.atomic_path))
    return first + next(i for i, line in enumerate(lines) if "os.replace(" in line)


class _Interrupt:
    """A trace function that raises KeyboardInterrupt at the k-th executed line, and
    notes the line counts at which the output is being written (inside atomic_path)."""

    rename = _rename_line()

    def __init__(self, k: int) -> None:
        self.k, self.count = k, 0
        self.write = [0, 0, 0]

    def __call__(self, frame, event, arg):
        if event == "line":
            self.count += 1
            if self.count == self.k:
                raise KeyboardInterrupt
            if frame.f_code.co_name == "atomic_path" and frame.f_lineno == self.rename:
                self.write[1] = self.count
        elif frame.f_code.co_name == "atomic_path":
            if event == "call" and not self.write[0]:
                self.write[0] = self.count
            elif event == "return":
                self.write[2] = self.count
        return self


def _run(argv: list[str], k: int | None) -> tuple[int, _Interrupt]:
    """main(argv) in the current folder, interrupted at line k (None: not at all)."""
    tracer = _Interrupt(k if k is not None else -1)
    previous_trace, previous_term = sys.gettrace(), signal.getsignal(signal.SIGTERM)
    sys.settrace(tracer)
    try:
        status = main(argv)
    except KeyboardInterrupt:  # landed outside main's handler (a process would die of it)
        status = EXIT_INTERRUPTED
    finally:
        sys.settrace(previous_trace)
        signal.signal(signal.SIGTERM, previous_term)
    return status, tracer


def _complete(path: Path, name: str, argv: list[str]) -> bool:
    """The output of command ``name`` (argv), read back whole."""
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    key = _RESULT.get(name, "v")
    return str(arrays["command"]).split()[1:] == argv and key in arrays


@pytest.fixture(scope="module")
def story(work):
    d, _ = work
    previous = os.getcwd()
    os.chdir(d)  # the commands use paths relative to the module's folder
    yield d
    os.chdir(previous)


# a ZipFile interrupted half-way complains when it is garbage-collected (numpy's, not ours)
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@settings(derandomize=True, max_examples=15, deadline=None, database=None)
@given(
    plan=st.lists(
        st.tuples(st.sampled_from(sorted(_COMMANDS)), st.sampled_from(["a", "b", "c"])),
        min_size=1,
        max_size=3,
    ),
    where=st.floats(0.0, 1.0, exclude_max=True),
    when=st.sampled_from(["anywhere", "writing", "renaming"]),
    which=st.integers(0, 3),
)
def test_interrupted_commands_leave_every_output_old_or_whole(story, plan, where, when, which):
    """Any sequence of commands, one interrupted at a random line: every output file is
    byte-identical to what it was, or a complete result of the command that wrote it;
    no temporary file is left. The line is drawn from the whole run, from the lines that
    write the output, or from the few lines around the rename."""
    d = story
    outputs = {}
    for p in d.glob("out_*.npz"):
        p.unlink()
    which = which % len(plan)
    for i, (name, out) in enumerate(plan):
        argv = [*_COMMANDS[name], "-o", f"out_{out}.npz"]
        if name not in _LINES:
            status, tracer = _run(argv, None)  # how many lines a full run executes
            assert status == EXIT_OK and 0 < tracer.write[0] < tracer.write[1] < tracer.write[2]
            _LINES[name] = (tracer.count, tuple(tracer.write))
            outputs[out] = (name, argv)
            continue
        if i != which:
            assert _run(argv, None)[0] == EXIT_OK
            outputs[out] = (name, argv)
            continue
        before = {p.name: p.read_bytes() for p in d.glob("out_*.npz")}
        total, (first, rename, last) = _LINES[name]
        lo, hi = {"anywhere": (0, total), "writing": (first, last), "renaming": (rename - 2, last)}[
            when
        ]
        k = lo + 1 + int(where * (hi - lo))
        status, _ = _run(argv, k)
        assert status in (EXIT_OK, EXIT_INTERRUPTED)
        target = d / f"out_{out}.npz"
        for p in d.glob("out_*.npz"):  # the other outputs are untouched
            if p != target:
                assert p.read_bytes() == before[p.name]
        after = target.read_bytes() if target.exists() else None
        if after == before.get(target.name):  # the old file, or still no file
            _SEEN.add("kept" if status == EXIT_INTERRUPTED else "finished")
        else:  # or the whole new one
            assert _complete(target, name, argv), (plan, k)
            outputs[out] = (name, argv)
            _SEEN.add("replaced" if status == EXIT_INTERRUPTED else "finished")
        if status == EXIT_OK:
            outputs[out] = (name, argv)
        assert temporaries(d) == []
    for out, (name, argv) in outputs.items():
        assert _complete(d / f"out_{out}.npz", name, argv)


def test_the_interruptions_hit_every_outcome():
    """The property test above saw outputs kept by an interrupted run (an interrupt
    before the rename) and outputs replaced by one (an interrupt after the rename); it
    runs after that test (file order)."""
    if not _LINES:
        pytest.skip("runs after test_interrupted_commands_leave_every_output_old_or_whole")
    assert _SEEN >= {"kept", "replaced"}, _SEEN


def test_read_data_only_reads_the_keys_it_uses(work, tmp_path):
    d, mesh = work
    data = read_data(d / "fields.npz", mesh)
    assert "not read yet" in repr(data)
    data.field("v", mesh)
    assert "float64(320, 3)" in repr(data)
