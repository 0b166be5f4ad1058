"""The worker side of a batch: one job = one mesh (or one pair), read, computed, written.

:func:`run_job` is what the driver submits to Dask. It receives a :class:`MeshJob` or
:class:`PairJob` (paths and options, a few hundred bytes), reads the files itself, runs
the tasks, writes the result file atomically and returns only the summary row (a small
dict). It never raises for a bad mesh: every exception becomes a ``failed`` row naming
its type and message, so one broken file never stops a batch. Only the death of the
worker process escapes it, and Dask reschedules the job on another worker.

It needs neither Dask nor the driver: ``run_job(job)`` in a plain loop gives the same
files and rows.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import math
import sys
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import OutputWriteError, thread_limit_text
from ..io.atomic import atomic_path, deferred_fsync
from ..io.datafile import write_data
from ..io.meshfile import read_mesh
from . import tasks as _builtin  # noqa: F401 (registers the built-in tasks)
from .registry import MeshContext, PairContext, Task, TaskOutput, lookup_task
from .store import ARRAYS_FIELD, KEY_FIELD, file_sha256, result_key, stored_row

__all__ = ["MeshJob", "PairJob", "run_job", "run_jobs"]


@dataclass(frozen=True)
class MeshJob:
    """One mesh of a batch, as shipped to a worker.

    Attributes
    ----------
    name : str
        Result name (``summary.csv``'s ``mesh``).
    path : str
        Absolute path of the mesh file (read by the worker).
    result : str
        Absolute path of the result file to write.
    tasks : tuple of (str or Task)
        Tasks in the order they run (names of registered tasks, or Task objects).
    options : dict
        The options the tasks read.
    options_json : str
        Canonical JSON of tasks and options (:func:`fvf.batch.store.options_text`).
    command : str
        Provenance: the command line or call that started the batch.
    """

    name: str
    path: str
    result: str
    tasks: tuple
    options: dict
    options_json: str
    command: str


@dataclass(frozen=True)
class PairJob:
    """One pair of a batch: as :class:`MeshJob`, with ``source``, ``target`` and ``map``
    paths instead of ``path``."""

    name: str
    source: str
    target: str
    map: str | None
    result: str
    tasks: tuple
    options: dict
    options_json: str
    command: str


# ---------------------------------------------------------------------------- memory
def _reset_peak() -> bool:
    """Reset the process's peak resident size (Linux ``clear_refs``); False if impossible."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def _peak_mb(reset: bool) -> float:
    """Peak resident size since the reset (else since the process started), in MB."""
    if reset:
        with contextlib.suppress(OSError), open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    try:
        import resource
    except ImportError:  # pragma: no cover (Windows)
        return math.nan
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KB on Linux, B on macOS
    return peak / (1024.0 * 1024.0) if sys.platform == "darwin" else peak / 1024.0


# ---------------------------------------------------------------------------- helpers
def _one_line(exc: BaseException) -> str:
    text = thread_limit_text(exc) or " ".join(str(exc).split())
    if isinstance(exc, OSError) and exc.filename is not None and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}"
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _warning_text(caught: Sequence[warnings.WarningMessage]) -> str:
    seen = dict.fromkeys(
        f"{w.category.__name__}: {' '.join(str(w.message).split())[:200]}" for w in caught
    )
    return " | ".join(seen)


def _read(path: str, options: dict) -> MeshContext:
    vertices, faces = read_mesh(path)
    return MeshContext(Path(path), vertices, faces, options)


def _apply(task: Task, ctx: MeshContext | PairContext, figures: dict) -> None:
    out = task.func(ctx)
    if not isinstance(out, TaskOutput):
        raise TypeError(f"batch task {task.name!r} returned {type(out).__name__}, not TaskOutput")
    arrays = {k: np.asarray(v) for k, v in out.arrays.items()}
    bad = [k for k, a in arrays.items() if a.dtype.kind in "fc" and not np.isfinite(a).all()]
    if bad:
        raise FloatingPointError(
            f"task {task.name!r}: the result {bad} has NaN or inf values; nothing was written"
        )
    ctx.arrays.update(arrays)
    for key, value in out.figures.items():
        figures[f"{task.name}_{key}"] = value.item() if isinstance(value, np.generic) else value


