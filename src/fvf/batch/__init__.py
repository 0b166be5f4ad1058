"""Batch processing: fvf's tasks over collections of meshes, from a laptop to a cluster.

:func:`run` (and ``fvf batch``) runs registered tasks — eigenbases, fields,
singularities, repairs, reports, maps between pairs — over many mesh files on a Dask
cluster: a local one started for the batch (one single-threaded worker process per core)
or an existing one. Workers read the files and write one result per mesh themselves
(``OUT/meshes/<name>.npz``, atomically); only paths and summary rows travel. Reruns skip
the results that match their inputs and options. See ``docs/batch.md``.

``import fvf.batch`` needs only numpy and scipy; :func:`run` needs the ``[batch]`` extra
(``pip install 'fvf[batch]'``) and raises :class:`fvf.MissingExtraError` without it.

Modules: :mod:`.inputs` (finding meshes, names, pairs files), :mod:`.registry` (tasks and
their contexts), :mod:`.tasks` (the built-in tasks), :mod:`.runner` (the worker side),
:mod:`.store` (hashes, result files, ``summary.csv``, the lock), :mod:`.progress`,
:mod:`.driver` (:func:`run`).
"""

from __future__ import annotations

from . import tasks as _tasks  # noqa: F401 (registers the built-in tasks)
from .driver import DEFAULT_MESH_TASKS, run
from .inputs import MeshInput, PairInput, find_meshes, unique_names
from .registry import (
    MeshContext,
    PairContext,
    Task,
    TaskOutput,
    register_task,
    registered_tasks,
)
from .runner import MeshJob, PairJob, run_job
from .store import RESULT_SCHEMA, SUMMARY_COLUMNS

__all__ = [
    "run",
    "run_job",
    "register_task",
    "registered_tasks",
    "Task",
    "TaskOutput",
    "MeshContext",
    "PairContext",
    "MeshJob",
    "PairJob",
    "MeshInput",
    "PairInput",
    "find_meshes",
    "unique_names",
    "DEFAULT_MESH_TASKS",
    "SUMMARY_COLUMNS",
    "RESULT_SCHEMA",
]
