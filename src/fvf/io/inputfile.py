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
import stat

import numpy as np

__all__ = ["regular_file", "read_bytes", "read_index_table", "describe_mode", "MAX_TABLE_BYTES"]


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


def regular_file(path: str | os.PathLike, error: type[ValueError]) -> os.stat_result:
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


def read_bytes(path: str | os.PathLike, error: type[ValueError], head: int = 0) -> bytes:
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


#: Largest small text input (landmarks, ground truth, vertex map) read into memory.
MAX_TABLE_BYTES = 1 << 30


def read_index_table(
    path: str | os.PathLike, columns: int, what: str, error: type[ValueError]
) -> np.ndarray:
    """A text table of integers (vertex indices): ``columns`` per line, ``#`` comments.

    Parameters
    ----------
    path : path
        A regular file (a FIFO, a device or a directory is refused before it is opened) of
        at most :data:`MAX_TABLE_BYTES` bytes.
    columns : int
        Integers per line; 1 gives a flat table.
    what : str
        What the file holds, for messages (``"landmarks"``, ``"the ground truth"``).
    error : ValueError subclass (an FvfError)
        Raised for a file that is not a regular file, too large, not UTF-8 text, or not
        ``columns`` integers per line; the message names ``path``.

    Returns
    -------
    numpy.ndarray
        int64, shape (q,) when ``columns`` is 1, else (q, columns).
    """
    st = regular_file(path, error)
    if st.st_size > MAX_TABLE_BYTES:
        raise error(
            f"{path}: {what} file is {st.st_size / 2**30:.3g} GiB, more than a table of "
            f"vertex indices can be ({MAX_TABLE_BYTES / 2**30:.3g} GiB); is it the right file?"
        )
    try:
        text = read_bytes(path, error).decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: {what} must be text (integers), not binary data ({exc})") from None
    numbered = [
        (i + 1, line.split("#", 1)[0].replace(",", " ").split())
        for i, line in enumerate(text.splitlines())
    ]
    numbered = [(i, r) for i, r in numbered if r]
    rows = [r for _, r in numbered]
    bad = next((r for r in rows if len(r) != columns), None)
    if bad is not None:
        raise error(
            f"{path}: {what} must be {columns} integer(s) per line; a data line has "
            f"{len(bad)}: {' '.join(bad)[:80]!r}"
        )
    try:
        table = np.array(rows, dtype=np.int64).reshape(-1, columns)
    except (ValueError, OverflowError):
        line, row = next((i, r) for i, r in numbered if not all(_is_int(x) for x in r))
        raise error(
            f"{path}: {what} must be {columns} integer(s) per line; line {line} is "
            f"{' '.join(row)[:80]!r}"
        ) from None
    return table[:, 0] if columns == 1 else table


def _is_int(token: str) -> bool:
    """Whether ``token`` is an integer that fits int64."""
    try:
        return -(2**63) <= int(token) < 2**63
    except ValueError:
        return False
