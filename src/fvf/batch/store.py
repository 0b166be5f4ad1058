"""The output folder of a batch: result files, their hashes, ``summary.csv``, the lock.

Layout of ``OUT``::

    OUT/summary.csv            one row per input mesh and per pair (SUMMARY_COLUMNS + figures)
    OUT/meshes/<name>.npz      one result per mesh (the data-file schema of the fvf command)
    OUT/pairs/<a>--<b>.npz     one result per pair
    OUT/.fvf-batch.lock        held while a batch writes into OUT

Every file is written through :func:`fvf.io.atomic.atomic_path`: a result exists whole or
not at all. A result records :data:`KEY_FIELD`, the SHA-256 of its input files' contents
and of the options that made it (:func:`options_text`); a batch reuses a result only when
that key matches, so a rerun skips what is done and redoes what changed.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import json
import math
import os
import re
import socket
import zipfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import BatchOutputError, OutputWriteError
from ..io.atomic import atomic_path, writable_folder

__all__ = [
    "SUMMARY_COLUMNS",
    "RESULT_SCHEMA",
    "KEY_FIELD",
    "ARRAYS_FIELD",
    "file_sha256",
    "options_text",
    "result_key",
    "stored_row",
    "write_summary",
    "output_lock",
    "remove_temporaries",
]

#: Columns of ``summary.csv`` before the per-task figures (``<task>_<figure>``).
SUMMARY_COLUMNS = (
    "mesh",
    "status",
    "error",
    "n",
    "m",
    "chi",
    "seconds",
    "peak_mb",
    "kind",
    "path",
    "result",
    "warnings",
)

#: Version of the result layout; part of every key, so a new layout recomputes.
RESULT_SCHEMA = 2

#: The key of a result file under which its hash is stored.
KEY_FIELD = "batch_key"
#: The key under which a result file lists the arrays its tasks wrote (a result that
#: lost one, say rewritten by hand without it, is computed again).
ARRAYS_FIELD = "batch_arrays"


def file_sha256(path: str | os.PathLike, chunk: int = 1 << 20) -> str:
    """SHA-256 of a file's contents (hex), read in chunks of ``chunk`` bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            h.update(block)
    return h.hexdigest()


def options_text(tasks: Sequence[str], options: Mapping[str, Any]) -> str:
    """The canonical JSON of what a result depends on besides its input files.

    Parameters
    ----------
    tasks : sequence of str
        Task names, in the order they run.
    options : mapping
        The options those tasks read (and only those).
    """
    return json.dumps(
        {"schema": RESULT_SCHEMA, "tasks": list(tasks), "options": dict(options)},
        sort_keys=True,
        default=str,
    )


def result_key(file_hashes: Sequence[str], options_json: str) -> str:
    """SHA-256 (hex) of the input files' hashes and the options' JSON."""
    return hashlib.sha256("\n".join([*file_hashes, options_json]).encode()).hexdigest()


def _intact(path: str | os.PathLike) -> bool:
    """Whether every member of the ``.npz`` at ``path`` matches its stored CRC-32.

    ``numpy.load`` reads a member only when it is asked for, so a result damaged after it
    was written (a zeroed block inside one array) would otherwise look complete.
    """
    with zipfile.ZipFile(path) as archive:
        return archive.testzip() is None


def stored_row(path: str | os.PathLike, key: str) -> dict | None:
    """The summary row stored in the result ``path`` when its key is ``key``, else None.

    A missing, unreadable, damaged (a member whose checksum does not match), stale
    (other key) or incomplete (an array it lists under :data:`ARRAYS_FIELD` is missing)
    result gives None: the mesh is recomputed.
    """
    try:
        if not _intact(path):
            return None
        with np.load(path, allow_pickle=False) as data:
            if KEY_FIELD not in data.files or str(data[KEY_FIELD]) != key:
                return None
            if ARRAYS_FIELD in data.files and not set(data[ARRAYS_FIELD].tolist()) <= set(
                data.files
            ):
                return None
            return json.loads(str(data["batch_summary"]))
    except (OSError, ValueError, KeyError, EOFError):
        return None
    except Exception:  # a damaged zip raises zipfile.BadZipFile, zlib.error and others
        return None


