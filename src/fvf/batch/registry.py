"""The task registry of a batch: one registered function per kind of result.

A task is a function of a context (:class:`MeshContext` for a task on one mesh,
:class:`PairContext` for a task on a mesh pair) returning a :class:`TaskOutput`: arrays to
store in the mesh's result file and figures (scalars) for the row of ``summary.csv``.
Registering a new task is one decorated function::

    from fvf.batch import TaskOutput, register_task

    @register_task("area", description="total surface area")
    def area(ctx):
        return TaskOutput(figures={"total": ctx.mesh.total_area})

Tasks declare the run options they read (``options=("k",)``), so a result is reused only
when those options are unchanged, and the tasks whose arrays they read
(``needs=("fields",)``), which then run first. ``raw=True`` tasks run on the file's
arrays before the :class:`fvf.TriMesh` is built (``repair``, ``info``).

The workers look tasks up by name in their own registry, so a task registered in a user's
script must be importable there too (or be passed to :func:`fvf.batch.run` as the
:class:`Task` object itself, which travels with the job).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..errors import MeshError, ParameterError

if TYPE_CHECKING:
    from ..mesh.trimesh import TriMesh

__all__ = [
    "Task",
    "TaskOutput",
    "MeshContext",
    "PairContext",
    "register_task",
    "registered_tasks",
    "lookup_task",
    "resolve_tasks",
    "accepts",
]

Kind = Literal["mesh", "pair"]


@dataclass(frozen=True)
class TaskOutput:
    """What a task returns.

    Attributes
    ----------
    arrays : mapping of str to array_like
        Stored in the result file under these keys (numeric or string arrays only:
        results are read with ``allow_pickle=False``).
    figures : mapping of str to int, float or str
        Columns ``<task>_<figure>`` of ``summary.csv``.
    """

    arrays: Mapping[str, Any] = field(default_factory=dict)
    figures: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Task:
    """A registered kind of result.

    Attributes
    ----------
    name : str
        What ``--tasks`` calls it.
    func : callable
        ``func(ctx) -> TaskOutput``.
    kind : {"mesh", "pair"}
        Runs once per input mesh, or once per pair of the pairs file.
    needs : tuple of str
        Tasks whose arrays ``func`` reads from ``ctx.arrays`` (added to the batch and run
        first).
    options : tuple of str
        Run options ``func`` reads from ``ctx.options`` (part of the result's hash).
    raw : bool
        Runs on ``ctx.vertices`` / ``ctx.faces`` before the mesh is validated.
    check : callable or None
        ``check(options)`` raises :class:`fvf.ParameterError` for options the task cannot
        honour; called on the driver before anything is submitted.
    description : str
        One line for ``fvf batch --help``.
    """

    name: str
    func: Callable[[Any], TaskOutput]
    kind: Kind = "mesh"
    needs: tuple[str, ...] = ()
    options: tuple[str, ...] = ()
    raw: bool = False
    check: Callable[[Mapping[str, Any]], None] | None = None
    description: str = ""


_REGISTRY: dict[str, Task] = {}


def register_task(
    name: str,
    *,
    kind: Kind = "mesh",
    needs: Iterable[str] = (),
    options: Iterable[str] = (),
    raw: bool = False,
    check: Callable[[Mapping[str, Any]], None] | None = None,
    description: str = "",
) -> Callable[[Callable], Callable]:
    """Decorator: register ``func(ctx) -> TaskOutput`` as the batch task ``name``.

    Parameters are the attributes of :class:`Task`. Registering a name again replaces the
    earlier task (so a newer implementation can take over a name).

    Returns
    -------
    callable
        The decorator; it returns the function unchanged.
    """
    if kind not in ("mesh", "pair"):
        raise ParameterError(f"kind must be 'mesh' or 'pair', not {kind!r}")

    def decorate(func: Callable) -> Callable:
        doc = description or (inspect.getdoc(func) or "").split("\n")[0]
        _REGISTRY[name] = Task(name, func, kind, tuple(needs), tuple(options), raw, check, doc)
        return func

    return decorate


def registered_tasks(kind: Kind | None = None) -> dict[str, Task]:
    """The registered tasks by name (of one kind, when given), in registration order."""
    return {n: t for n, t in _REGISTRY.items() if kind is None or t.kind == kind}


def lookup_task(item: str | Task) -> Task:
    """The registered task of this name (a Task passes through), else
    :class:`fvf.ParameterError` listing the registered names."""
    if isinstance(item, Task):
        return item
    task = _REGISTRY.get(str(item).strip())
    if task is None:
        raise ParameterError(
            f"unknown batch task {item!r}; registered tasks: {', '.join(_REGISTRY)} "
            "(fvf batch --help describes each)"
        )
    return task


def resolve_tasks(tasks: Iterable[str | Task], options: Mapping[str, Any]) -> list[Task]:
    """The tasks to run, their dependencies added, in the order they run.

    Raw tasks first (in registration order), then the others with each task after the
    tasks it needs (otherwise in the order given). Each task's ``check`` is called.

    Raises
    ------
    ParameterError
        An unknown task name (listing the registered ones), a dependency cycle, or
        options a task cannot honour.
    """
    wanted = [lookup_task(t) for t in tasks]
    ordered: list[Task] = []

    def visit(task: Task, path: tuple[str, ...]) -> None:
        if task.name in path:
            raise ParameterError(f"batch tasks depend on each other in a cycle: {path}")
        if any(t.name == task.name for t in ordered):
            return
        for need in task.needs:
            visit(lookup_task(need), (*path, task.name))
        ordered.append(task)

    for task in wanted:
        visit(task, ())
    rank = {n: i for i, n in enumerate(_REGISTRY)}
    raw = sorted((t for t in ordered if t.raw), key=lambda t: rank.get(t.name, len(rank)))
    ordered = raw + [t for t in ordered if not t.raw]
    for task in ordered:
        if task.check is not None:
            task.check(options)
    return ordered


def accepts(func: Callable, name: str) -> bool:
    """Whether ``func`` takes a keyword argument ``name`` (or ``**kwargs``)."""
    try:
        params = inspect.signature(func).parameters
    except (TypeError, ValueError):
        return False
    return name in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


# ---------------------------------------------------------------------------- contexts
class MeshContext:
    """What a mesh task sees: the file, its arrays, the mesh, the options, earlier results.

    Attributes
    ----------
    path : pathlib.Path
        The mesh file.
    vertices : numpy.ndarray, float64 (n, 3)
    faces : numpy.ndarray, int64 (m, 3)
        The file's arrays (after ``repair``, when it ran).
    options : mapping
        The run options (``k``, ``n``, ...).
    arrays : dict of str to numpy.ndarray
        The arrays returned by the tasks that ran before, by key.
    """

    def __init__(self, path: Path, vertices: np.ndarray, faces: np.ndarray, options: Mapping):
        self.path = Path(path)
        self.vertices, self.faces = vertices, faces
        self.options = options
        self.arrays: dict[str, np.ndarray] = {}
        self._mesh: TriMesh | None = None

    @property
    def mesh(self) -> TriMesh:
        """The validated :class:`fvf.TriMesh` (built on first use).

        Raises
        ------
        MeshError
            The arrays are not a valid mesh; the message suggests ``fvf info`` and the
            ``repair`` task.
        """
        if self._mesh is None:
            from ..mesh.trimesh import TriMesh

            try:
                self._mesh = TriMesh(self.vertices, self.faces)
            except MeshError as exc:
                raise type(exc)(
                    f"{exc} (`fvf info {self.path}` lists every problem; the batch task "
                    "'repair' fixes the repairable ones)"
                ) from exc
        return self._mesh

    def replace(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        """Continue with other arrays (what ``repair`` does); the mesh is rebuilt."""
        self.vertices, self.faces, self._mesh = vertices, faces, None


class PairContext:
    """What a pair task sees: both meshes (as :class:`MeshContext`), the map file, options.

    Attributes
    ----------
    source, target : MeshContext
    map_path : pathlib.Path or None
        The pair's vertex map file, if the pairs file gives one.
    options : mapping
    arrays : dict of str to numpy.ndarray
        Arrays of the pair tasks that ran before.
    """

    def __init__(
        self,
        source: MeshContext,
        target: MeshContext,
        map_path: str | Path | None,
        options: Mapping,
    ):
        self.source, self.target = source, target
        self.map_path = None if map_path is None else Path(map_path)
        self.options = options
        self.arrays: dict[str, np.ndarray] = {}

    def point_map(self) -> np.ndarray:
        """The vertex map source → target: int64 (n_source,), 0-based target vertices.

        From the map file (``.npy``, or text with one integer per line), else the identity
        when both meshes have the same number of vertices (registered shapes).

        Raises
        ------
        FieldShapeError
            No map file and different vertex counts, or a map of the wrong shape or range.
        BatchInputError
            The map file is not a regular file (a FIFO, a device), not a vertex map (an
            .npz archive, a table of several columns), or a text line is no integer.
        """
        from ..errors import BatchInputError, FieldShapeError
        from ..io.inputfile import read_index_table, regular_file
        from ..spectral.fmaps import check_p2p

        n_s, n_t = self.source.mesh.n_vertices, self.target.mesh.n_vertices
        if self.map_path is None:
            if n_s != n_t:
                raise FieldShapeError(
                    f"no vertex map for {self.source.path.name} -> {self.target.path.name} "
                    f"and their vertex counts differ ({n_s} vs {n_t}); add a map file as the "
                    "third column of the pairs file"
                )
            return np.arange(n_s)
        regular_file(self.map_path, BatchInputError)  # a FIFO or /dev/zero would never end
        if self.map_path.suffix.lower() == ".npy":
            try:
                raw = np.load(self.map_path, allow_pickle=False)
            except (ValueError, OSError, EOFError) as exc:
                raise BatchInputError(
                    f"{self.map_path}: the vertex map is not a readable .npy array ({exc})"
                ) from None
            if not isinstance(raw, np.ndarray):  # np.load reads an .npz under any name
                raw.close()
                raise BatchInputError(
                    f"{self.map_path}: the vertex map is an .npz archive under an .npy name; "
                    "save the map alone with np.save(path, p2p)"
                )
        else:  # one integer per line, # comments: the message names the file and the line
            raw = read_index_table(self.map_path, 1, "the vertex map", BatchInputError)
        raw = np.asarray(raw)
        if raw.ndim != 1 and not (raw.ndim == 2 and raw.shape[1] == 1):
            raise BatchInputError(
                f"{self.map_path}: the vertex map must be one target vertex per source vertex, "
                f"shape ({n_s},); got {raw.dtype} {raw.shape}"
            )
        try:
            return check_p2p(raw.reshape(-1), n_t, n_s)
        except FieldShapeError as exc:
            raise FieldShapeError(f"{self.map_path}: {exc}") from None