def _provenance(
    job: MeshJob | PairJob, key: str, file_hashes: Sequence[str], row: dict, arrays: Sequence[str]
) -> dict[str, np.ndarray]:
    return {
        KEY_FIELD: np.array(key),
        ARRAYS_FIELD: np.array(sorted(arrays), dtype=str),
        "batch_input_sha256": np.array(list(file_hashes), dtype=str),
        "batch_options": np.array(job.options_json),
        "batch_tasks": np.array([t if isinstance(t, str) else t.name for t in job.tasks], str),
        "batch_summary": np.array(json.dumps(row, default=str)),
    }


# ---------------------------------------------------------------------------- jobs
def _run_mesh(job: MeshJob, row: dict, figures: dict) -> tuple[MeshContext, list[str]]:
    """Read, repair/validate and run the tasks of one mesh. A task that fails on a valid
    mesh does not lose the others: its failure (and that of the tasks needing it) is
    returned as ``"task NAME: ExceptionType: message"`` and the rest run."""
    ctx = _read(job.path, job.options)
    row.update(n=len(ctx.vertices), m=len(ctx.faces))
    tasks = [lookup_task(t) for t in job.tasks]
    for task in (t for t in tasks if t.raw):
        _apply(task, ctx, figures)
    mesh = ctx.mesh  # validation: a mesh that is not valid fails here
    row.update(n=mesh.n_vertices, m=mesh.n_faces, chi=int(mesh.euler_characteristic))
    failed: dict[str, str] = {}
    for task in (t for t in tasks if not t.raw):
        lost = [name for name in task.needs if name in failed]
        if lost:
            failed[task.name] = f"needs {', '.join(lost)}, which failed"
            continue
        try:
            _apply(task, ctx, figures)
        except Exception as exc:  # the other tasks' results are kept
            failed[task.name] = _one_line(exc)
    return ctx, [f"task {name}: {why}" for name, why in failed.items()]


def _write_mesh(job: MeshJob, ctx: MeshContext, extra: dict) -> None:
    # write_data is itself atomic (temporary file, fsync, rename): no second wrapper
    write_data(
        job.result,
        {**ctx.arrays, **extra},
        mesh=ctx.mesh,
        mesh_path=job.path,
        command=job.command,
    )


def _run_pair(job: PairJob, row: dict, figures: dict) -> PairContext:
    source, target = _read(job.source, job.options), _read(job.target, job.options)
    ctx = PairContext(source, target, job.map, job.options)
    for task in (lookup_task(t) for t in job.tasks):
        _apply(task, ctx, figures)
    return ctx


def _write_pair(job: PairJob, ctx: PairContext, extra: dict) -> None:
    path = Path(job.result)
    path.parent.mkdir(parents=True, exist_ok=True)
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    arrays = {
        **ctx.arrays,
        "source_path": np.array(job.source),
        "target_path": np.array(job.target),
        "map_path": np.array(job.map or ""),
        "fvf_version": np.array(__version__),
        "command": np.array(job.command),
        "created_utc": np.array(now),
        "layout": np.array("columns"),
        **extra,
    }
    with atomic_path(path) as tmp:
        np.savez(tmp, **arrays)


def _inputs_of(job: MeshJob | PairJob) -> list[str]:
    if isinstance(job, MeshJob):
        return [job.path]
    return [job.source, job.target] + ([job.map] if job.map else [])


