"""What a batch runs on: mesh files found from files, folders and glob patterns, their
result names, and the mesh pairs of a pairs file.

Everything here runs on the driver and touches only paths (it never reads a mesh), so a
batch over thousands of large scans starts at once. The workers read the files themselves
(:mod:`fvf.batch.runner`).
"""

from __future__ import annotations

import csv
import glob
import hashlib
import os
import re
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import BatchInputError
from ..io.formats import readable_suffixes

__all__ = ["MeshInput", "PairInput", "find_meshes", "unique_names", "read_pairs"]

_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]+")


@dataclass(frozen=True)
class MeshInput:
    """One mesh file of a batch.

    Attributes
    ----------
    path : pathlib.Path
        Absolute path of the file (as the workers will open it).
    name : str
        Its result name, unique within the batch: the file's stem, or more of its path
        where stems collide (:func:`unique_names`).
    """

    path: Path
    name: str


@dataclass(frozen=True)
class PairInput:
    """One mesh pair of a batch (a row of the pairs file).

    Attributes
    ----------
    source, target : MeshInput
        The two meshes, in the order of the row.
    map : pathlib.Path or None
        Optional vertex map file (one target vertex per source vertex, 0-based), for tasks
        that need a given correspondence (``fmap``).
    name : str
        ``"<source name>--<target name>"``, unique within the batch.
    """

    source: MeshInput
    target: MeshInput
    map: Path | None
    name: str


def _is_mesh_file(path: Path) -> bool:
    suffixes = readable_suffixes()  # the mesh formats fvf reads (fvf.io.formats registry)
    return path.is_file() and path.suffix.lower() in suffixes and not path.name.startswith(".")


def _meshes_in(folder: Path) -> list[Path]:
    """Mesh files under ``folder`` (recursively), hidden files and folders left out."""
    found = []
    for root, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        found += [Path(root) / f for f in sorted(files) if _is_mesh_file(Path(root) / f)]
    return found


def find_meshes(inputs: Iterable[str | os.PathLike]) -> list[Path]:
    """The mesh files named by files, folders and glob patterns, in order, without repeats.

    Parameters
    ----------
    inputs : iterable of str or path
        A file is taken as it is (whatever its suffix: a file that is not a mesh becomes a
        ``failed`` row of the batch). A folder contributes every OBJ, OFF and PLY file
        under it (recursively, sorted, hidden files and folders skipped). A glob pattern
        (``*``, ``?``, ``[...]``, ``**`` recursive) contributes the mesh files it matches
        and the mesh files under the folders it matches.

    Returns
    -------
    list of pathlib.Path
        Absolute paths, first appearance first, each file once.

    Raises
    ------
    BatchInputError
        Some inputs do not exist, or are folders or patterns without a mesh file (all
        of them are named).
    """
    found: list[Path] = []
    missing, empty = [], []
    for item in inputs:
        text = os.fspath(item)
        path = Path(text).expanduser()
        if path.is_dir():
            hits = _meshes_in(path)
        elif path.exists():
            hits = [path]
        elif glob.has_magic(text):
            hits = []
            for match in sorted(glob.glob(os.path.expanduser(text), recursive=True)):
                m = Path(match)
                hits += _meshes_in(m) if m.is_dir() else [m] if _is_mesh_file(m) else []
        else:
            missing.append(text)
            continue
        if not hits:
            empty.append(text)
        found += hits
    if missing or empty:
        parts = []
        if missing:
            parts.append(f"no such file, folder or matching pattern: {', '.join(missing)}")
        if empty:
            parts.append(f"no mesh file ({', '.join(readable_suffixes())}) in: {', '.join(empty)}")
        raise BatchInputError(
            "; ".join(parts) + ". Fix: give existing mesh files, folders holding them, or "
            "quoted glob patterns such as 'scans/**/*.ply'"
        )
    seen, unique = set(), []
    for p in found:
        p = p.resolve()
        if p not in seen:
            seen.add(p)
            unique.append(p)
    return unique


def _safe(parts: Sequence[str]) -> str:
    """Path parts joined by ``__``, characters other than letters, digits and ``._+-``
    replaced by ``_``; never hidden (a leading dot gets a ``_``)."""
    label = "__".join(_UNSAFE.sub("_", p) for p in parts)
    return "_" + label if label.startswith(".") or not label else label


