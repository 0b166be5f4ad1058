"""Opening input files safely: regular files only, read with a size check.

A path can name something that is not a file: ``/dev/zero`` (endless), a FIFO (blocks
until someone writes), a directory, a socket. Reading those "until the end" hangs or
fills the memory. :func:`regular_file` refuses them with a typed error before anything
is opened; :func:`read_bytes` reads exactly the size the file had when it was checked
(a file that grows meanwhile is reported, not read forever) and turns an allocation
failure into the same typed error.
"""

from __future__ import annotations

import os
import re
import stat

import numpy as np

from ..errors import FvfError

__all__ = ["regular_file", "read_bytes", "read_index_table", "describe_mode"]


_INTEGER = re.compile(r"[+-]?[0-9]{1,18}")


def describe_mode(mode: int) -> str:
    """What a ``st_mode`` is, in words ("a directory", "a FIFO (named pipe)", ...)."""
    kinds = (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    for test, name in kinds:
        if test(mode):
            return name
    return "not a regular file"


def regular_file(path: str | os.PathLike, error: type[FvfError]) -> os.stat_result:
    """``os.stat(path)`` (following links) when ``path`` is a regular file.

    Raises
    ------
    FileNotFoundError
        Nothing is at ``path``.
    error
        ``path`` is a directory, FIFO, device or socket (named in the message).
    """
    st = os.stat(path)
    if not stat.S_ISREG(st.st_mode):
        raise error(
            f"{path}: is {describe_mode(st.st_mode)}, not a regular file; fvf reads only "
            "regular files (a FIFO or a device such as /dev/zero never ends). Fix: save the "
            "data to a file and pass its path."
        )
    return st


def read_bytes(path: str | os.PathLike, error: type[FvfError], head: int = 0) -> bytes:
    """The content of a regular file, read with a size check.

    Parameters
    ----------
    path : path
    error : FvfError subclass
        Raised for a path that is not a regular file, a file that changed size while it
        was read, or one too large to hold in memory.
    head : int
        When positive, read at most this many bytes (a sniff of the file's start).

    Returns
    -------
    bytes
    """
    st = regular_file(path, error)
    size = st.st_size if head <= 0 else min(head, st.st_size)
    try:
        with open(path, "rb") as fh:
            data = fh.read(size + (1 if head <= 0 else 0))
    except MemoryError:
        raise error(
            f"{path}: the file ({st.st_size / 2**30:.3g} GiB) does not fit in memory"
        ) from None
    if head <= 0 and len(data) != st.st_size:
        raise error(
            f"{path}: the file changed size while it was read ({st.st_size} bytes, then "
            f"{len(data)}{'+' if len(data) > st.st_size else ''}); read it again when "
            "nothing is writing it"
        )
    return data


def read_index_table(
    path: str | os.PathLike, columns: int, what: str, error: type[FvfError]
) -> np.ndarray:
    """A text file of integers, ``columns`` per line (``#`` comments), int64 (k, columns).

    Read as a regular file with a size check (:func:`read_bytes`); ``what`` names the
    table in messages ("feature edges", "landmarks"). An empty file gives (0, columns).
    """
    data = read_bytes(path, error)
    rows = []
    for number, line in enumerate(data.decode("utf-8", "replace").splitlines(), 1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        fields = text.split()
        if len(fields) != columns or not all(_INTEGER.fullmatch(f) for f in fields):
            raise error(
                f"{path}, line {number}: {what} must be {columns} integers per line; got "
                f"{text[:60]!r}"
            )
        rows.append([int(f) for f in fields])
    return np.array(rows, dtype=np.int64).reshape(-1, columns)
