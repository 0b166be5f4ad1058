"""The driver of a batch: plan the jobs, run them on a Dask cluster, write ``summary.csv``.

:func:`run` finds the meshes, checks the tasks and options, takes the output folder's
lock, then submits one Dask task per mesh (and per pair) calling
:func:`fvf.batch.runner.run_job` with the job's paths and options. Workers read the mesh
files and write the results themselves; only paths go out and summary rows come back.
The cluster is a :class:`distributed.LocalCluster` started here (one single-threaded
worker process per core), the cluster of a scheduler address, or a client the caller
already has.
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import time
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

from ..errors import (
    BatchInputError,
    BatchOutputError,
    BatchWarning,
    MissingExtraError,
    ParameterError,
    thread_limit_text,
)
from ..io.atomic import writable_folder
from . import interrupts
from .inputs import MeshInput, PairInput, plan_inputs
from .progress import Progress
from .registry import Task, registered_tasks, resolve_tasks
from .runner import MeshJob, PairJob, run_jobs, stored_result_row
from .store import columns_of, options_text, output_lock, remove_temporaries, write_summary

__all__ = [
    "run",
    "DEFAULT_MESH_TASKS",
    "INSTALL_HINT",
    "MESH_RESOURCE",
    "SUMMARY_INTERVAL",
    "local_cluster_config",
    "chunks",
]

INSTALL_HINT = "pip install 'fvf[batch]'"

#: Tasks of a batch when none are named.
DEFAULT_MESH_TASKS = ("info", "basis", "fields", "singularities")

#: A worker resource: when every worker declares it, each job asks for one unit, so a
#: multi-threaded worker still holds one mesh at a time.
MESH_RESOURCE = "MESH"

#: The module each worker of the local cluster loads at its start (Dask's preload).
WORKER_PRELOAD = "fvf.batch.worker_start"
#: Seconds between two rewrites of ``summary.csv`` while a batch runs.
SUMMARY_INTERVAL = 10.0

#: The most local worker processes per core a batch starts (more is refused: each is a
#: Python process with its own memory limit, and the machine would only thrash).
WORKERS_PER_CORE = 4
#: The smallest memory limit of a local worker: a Python process with numpy, scipy, fvf
#: and distributed imported holds 105 MiB (measured), and under 1 KB a worker was killed
#: as it started, over and over (a batch that never ended).
MIN_WORKER_MEMORY = 256 * 2**20

#: Input bytes that make one Dask task: smaller files are grouped up to this size.
CHUNK_BYTES = 256 * 1024

#: At most this many jobs in one Dask task.
CHUNK_MAX = 16

#: Groups are made small enough to give each thread of the cluster this many tasks.
CHUNKS_PER_THREAD = 4

#: Seconds between two looks at the cluster's size (an adaptive cluster grows and shrinks).
CAPACITY_INTERVAL = 2.0

#: Seconds to wait for a scheduler to answer, and for its first worker.
#: Seconds a local cluster may take to start its workers.
START_TIMEOUT = 60.0
CONNECT_TIMEOUT = 30.0


def _require_dask():
    """``distributed``, or :class:`fvf.MissingExtraError` naming the extra."""
    try:
        import dask  # noqa: F401
        import distributed
    except ImportError as exc:
        raise MissingExtraError(
            f"fvf.batch needs dask.distributed, which is not installed ({exc}). Fix: {INSTALL_HINT}"
        ) from exc
    return distributed


def local_cluster_config(retries: int) -> dict[str, Any]:
    """The Dask settings of the local cluster :func:`run` starts.

    ``allowed-failures``: a job whose worker died ``retries + 1`` times fails
    (``KilledWorker``) instead of killing more workers; ``worker-saturation`` 1.0: a worker
    holds only the job it runs (no queue of prefetched jobs that a dying worker would
    take down with it); no spilling or pausing (results are files, not worker memory),
    and the nanny restarts a worker at 95 % of its memory limit. Background work that
    competes with the tasks for the worker's core is cut: no statistical profiler (it
    samples every thread's stack every 10 ms), event-loop ticks every 500 ms instead of
    20 ms, system metrics every 2 s, no GIL monitor. The workers get Dask's
    ``pre-spawn-environ`` (BLAS and OpenMP on one thread) without its
    ``MALLOC_TRIM_THRESHOLD_=65536``: that setting also turns off glibc's adaptive mmap
    threshold, so every array above 128 KiB is a fresh mmap with its pages zero-filled on
    first touch: the serial loop over the 40-mesh mixed corpus of
    ``benchmarks/bench_batch.py`` takes 1.35-1.55x the CPU time with it set (same run).
    Each worker loads :data:`WORKER_PRELOAD`, which makes it ignore SIGINT: a terminal's
    Ctrl-C reaches every process of its group, and the workers printed their tracebacks
    of it while the driver closed them.
    """
    return {
        "distributed.scheduler.allowed-failures": retries,
        "distributed.scheduler.worker-saturation": 1.0,
        "distributed.worker.memory.target": False,
        "distributed.worker.memory.spill": False,
        "distributed.worker.memory.pause": False,
        "distributed.worker.memory.terminate": 0.95,
        "distributed.worker.profile.enabled": False,
        "distributed.admin.tick.interval": "500ms",
        "distributed.admin.system-monitor.interval": "2s",
        "distributed.admin.system-monitor.gil.enabled": False,
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,  # None unsets
        "distributed.worker.preload": [WORKER_PRELOAD],
    }


# ---------------------------------------------------------------------------- planning
def _check_options(
    k: int,
    n: int | None,
    workers: int | None,
    memory_limit: str | int | float | None,
    retries: int,
    client: Any,
    scheduler: str | None,
) -> None:
    if client is not None and scheduler is not None:
        raise ParameterError("give either client or scheduler, not both")
    if (client is not None or scheduler is not None) and (
        workers is not None or memory_limit != "auto"
    ):
        raise ParameterError(
            "workers and memory_limit (--workers, --memory-limit) size the local cluster; "
            "an existing cluster (--scheduler, client) has its own workers: drop them"
        )
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ParameterError(f"workers must be an integer >= 1, not {workers!r}")
    cores = os.cpu_count() or 1
    if workers is not None and client is None and scheduler is None:
        if workers > WORKERS_PER_CORE * cores:
            raise ParameterError(
                f"workers={workers} is more than this machine can run: at most "
                f"{WORKERS_PER_CORE} worker processes per core ({WORKERS_PER_CORE * cores} "
                f"here, {cores} cores). Fix: --workers {cores} (one per core, the default), "
                "or --scheduler ADDRESS for a larger cluster"
            )
    if not isinstance(retries, int) or isinstance(retries, bool) or retries < 0:
        raise ParameterError(f"retries must be an integer >= 0, not {retries!r}")
    if memory_limit is not None and memory_limit != "auto":
        from dask.utils import parse_bytes

        try:
            size = parse_bytes(memory_limit) if isinstance(memory_limit, str) else memory_limit
        except (ValueError, TypeError) as exc:
            raise ParameterError(
                f"memory limit {memory_limit!r} is not a size such as '4GB', '500MiB' or 'auto'"
            ) from exc
        if not size >= MIN_WORKER_MEMORY:  # a worker this small dies as it starts: a hang
            raise ParameterError(
                f"memory limit {memory_limit!r} is below the {MIN_WORKER_MEMORY // 2**20} MiB "
                "a worker process needs to start (with numpy and scipy loaded); give at least "
                "'256MiB', or 'auto'"
            )


def _split_tasks(
    tasks: Iterable[str | Task] | str | None, has_meshes: bool, has_pairs: bool, options: dict
) -> tuple[list[Task], list[Task]]:
    """The mesh tasks and the pair tasks to run (defaults when ``tasks`` is None)."""
    if isinstance(tasks, str):
        tasks = [t for t in tasks.split(",") if t.strip()]
    if tasks is None:
        pair_default = "match" if "match" in registered_tasks("pair") else "fmap"
        tasks = (DEFAULT_MESH_TASKS if has_meshes else ()) + ((pair_default,) if has_pairs else ())
    ordered = resolve_tasks(list(tasks), options)
    mesh = [t for t in ordered if t.kind == "mesh"]
    pair = [t for t in ordered if t.kind == "pair"]
    pair_names = ", ".join(registered_tasks("pair")) or "none registered"
    if has_pairs and not pair:
        raise ParameterError(f"--pairs needs a pair task in --tasks ({pair_names})")
    if pair and not has_pairs:
        raise ParameterError(
            f"the pair tasks {[t.name for t in pair]} need a pairs file (--pairs pairs.csv)"
        )
    if has_meshes and not mesh:
        raise ParameterError(
            f"the input meshes need a mesh task in --tasks ({', '.join(registered_tasks('mesh'))})"
        )
    return mesh, pair


def _shipped(task: Task) -> str | Task:
    """A registered task travels by name (the worker's registry has it), others whole."""
    return task.name if registered_tasks().get(task.name) is task else task


def _options_of(tasks: Sequence[Task], options: dict) -> dict:
    return {o: options[o] for t in tasks for o in t.options if o in options}


def _jobs(
    out: Path,
    meshes: Sequence[MeshInput],
    pairs: Sequence[PairInput],
    mesh_tasks: Sequence[Task],
    pair_tasks: Sequence[Task],
    options: dict,
    command: str,
) -> list[MeshJob | PairJob]:
    jobs: list[MeshJob | PairJob] = []
    for tasks, items in ((mesh_tasks, meshes), (pair_tasks, pairs)):
        if not items:
            continue
        opts = _options_of(tasks, options)
        text = options_text([t.name for t in tasks], opts)
        shipped = tuple(_shipped(t) for t in tasks)
        for item in items:
            if isinstance(item, MeshInput):
                result = out / "meshes" / f"{item.name}.npz"
                jobs.append(
                    MeshJob(item.name, str(item.path), str(result), shipped, opts, text, command)
                )
            else:
                result = out / "pairs" / f"{item.name}.npz"
                vmap = None if item.map is None else str(item.map)
                jobs.append(
                    PairJob(
                        item.name,
                        str(item.source.path),
                        str(item.target.path),
                        vmap,
                        str(result),
                        shipped,
                        opts,
                        text,
                        command,
                    )
                )
    return jobs


def _identity(path: str | os.PathLike) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino


def _check_not_inputs(
    out: Path, jobs: Sequence[MeshJob | PairJob], pairs: str | os.PathLike | None
) -> None:
    """Refuse a batch whose outputs (``summary.csv``, the lock, a result file) would
    replace one of its inputs (a mesh, a map or the pairs file), before anything runs.

    One ``stat`` per file: inputs and outputs are compared by device and inode (a hard
    link, a path through linked folders) and by resolved path (a symbolic link).
    """
    from ..errors import InputOverwriteError
    from ..io.atomic import same_file

    inputs: list[str] = [os.fspath(pairs)] if pairs is not None else []
    for job in jobs:
        if isinstance(job, MeshJob):
            inputs.append(job.path)
        else:
            inputs += [job.source, job.target] + ([job.map] if job.map else [])
    ids = {i: p for p in inputs if (i := _identity(p)) is not None}
    real = {os.path.realpath(p): p for p in inputs}
    outputs = [out / "summary.csv", out / ".fvf-batch.lock", *(Path(j.result) for j in jobs)]
    for output in outputs:
        hit = ids.get(_identity(output)) or real.get(os.path.realpath(output))  # type: ignore[arg-type]
        if hit is not None:
            how = same_file(output, hit) or f"the input {hit}"
            raise InputOverwriteError(
                f"the batch output {output} is {how}: writing it would replace an input. "
                "Fix: give -o a folder that holds none of the inputs' output names (a "
                "fresh folder), or move the input."
            )


def _size(job: MeshJob | PairJob) -> int:
    paths = [job.path] if isinstance(job, MeshJob) else [job.source, job.target]
    total = 0
    for p in paths:
        with contextlib.suppress(OSError):
            total += os.stat(p).st_size
    return total


# ---------------------------------------------------------------------------- cluster
def _has_bokeh() -> bool:
    return importlib.util.find_spec("bokeh") is not None


@contextlib.contextmanager
def _connected(
    client: Any,
    scheduler: str | None,
    workers: int | None,
    memory_limit: str | int | float | None,
    retries: int,
) -> Iterator[tuple[Any, str]]:
    """A client of the given, addressed or a new local cluster, and a description."""
    distributed = _require_dask()
    if client is not None:
        yield client, "the given client's cluster"
        return
    if scheduler is not None:
        try:
            _probe_scheduler(scheduler, CONNECT_TIMEOUT)
            c = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as exc:
            raise BatchInputError(
                f"cannot reach the Dask scheduler at {scheduler!r} ({type(exc).__name__}: "
                f"{exc}); start one (`dask scheduler`, then `dask worker ADDRESS`) or drop "
                "--scheduler to use a local cluster"
            ) from exc
        try:
            yield c, f"the cluster at {scheduler}"
        finally:
            c.close()
        return
    import dask

    with dask.config.set(local_cluster_config(retries)):
        n = workers or dask.system.CPU_COUNT
        try:
            cluster = _started_within(
                START_TIMEOUT,
                lambda: distributed.LocalCluster(
                    n_workers=n,
                    threads_per_worker=1,
                    processes=True,
                    memory_limit=memory_limit,
                    host="127.0.0.1",
                    dashboard_address="127.0.0.1:0",  # a free port: never another's 8787
                    silence_logs=logging.CRITICAL,  # worker teardown noise; failures are rows
                ),
                stop=lambda cluster: cluster.close(),
            )
        except (RuntimeError, OSError, TimeoutError, MemoryError) as exc:
            if interrupts.pressed():  # workers that died of the same Ctrl-C (a terminal's)
                raise KeyboardInterrupt from exc
            raise BatchInputError(
                f"could not start a local Dask cluster of {n} worker process"
                f"{'es' if n != 1 else ''} ({type(exc).__name__}: {exc}); under a memory "
                "limit (ulimit -v) give fewer --workers or more memory, or use --scheduler"
            ) from exc
        try:
            with distributed.Client(cluster) as c:
                yield c, f"a local cluster of {n} worker process{'es' if n != 1 else ''}"
        finally:
            cluster.close()


def _started_within(
    seconds: float, start: Callable[[], Any], stop: Callable[[Any], Any] | None = None
) -> Any:
    """``start()`` run in a daemon thread; TimeoutError when it has not returned within
    ``seconds`` (a local cluster whose workers keep dying under a memory limit never
    does), its exception re-raised here otherwise. Interrupted while waiting, it waits on
    (up to ``seconds``) and ``stop``s what was started before re-raising the interrupt,
    so that no cluster is left starting behind the interpreter's exit."""
    import threading

    done: list = []
    began, finished = threading.Event(), threading.Event()

    def run() -> None:
        began.set()
        try:
            done.append((True, start()))
        except BaseException as exc:  # noqa: BLE001 -- handed to the caller
            done.append((False, exc))
        finished.set()

    try:  # the interrupt may come while the thread starts, during the wait or just after
        threading.Thread(target=run, name="fvf-start-cluster", daemon=True).start()
        if not finished.wait(seconds):
            raise TimeoutError(f"its workers did not start within {seconds:g} s")
        ok, value = done[0]
        if not ok:
            raise value
        return value
    except KeyboardInterrupt:
        if began.wait(1.0):  # (not when interrupted before the thread was created)
            finished.wait(seconds)  # further presses are ignored meanwhile (held)
        if done and done[0][0] and stop is not None:
            stop(done[0][1])
        raise


def _result_folders(jobs: Sequence[MeshJob | PairJob]) -> None:
    """Create the folders the results go to (``OUT/meshes``, ``OUT/pairs``) before any
    work: :class:`fvf.BatchOutputError` when a file is in the way, OutputWriteError when
    they cannot be created or written."""
    for folder in sorted({Path(job.result).parent for job in jobs}):
        if folder.exists() and not folder.is_dir():
            raise BatchOutputError(
                f"{folder} is a file, where the batch puts its results; move it away or "
                "give -o another folder"
            )
        writable_folder(folder, "the batch results")


def _probe_scheduler(address: str, timeout: float) -> None:
    """Ask a plain TCP scheduler who it is, within ``timeout`` seconds in all: a server
    that accepts the connection and never answers would hold ``distributed.Client`` for
    ever (its own timeout covers the connection, not the handshake). Raises TimeoutError
    or OSError; other protocols (tls://, inproc://) are left to the client."""
    import asyncio

    from distributed.comm import connect

    if "://" in address and not address.startswith("tcp://"):
        return

    async def identity() -> None:
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            await comm.read()
        finally:
            comm.abort()

    async def bounded() -> None:
        await asyncio.wait_for(identity(), timeout)

    import threading

    failure: list[BaseException] = []

    def probe() -> None:  # in a thread of its own: the caller may run an event loop
        try:
            asyncio.run(bounded())
        except BaseException as exc:  # handed to the caller
            failure.append(exc)

    thread = threading.Thread(target=probe, name="fvf-scheduler-probe", daemon=True)
    thread.start()
    thread.join(timeout + 5.0)
    if thread.is_alive() or (failure and isinstance(failure[0], asyncio.TimeoutError)):
        raise TimeoutError(f"no answer within {timeout:g} s")
    if failure:
        raise failure[0]


def _warm() -> str | None:
    """Import the worker side (numpy, scipy, fvf) before the first job is timed; the
    worker's ``MALLOC_TRIM_THRESHOLD_`` (see :func:`local_cluster_config`)."""
    import os

    import fvf.batch.runner  # noqa: F401

    return os.environ.get("MALLOC_TRIM_THRESHOLD_")


def _prepare(client: Any, note: Callable[[str], None], local: bool) -> dict | None:
    """Wait for a worker, warm the workers up, print the dashboard; the jobs' resources."""
    import warnings

    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
    except (TimeoutError, OSError) as exc:
        raise BatchInputError(
            f"the Dask cluster has no worker after {CONNECT_TIMEOUT:g} s; start some with "
            "`dask worker SCHEDULER_ADDRESS --nthreads 1`"
        ) from exc
    trims = client.run(_warm)
    if any(value is not None for value in trims.values()):
        note(
            "fvf batch: the workers run with MALLOC_TRIM_THRESHOLD_ set (Dask's nanny sets "
            "65536 by default), which costs fvf's jobs about 40 % more CPU time; start them "
            "with the Dask setting distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_ "
            "removed (docs/batch.md)"
        )
    info = client.scheduler_info()
    if "dashboard" in info.get("services", {}) and (_has_bokeh() or not local):
        note(f"fvf batch: Dask dashboard at {client.dashboard_link}")
    workers = list(info.get("workers", {}).values())
    if workers and all(MESH_RESOURCE in (w.get("resources") or {}) for w in workers):
        return {MESH_RESOURCE: 1}
    many = sum(w.get("nthreads", 1) > 1 for w in workers)
    if many:
        warnings.warn(
            f"{many} of the cluster's {len(workers)} workers run several threads and declare "
            f"no {MESH_RESOURCE} resource, so such a worker may hold several meshes at once; "
            f"start workers with --nthreads 1 or --resources {MESH_RESOURCE}=1",
            BatchWarning,
            stacklevel=4,
        )
    return None


def _lost_row(job: MeshJob | PairJob, exc: BaseException, retries: int | None) -> dict:
    """The row of a job whose worker died too often (or whose future failed otherwise)."""
    text = thread_limit_text(exc) or " ".join(str(exc).split())
    if type(exc).__name__ == "KilledWorker":
        limit = "" if retries is None else f" (--retries {retries})"
        text = (
            f"the worker process died each time it ran this job{limit}: out of memory "
            "(raise --memory-limit) or a crash in native code"
        )
    return {
        "mesh": job.name,
        "status": "failed",
        "error": f"{type(exc).__name__}: {text}",
        "kind": "mesh" if isinstance(job, MeshJob) else "pair",
        "path": job.path if isinstance(job, MeshJob) else f"{job.source} -> {job.target}",
        "result": "",  # nothing was written for it
    }


def _capacity(client: Any, resources: dict | None) -> int:
    """Jobs the cluster runs at once: its threads, or its MESH resource units."""
    if resources:
        workers = client.scheduler_info()["workers"].values()
        units = sum((w.get("resources") or {}).get(MESH_RESOURCE, 0) for w in workers)
        return max(1, int(units))
    return max(1, sum(client.nthreads().values()))


def chunks(sizes: Sequence[int], capacity: int) -> deque[tuple[int, ...]]:
    """Group jobs into Dask tasks: large files alone, small ones together, largest first.

    A Dask task costs a few milliseconds of scheduling (tens on a loaded machine), as much
    as a small mesh's computation. Files smaller than the target size travel in groups
    whose files add up to it, at most :data:`CHUNK_MAX` jobs; the target is
    :data:`CHUNK_BYTES`, smaller when that would leave fewer than :data:`CHUNKS_PER_THREAD`
    tasks per thread of the cluster (so the work still spreads over every worker).

    Parameters
    ----------
    sizes : sequence of int
        Bytes of input of each job.
    capacity : int
        Jobs the cluster runs at once.

    Returns
    -------
    collections.deque of tuple of int
        Job indices per task, in the order to submit them (largest files first).
    """
    order = sorted(range(len(sizes)), key=lambda i: -sizes[i])
    target = min(CHUNK_BYTES, sum(sizes) / (CHUNKS_PER_THREAD * max(capacity, 1)))
    groups: deque[tuple[int, ...]] = deque()
    current: list[int] = []
    total = 0
    for i in order:
        if sizes[i] >= target:
            groups.append((i,))
            continue
        current.append(i)
        total += sizes[i]
        if total >= target or len(current) >= CHUNK_MAX:
            groups.append(tuple(current))
            current, total = [], 0
    if current:
        groups.append(tuple(current))
    return groups


def _execute(
    client: Any,
    jobs: Sequence[MeshJob | PairJob],
    progress: Progress,
    resources: dict | None,
    retries: int | None,
    rows: dict[int, dict],
    save: Callable[[dict[int, dict]], None],
) -> None:
    """Run the jobs, largest files first, at most one task per worker thread at a time; put
    each row into ``rows`` (by job index) as it finishes. On an interrupt the tasks in
    flight are cancelled (the rows so far stay in ``rows``).

    Tasks (one job, or a group of small ones: :func:`chunks`) are handed to the scheduler
    only as threads free up (``as_completed.add``): a worker then never holds a task
    waiting behind the one it runs, so a worker that dies takes down only its own task,
    which alone counts towards ``retries``; and the scheduler holds a few tasks, not one
    per mesh of a very large batch. A group whose workers died too often is split and its
    jobs rerun one by one (those finished are then skipped), so only the job that kills
    its workers ends as ``failed``.
    """
    from distributed import as_completed

    token = uuid.uuid4().hex[:8]
    capacity, checked = _capacity(client, resources), time.monotonic()
    waiting = chunks([_size(job) for job in jobs], capacity)
    futures: dict[Any, tuple[int, ...]] = {}
    done = as_completed()

    def submit_more() -> None:
        nonlocal capacity, checked
        if time.monotonic() - checked > CAPACITY_INTERVAL:  # workers come and go
            capacity, checked = _capacity(client, resources), time.monotonic()
        while waiting and len(futures) < capacity:
            group = waiting.popleft()
            first = jobs[group[0]].name
            key = f"fvf-batch-{first}{f'+{len(group) - 1}' if len(group) > 1 else ''}-{token}"
            batch = [jobs[i] for i in group]
            future = client.submit(run_jobs, batch, key=key, pure=False, resources=resources)
            futures[future] = group
            done.add(future)

    submit_more()
    try:
        for future in done:
            group = futures.pop(future)
            submit_more()  # the freed thread starts its next task while this one's rows travel
            try:
                results = future.result()
            except Exception as exc:  # KilledWorker, a lost scheduler, ...
                if len(group) > 1 and type(exc).__name__ == "KilledWorker":
                    waiting.extendleft((i,) for i in reversed(group))
                    results = []
                else:
                    results = [_lost_row(jobs[i], exc, retries) for i in group]
            future.release()
            for i, row in zip(group, results, strict=False):
                rows[i] = row
                progress.update(row)
            save(rows)
            submit_more()
    finally:
        if futures:
            client.cancel(list(futures))


def _stamp(path: str) -> tuple[int, int, int] | None:
    """The file's (inode, mtime in ns, size), or None when there is none."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size


def _result_stamps(jobs: Sequence[MeshJob | PairJob]) -> list[tuple[int, int, int] | None]:
    """Per job, its result file's :func:`_stamp`."""
    return [_stamp(job.result) for job in jobs]


def _written_meanwhile(
    jobs: Sequence[MeshJob | PairJob],
    rows: dict[int, dict],
    before: list[tuple[int, int, int] | None],
) -> dict[int, dict]:
    """The rows of jobs without one whose result files changed since ``before``
    (:func:`_result_stamps` when the batch started: no clock is compared, so coarse file
    times and another host's clock do not matter) and are current: tasks that finished
    while an interrupted batch cancelled the others and closed its cluster. Their rows are
    read from the result files, as a rerun would; a file that cannot be read (an input
    removed meanwhile) is left to the rerun."""
    found = {}
    for i, job in enumerate(jobs):
        stamp = None if i in rows else _stamp(job.result)
        if stamp is None or stamp == before[i]:
            continue
        try:
            row = stored_result_row(job)
        except (OSError, ValueError):
            continue
        if row is not None:
            found[i] = row
    return found


def _table(rows: list[dict], columns: list[str], as_frame: bool | None) -> Any:
    """A pandas.DataFrame of the rows (when pandas is there and wanted), else a list."""
    if as_frame is not False:
        try:
            import pandas as pd
        except ImportError:
            if as_frame:
                raise MissingExtraError("as_frame=True needs pandas: pip install pandas") from None
        else:
            frame = pd.DataFrame(rows, columns=columns)
            for c in columns:  # integer columns with gaps (failed rows): nullable integers
                values = [r[c] for r in rows if r.get(c) is not None]
                if values and all(isinstance(v, int) and not isinstance(v, bool) for v in values):
                    frame[c] = frame[c].astype("Int64")
            return frame
    return [{c: row.get(c) for c in columns} for row in rows]


# ---------------------------------------------------------------------------- run
def run(
    inputs: Iterable[str | os.PathLike] = (),
    out: str | os.PathLike = "fvf-batch",
    tasks: Iterable[str | Task] | str | None = None,
    *,
    k: int = 50,
    n: int | None = None,
    quads: int | None = None,
    fallback: str = "error",
    pairs: str | os.PathLike | None = None,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    memory_limit: str | int | float | None = "auto",
    retries: int = 3,
    progress: bool = True,
    as_frame: bool | None = None,
    command: str | None = None,
) -> Any:
    """Run tasks over many meshes (and mesh pairs) in parallel on a Dask cluster.

    Each mesh is one Dask task: a worker process reads the file, runs the tasks
    (:mod:`fvf.batch.tasks`), writes ``OUT/meshes/<name>.npz`` atomically and returns a
    summary row. Results whose key (SHA-256 of the input file and of the tasks' options)
    matches are skipped, so rerunning an interrupted batch finishes it. A mesh that fails
    is a ``failed`` row; a worker that dies has its job rerun on another worker, up to
    ``retries`` times. See ``docs/batch.md``.

    Parameters
    ----------
    inputs : iterable of str or path
        Mesh files, folders (searched recursively for OBJ, OFF, PLY) and glob patterns.
    out : str or path
        Output folder: ``summary.csv``, ``meshes/``, ``pairs/``.
    tasks : iterable of str or Task, or comma-separated str, optional
        Registered task names (:func:`fvf.batch.registered_tasks`) or :class:`Task`
        objects. Default: ``info, basis, fields, singularities`` for meshes, and
        ``match`` (if ``fvf.match`` exists, else ``fmap``) for pairs.
    k : int
        Eigenpairs of ``basis`` and ``fmap``.
    n : int, optional
        Symmetry of the fields (N-fields, when :func:`fvf.design_field` takes ``n``).
    quads : int, optional
        Quads per mesh of the ``quad`` task (``target_faces`` of :func:`fvf.quad_mesh`;
        default m / 10).
    fallback : {"error", "split"}
        The ``quad`` task's ``fallback`` (:func:`fvf.quad_mesh`): a component whose
        attempts all fail fails the mesh, or is split from triangles.
    pairs : str or path, optional
        CSV of mesh pairs, ``source,target[,map]`` per line: one pair task per row.
    client : distributed.Client, optional
        Run on this client's cluster (it is left open).
    scheduler : str, optional
        Address of a running Dask scheduler, e.g. ``"tcp://10.0.0.5:8786"``.
    workers : int, optional
        Worker processes of the local cluster (default: one per core).
    memory_limit : str, int, float or None
        Memory limit per worker of the local cluster (``"4GB"``; ``"auto"``: the machine's
        memory divided among the workers; None: none). A worker past 95 % of it is
        restarted and its job retried.
    retries : int
        How many times a job may be rerun after its worker died (the local cluster's
        ``allowed-failures``; a cluster at ``scheduler`` keeps its own setting).
    progress : bool
        Show progress on stderr.
    as_frame : bool, optional
        Return a pandas DataFrame (default when pandas is installed) or a list of dicts.
    command : str, optional
        Provenance stored in every result (default: this call).

    Returns
    -------
    pandas.DataFrame or list of dict
        The rows of ``OUT/summary.csv``, in input order (meshes, then pairs): ``mesh``,
        ``status`` (``ok``, ``skipped``, ``failed``), ``error``, ``n``, ``m``, ``chi``,
        ``seconds``, ``peak_mb``, ``kind``, ``path``, ``result``, ``warnings`` and the
        task figures ``<task>_<figure>``.

    Raises
    ------
    MissingExtraError
        dask.distributed is not installed (``pip install 'fvf[batch]'``).
    BatchInputError
        Missing inputs, a bad pairs file, an unreachable scheduler.
    BatchOutputError
        ``out`` is a file, or another batch is writing into it.
    InputOverwriteError
        An output (``summary.csv``, a result file) would replace an input (a mesh, a map,
        the pairs file); checked before anything runs.
    ParameterError
        Unknown tasks or invalid options (``workers`` beyond
        :data:`WORKERS_PER_CORE` per core of this machine).
    """
    _require_dask()
    _check_options(k, n, workers, memory_limit, retries, client, scheduler)
    options = {"k": k, "n": n, "quads": quads, "fallback": fallback}
    meshes, pair_inputs = plan_inputs(inputs, pairs)
    mesh_tasks, pair_tasks = _split_tasks(tasks, bool(meshes), bool(pair_inputs), options)
    out = Path(out).resolve()
    if command is None:
        command = f"fvf.batch.run({len(meshes)} meshes, {len(pair_inputs)} pairs)"
    jobs = _jobs(out, meshes, pair_inputs, mesh_tasks, pair_tasks, options, command)
    _check_not_inputs(out, jobs, pairs)
    summary_path = out / "summary.csv"
    rows: dict[int, dict] = {}
    show = Progress(len(jobs), enabled=progress)
    last_save = [time.perf_counter()]

    def save(current: dict[int, dict], force: bool = False) -> None:
        if force or time.perf_counter() - last_save[0] >= SUMMARY_INTERVAL:
            write_summary(summary_path, [current[i] for i in sorted(current)])
            last_save[0] = time.perf_counter()

    with interrupts.held(), output_lock(out):  # one Ctrl-C stops, no second cuts cleanup
        before = _result_stamps(jobs)  # to find the results written if interrupted
        remove_temporaries(out)
        _result_folders(jobs)
        try:
            with _connected(client, scheduler, workers, memory_limit, retries) as (c, where):
                local = client is None and scheduler is None
                resources = _prepare(c, show.note, local)
                show.note(f"fvf batch: {len(meshes)} meshes, {len(pair_inputs)} pairs on {where}")
                show.start = time.perf_counter()
                _execute(c, jobs, show, resources, retries if local else None, rows, save)
        finally:
            show.close()
            if len(rows) < len(jobs):  # interrupted or failed: results written meanwhile
                rows.update(_written_meanwhile(jobs, rows, before))
            save(rows, force=True)
            remove_temporaries(out)
    ordered = [rows[i] for i in sorted(rows)]
    return _table(ordered, columns_of(ordered), as_frame)