def unique_names(paths: Sequence[Path]) -> list[str]:
    """Unique result names for distinct files: the stem, lengthened only where names collide.

    Files whose names collide are named by their path from the deepest folder they share,
    ``__`` for ``/``: ``a/x.off`` and ``b/x.off`` become ``a__x`` and ``b__x``, ``a.off``
    and ``sub/a.off`` become ``a`` and ``sub__a``; if that is not enough the suffix is kept
    (``x.off`` and ``x.obj`` in one folder), then a hash of the path is added. Names are
    compared case-insensitively (so results do not collide on a case-insensitive file
    system). The names depend only on the set of paths, so a rerun finds its results.

    Parameters
    ----------
    paths : sequence of pathlib.Path
        Distinct absolute paths.

    Returns
    -------
    list of str
        One name per path, in the same order.
    """
    paths = list(paths)
    labels = [_safe([p.stem]) for p in paths]
    level = [0] * len(paths)
    while True:
        groups = defaultdict(list)
        for i, label in enumerate(labels):
            groups[label.lower()].append(i)
        clashes = [g for g in groups.values() if len(g) > 1]
        if not clashes:
            return labels
        for group in clashes:
            base = Path(os.path.commonpath([paths[i].parent for i in group]))
            for i in group:
                level[i] += 1
                rel = paths[i].relative_to(base)
                last = rel.stem if level[i] == 1 else rel.name
                labels[i] = _safe([*rel.parent.parts, last])
                if level[i] > 2:
                    labels[i] += "-" + _digest(paths[i])


def _digest(path: Path) -> str:
    return hashlib.sha256(str(path).encode()).hexdigest()[:8]


def _cell(path_text: str, base: Path) -> Path:
    p = Path(path_text.strip()).expanduser()
    return (p if p.is_absolute() else base / p).resolve()


def read_pairs(path: str | os.PathLike) -> list[tuple[Path, Path, Path | None]]:
    """The rows of a pairs file: ``source, target[, map]`` per line.

    Parameters
    ----------
    path : str or path
        A CSV file: one pair per line, ``source,target`` or ``source,target,map``; relative
        paths are relative to the pairs file's folder. Blank lines and lines starting with
        ``#`` are skipped; a first line ``source,target[,map]`` is a header.

    Returns
    -------
    list of (source, target, map or None)
        Absolute paths.

    Raises
    ------
    BatchInputError
        The file is missing, a row has not 2 or 3 cells, or names a file that does not
        exist (the line numbers are named).
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise BatchInputError(f"cannot read the pairs file {path}: {exc.strerror}") from exc
    base, rows, bad, missing = path.resolve().parent, [], [], []
    for lineno, cells in enumerate(csv.reader(text.splitlines()), 1):
        cells = [c.strip() for c in cells]
        if not cells or not any(cells) or cells[0].startswith("#"):
            continue
        if lineno == 1 and [c.lower() for c in cells[:2]] == ["source", "target"]:
            continue
        if len(cells) not in (2, 3) or not all(cells):
            bad.append(lineno)
            continue
        files = [_cell(c, base) for c in cells]
        missing += [f"line {lineno}: {f}" for f in files if not f.is_file()]
        rows.append((files[0], files[1], files[2] if len(files) == 3 else None))
    if bad or missing or not rows:
        why = []
        if bad:
            why.append(f"lines {bad} do not have the form source,target[,map]")
        if missing:
            why.append("missing files: " + "; ".join(missing[:8]))
        if not rows and not bad:
            why.append("it lists no pair")
        raise BatchInputError(
            f"{path}: {'; '.join(why)}. Fix: one pair per line, 'source.off,target.off' or "
            "'source.off,target.off,map.txt', paths relative to the pairs file"
        )
    return rows


def plan_inputs(
    inputs: Iterable[str | os.PathLike], pairs: str | os.PathLike | None
) -> tuple[list[MeshInput], list[PairInput]]:
    """The meshes and pairs of a batch, with unique names over all the files involved.

    Raises
    ------
    BatchInputError
        As :func:`find_meshes` and :func:`read_pairs`; or neither inputs nor pairs given.
    """
    inputs = list(inputs)
    meshes = find_meshes(inputs) if inputs else []
    rows = read_pairs(pairs) if pairs is not None else []
    if not meshes and not rows:
        raise BatchInputError("a batch needs mesh files (INPUTS) or a pairs file (--pairs)")
    everything = list(dict.fromkeys(meshes + [p for r in rows for p in r[:2]]))
    names = dict(zip(everything, unique_names(everything), strict=True))
    mesh_inputs = [MeshInput(p, names[p]) for p in meshes]
    pair_inputs, seen = [], set()
    for source, target, vmap in dict.fromkeys(rows):
        name = f"{names[source]}--{names[target]}"
        while name.lower() in seen:
            name += "-" + _digest(source / str(target) / str(vmap))[:4]
        seen.add(name.lower())
        pair_inputs.append(
            PairInput(
                MeshInput(source, names[source]), MeshInput(target, names[target]), vmap, name
            )
        )
    return mesh_inputs, pair_inputs