#: First characters that make a spreadsheet read a text cell as a formula.
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _cell(value: Any) -> str:
    """The CSV text of a summary value: floats in shortest round-trip form, NaN and None
    empty; a text cell starting with ``= + - @`` (or a tab, a carriage return) gets a
    leading ``'`` so that a spreadsheet shows it as text instead of running it as a
    formula (numbers, even negative ones, are written as they are)."""
    if value is None:
        return ""
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    if isinstance(value, (bool, int, np.integer, np.floating)):
        return str(value)
    text = str(value)
    if text.startswith(_FORMULA_START):
        return "'" + text
    return text


def columns_of(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """SUMMARY_COLUMNS, then every other key of the rows in order of first appearance."""
    extra = dict.fromkeys(k for row in rows for k in row if k not in SUMMARY_COLUMNS)
    return [*SUMMARY_COLUMNS, *extra]


def write_summary(path: str | os.PathLike, rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """Write ``rows`` as CSV (atomically); return the columns written.

    Floats are written in their shortest round-trip form, missing values as empty cells.
    """
    columns = columns_of(rows)
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell(row.get(c)) for c in columns])
    return columns


#: Names :func:`fvf.io.atomic.atomic_path` gives the temporary files of a batch's outputs:
#: ``.<name>.npz.<hex digits>.npz`` and ``.summary.csv.<hex digits>.csv``.
_TEMPORARY = re.compile(r"\.(?:.+\.npz\.[0-9a-f]+\.npz|summary\.csv\.[0-9a-f]+\.csv)")


def remove_temporaries(folder: str | os.PathLike) -> int:
    """Delete the temporary files that interrupted atomic writes left in ``folder``.

    :func:`fvf.io.atomic.atomic_path` names them ``.<target>.<hex digits><suffix>``; a worker
    killed while writing leaves one behind (its target is untouched). Only names of
    exactly that form are removed (in ``folder``, ``meshes/`` and ``pairs/``): a user's
    own dot-file there (``.summary.csv.swp``, ``.res.npz.bak``) is kept. Returns the count.
    """
    count = 0
    for sub in ("meshes", "pairs", "."):
        d = Path(folder) / sub
        if not d.is_dir():
            continue
        for p in d.glob(".*"):
            if _TEMPORARY.fullmatch(p.name) and p.is_file() and not p.is_symlink():
                with contextlib.suppress(OSError):
                    p.unlink()
                    count += 1
    return count


@contextlib.contextmanager
def output_lock(folder: str | os.PathLike) -> Iterator[Path]:
    """Hold ``folder/.fvf-batch.lock`` (an ``fcntl`` lock) while a batch writes there.

    The lock is released when the block ends or the process dies, so a crashed batch never
    blocks the next one. Where ``fcntl`` is missing (Windows) no lock is taken.

    Raises
    ------
    BatchOutputError
        Another process holds the lock (its host and process id are named), or ``folder``
        exists and is not a folder.
    OutputWriteError
        ``folder`` cannot be created or written into (read-only).
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise BatchOutputError(f"{folder} is not a folder; give -o a folder for the results")
    writable_folder(folder, "the batch results")
    path = folder / ".fvf-batch.lock"
    try:
        import fcntl
    except ImportError:  # pragma: no cover (Windows)
        yield path
        return
    try:
        fh = open(path, "a+")
    except OSError as exc:
        raise OutputWriteError(
            f"{path}: cannot create the batch's lock ({exc.strerror or exc}); nothing was "
            "written. Fix: give -o a folder you can write to"
        ) from exc
    try:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            fh.seek(0)
            holder = fh.read().strip() or "another process"
            raise BatchOutputError(
                f"{folder} is in use by another fvf batch ({holder}); wait for it to finish "
                "or write to another folder"
            ) from exc
        fh.seek(0)
        fh.truncate()
        fh.write(f"host {socket.gethostname()}, pid {os.getpid()}\n")
        fh.flush()
        yield path
    finally:
        fh.close()