def _job_key(job: MeshJob | PairJob) -> tuple[list[str], str]:
    """The SHA-256 of each input file of ``job`` and the key of its result."""
    hashes = [file_sha256(p) for p in _inputs_of(job)]
    return hashes, result_key(hashes, job.options_json)


def stored_result_row(job: MeshJob | PairJob) -> dict[str, Any] | None:
    """The summary row stored in ``job``'s result file when that file is intact and
    current (written for these inputs and options), else None."""
    return stored_row(job.result, _job_key(job)[1])


def run_job(job: MeshJob | PairJob) -> dict[str, Any]:
    """Run one job on this process; write its result; return its summary row.

    Parameters
    ----------
    job : MeshJob or PairJob

    Returns
    -------
    dict
        The row of ``summary.csv``: ``mesh``, ``status`` (``ok``; ``skipped`` when a result
        with the same key exists, then with the stored figures; ``failed`` with ``error``
        = ``"<ExceptionType>: <message>"``, or ``"task NAME: <ExceptionType>: <message>"``
        for each task that failed on a valid mesh, the other tasks' results being written
        all the same), ``n``, ``m``, ``chi``, ``seconds`` (reading,
        computing and writing), ``peak_mb`` (peak resident size of this process while the
        job ran), ``kind``, ``path``, ``result`` (the result file; empty when none was
        written), ``warnings`` (the distinct warnings
        raised) and the figures ``<task>_<figure>``.
    """
    start = time.perf_counter()
    reset = _reset_peak()
    row: dict[str, Any] = {
        "mesh": job.name,
        "status": "failed",
        "error": "",
        "kind": "pair" if isinstance(job, PairJob) else "mesh",
        "path": f"{job.source} -> {job.target}" if isinstance(job, PairJob) else job.path,
        "result": job.result,
    }
    figures: dict[str, Any] = {}
    try:
        hashes, key = _job_key(job)
        stored = stored_row(job.result, key)
        if stored is not None and stored.get("status") == "ok":  # a failed task: again
            return {**stored, "status": "skipped"}
        failed: list[str] = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if isinstance(job, PairJob):
                pair_ctx = _run_pair(job, row, figures)
            else:
                mesh_ctx, failed = _run_mesh(job, row, figures)
        row.update(status="failed" if failed else "ok", warnings=_warning_text(caught))
        row.update(error="; ".join(failed), **figures)
        row.update(seconds=time.perf_counter() - start, peak_mb=_peak_mb(reset))
        made = (pair_ctx if isinstance(job, PairJob) else mesh_ctx).arrays
        extra = _provenance(job, key, hashes, row, list(made))
        if isinstance(job, PairJob):
            _write_pair(job, pair_ctx, extra)
        else:
            _write_mesh(job, mesh_ctx, extra)
    except Exception as exc:  # every failure of one mesh is a row, never a stopped batch
        row.update(status="failed", error=_one_line(exc), result="", **figures)
    row["seconds"] = time.perf_counter() - start
    row["peak_mb"] = _peak_mb(reset)
    return row


def run_jobs(jobs: Sequence[MeshJob | PairJob]) -> list[dict[str, Any]]:
    """:func:`run_job` for several jobs, one after the other (what one Dask task runs: a
    large mesh alone, or a group of small ones); their rows, in order.

    The result files are flushed to disk together when the last job is done
    (:func:`fvf.io.atomic.deferred_fsync`), before the rows are returned: a row that
    reaches the driver as ``ok`` is on disk. Should that flush fail (a disk I/O error), the
    group's new result files are removed and their rows are ``failed`` with the error, so
    a rerun recomputes them.
    """
    rows: list[dict[str, Any]] = []
    try:
        with deferred_fsync():
            rows.extend(run_job(job) for job in jobs)
    except OutputWriteError as exc:
        for row in rows:
            if row["status"] == "ok":
                with contextlib.suppress(OSError):
                    Path(row["result"]).unlink()
                row.update(status="failed", error=_one_line(exc), result="")
    return rows
