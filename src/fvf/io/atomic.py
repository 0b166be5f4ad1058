"""Atomic output files: written whole or not at all.

Every file fvf writes goes through :func:`atomic_path`: the content is written to a
temporary file in the target's directory, flushed and fsynced, then renamed over the
target (``os.replace``, atomic on POSIX and Windows within one file system). An
interrupt, a full disk or an exception while writing leaves the previous file untouched
and removes the temporary one; two concurrent writers each produce a complete file and
the last rename wins.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "fsync_directory"]


def fsync_directory(directory: str | os.PathLike) -> None:
    """Flush a directory entry (a rename) to disk; a no-op where directories cannot be
    opened (Windows)."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """A temporary path beside ``path``; on success it is fsynced and renamed to ``path``.

    Parameters
    ----------
    path : str or PathLike
        The final file. Its directory must exist. A symlink at ``path`` is replaced by
        the new file (the link's target is never written through).
    suffix : str, optional
        Suffix of the temporary file (default: ``path``'s own, so that writers that
        choose a format by suffix, such as ``numpy.savez`` or PIL, see the right one).

    Yields
    ------
    pathlib.Path
        Where to write. The file exists (empty) when the block starts.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "a.npz"
    >>> with atomic_path(out) as tmp:
    ...     np.savez(tmp, x=np.arange(3))
    >>> sorted(np.load(out).files)
    ['x']
    """
    target = Path(path)
    directory = target.parent if str(target.parent) else Path(".")
    fd, name = tempfile.mkstemp(
        prefix=f".{target.name}.",
        suffix=target.suffix if suffix is None else suffix,
        dir=directory,
    )
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    fsync_directory(directory)
