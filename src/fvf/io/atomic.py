"""Safe output files: written whole or not at all, never onto an input.

Every file fvf writes goes through :func:`atomic_path`: the content is written to a
temporary file in the target's directory, flushed and fsynced, then renamed over the
target (``os.replace``, atomic on POSIX and Windows within one file system). An
interrupt, a full disk or an exception while writing leaves the previous file untouched
and removes the temporary one; two concurrent writers each produce a complete file and
the last rename wins. The rename replaces the directory entry, so a symbolic link or a
hard link at the target is replaced, never written through.

:func:`check_not_input` refuses an output path that is one of a command's inputs (the
same path, a hard link to it, or a symbolic link to it), so no command replaces its own
input by accident. ``docs/files.md`` states these guarantees.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import secrets
import stat
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import BinaryIO

from ..errors import InputOverwriteError, OutputWriteError

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_not_input",
    "deferred_fsync",
    "fsync_directory",
    "same_file",
    "writable_folder",
]

#: errno values that mean "the output could not be written" (not "bad content").
_WRITE_ERRNOS = {
    errno.ENOSPC,
    errno.EFBIG,
    errno.EROFS,
    errno.EIO,
    getattr(errno, "EDQUOT", errno.ENOSPC),
}


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


#: Files renamed into place whose fsync waits for the end of a :func:`deferred_fsync`
#: block (None outside one). A context variable: each thread has its own.
_PENDING: contextvars.ContextVar[list[Path] | None] = contextvars.ContextVar(
    "fvf_pending_fsync", default=None
)


def _fsync_file(path: Path) -> None:
    fh: BinaryIO
    try:
        fh = open(path, "rb+")  # Windows flushes only handles open for writing
    except PermissionError:  # a read-only file (its mode copied from the one it replaces)
        fh = open(path, "rb")
    with fh:
        os.fsync(fh.fileno())


@contextlib.contextmanager
def deferred_fsync() -> Iterator[list[Path]]:
    """Flush the files :func:`atomic_path` writes in this block to disk at its end, together.

    Inside the block every file is still written to a temporary file and renamed over its
    target, so it is whole or absent whatever happens to the process; only the fsync of
    the file and of its folder waits until the block ends, when all of them are flushed at
    once. Several small files flushed together cost a fraction of flushing each on its
    own (16 result files of a batch: about 0.6 ms each instead of 1.3-2.7 ms, on ext4).
    What a power cut (not a killed process) can then cost is the files written since the
    block began: they may be missing, empty or damaged on disk, so use it where such a
    file is detected and recomputed (a batch's results carry their key and are reloaded).

    Yields
    ------
    list of pathlib.Path
        The files written so far in the block (final paths, in order).

    Raises
    ------
    OutputWriteError
        A file or folder could not be flushed (an I/O error of the disk); its name is given.
    """
    pending: list[Path] = []
    token = _PENDING.set(pending)
    try:
        yield pending
    finally:
        _PENDING.reset(token)
    for path in dict.fromkeys(pending):
        try:
            _fsync_file(path)
        except FileNotFoundError:  # replaced or removed since: nothing of ours to flush
            continue
        except OSError as exc:
            raise _write_failed(path, exc) from exc
    for directory in dict.fromkeys(p.parent for p in pending):
        fsync_directory(directory)


def _write_failed(target: Path, exc: OSError) -> OutputWriteError:
    reason = exc.strerror or type(exc).__name__
    return OutputWriteError(
        f"{target}: cannot write the output ({reason}); nothing was written and a file "
        "already there is unchanged. Fix: free disk space, raise the file size limit "
        "(ulimit -f), or write somewhere else."
    )


def _interrupt_behind(exc: BaseException) -> BaseException | None:
    """The interrupt (KeyboardInterrupt, SystemExit, any non-Exception) that ``exc`` was
    raised while handling, if ``exc`` is not one itself: a writer's cleanup can replace
    an interrupt by its own error (zipfile raises ValueError "Can't close the ZIP file
    while there is an open writing handle"), which would misreport Ctrl-C."""
    seen, cause = set(), exc.__context__
    if not isinstance(exc, Exception):
        return None
    while cause is not None and id(cause) not in seen:
        if not isinstance(cause, Exception):
            return cause
        seen.add(id(cause))
        cause = cause.__context__
    return None


def _mode(target: Path) -> int:
    """The mode of the file being replaced, else 0o666 (the kernel applies the umask)."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except OSError:
        return 0o666


def _create(tmp: Path, mode: int, target: Path) -> bool:
    """Create the empty file ``tmp`` (exclusively); False if the name is taken."""
    try:
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, mode))
    except FileExistsError:
        return False
    except FileNotFoundError as exc:
        raise OutputWriteError(
            f"{target}: the folder {tmp.parent} does not exist; create it first"
        ) from exc
    except OSError as exc:
        raise OutputWriteError(
            f"{target}: cannot create a file in {tmp.parent} ({exc.strerror}); write elsewhere"
        ) from exc
    return True


#: Bytes of a file name on common file systems (ext4, APFS, NTFS in UTF-16 units).
NAME_MAX = 255


def _short_name(target: Path, suffix: str) -> str:
    """``target``'s name for its temporary, shortened (stem cut to 120 characters, the
    suffix kept) when ``.NAME.<16 hex>SUFFIX`` would be longer than :data:`NAME_MAX`: a
    250-character output name is valid, its temporary must be too."""
    name = target.name
    if len(f".{name}.{'0' * 16}{suffix}".encode()) <= NAME_MAX:
        return name
    return target.stem[:120] + target.suffix[:40]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """A temporary path beside ``path``; on success it is fsynced and renamed to ``path``.

    Inside a :func:`deferred_fsync` block the fsync of the file and its folder waits for
    the end of the block; the rename (what makes the file whole or absent) does not.

    Parameters
    ----------
    path : str or PathLike
        The final file. Its directory must exist. A symbolic link at ``path`` is replaced
        by the new file (the link's target is never written through); so is a hard link.
    suffix : str, optional
        Suffix of the temporary file (default: ``path``'s own, so that writers that
        choose a format by suffix, such as ``numpy.savez`` or PIL, see the right one).

    Yields
    ------
    pathlib.Path
        Where to write: ``.<name>.<16 hex digits><suffix>`` beside ``path`` (a name too
        long for that is cut to 120 characters and its suffix). The file
        exists (empty) when the block starts; it has the mode of the file it will
        replace, or the default mode of new files (umask).

    Raises
    ------
    OutputWriteError
        The temporary file could not be created, written (disk full, file size limit,
        read-only file system) or renamed; it is removed and ``path`` is unchanged.

    Notes
    -----
    The temporary name is chosen before the file is created, so an interrupt at any
    point (even between the creation and the return of ``os.open``) removes it. Only a
    process killed outright (SIGKILL, power loss) can leave one behind; the target is
    then still the old file or the complete new one.

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
    suffix = target.suffix if suffix is None else suffix
    mode = _mode(target)
    tmp: Path | None = None  # named before it is created: the cleanup below always knows it
    name = _short_name(target, suffix)
    try:
        for _ in range(100):
            tmp = directory / f".{name}.{secrets.token_hex(8)}{suffix}"
            if _create(tmp, mode, target):
                break
            tmp = None  # another writer's file: never removed here
        else:
            raise OutputWriteError(f"{target}: no free temporary name in {directory}")
        try:
            yield tmp
        except BaseException as exc:
            interrupt = _interrupt_behind(exc)
            if interrupt is not None:  # e.g. zipfile turns Ctrl-C into a ValueError
                raise interrupt from None
            if isinstance(exc, OSError) and exc.errno in _WRITE_ERRNOS:
                raise _write_failed(target, exc) from exc
            raise
        pending = _PENDING.get()
        try:
            if pending is None:
                _fsync_file(tmp)
            os.replace(tmp, target)
        except OSError as exc:
            raise _write_failed(target, exc) from exc
        tmp = None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                tmp.unlink()
    if pending is None:
        fsync_directory(directory)
    else:
        pending.append(directory / target.name)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` through :func:`atomic_path`; returns ``Path(path)``."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def atomic_write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` through :func:`atomic_path`; returns ``Path(path)``."""
    return atomic_write_bytes(path, text.encode(encoding))


def same_file(output: str | os.PathLike, other: str | os.PathLike) -> str | None:
    """How ``output`` is ``other``: None if it is not, else a phrase for messages.

    ``output`` is ``other`` when both name the same file (:func:`os.path.samefile`: the
    same path, a hard link, a path through linked folders), or when ``output`` is a
    symbolic link whose target resolves to ``other`` (even a dangling one).
    """
    out, inp = Path(output), Path(other)
    try:
        if out.is_symlink() and os.path.realpath(out) == os.path.realpath(inp):
            return f"a symbolic link to the input {inp}"
    except OSError:
        pass
    try:
        if os.path.samefile(out, inp):
            link = ""
            if os.path.realpath(out) != os.path.realpath(inp):
                link = " (a hard link)"
            return f"the input {inp}{link}"
    except OSError:  # one of them does not exist: then they are not the same file
        pass
    if os.path.realpath(out) == os.path.realpath(inp):
        return f"the input {inp}"
    return None


def check_not_input(
    output: str | os.PathLike,
    inputs: Iterable[str | os.PathLike | None],
    *,
    force: bool = False,
    option: str = "the output",
) -> None:
    """Refuse to write ``output`` when it is one of ``inputs`` (see :func:`same_file`).

    Parameters
    ----------
    output : path
        Where a command will write.
    inputs : iterable of path (None entries are skipped)
        The files it reads.
    force : bool
        Allow it. Even then the input is replaced by a rename, never written through: a
        symbolic or hard link at ``output`` is replaced and the file it pointed to keeps
        its content.
    option : str
        How the output was given, for the message (e.g. ``"-o"``).

    Raises
    ------
    InputOverwriteError
        ``output`` is an input and ``force`` is false.
    """
    if force:
        return
    for inp in inputs:
        if inp is None:
            continue
        how = same_file(output, inp)
        if how is not None:
            raise InputOverwriteError(
                f"{option} {output} is {how}: writing it would replace an input. Fix: "
                "write to another path, or pass --force (overwrite_inputs=True) to "
                "replace it (a link is then replaced, never written through)."
            )


def writable_folder(path: str | os.PathLike, what: str = "the outputs") -> Path:
    """``path`` as a folder that can be written into: created (with its parents) when
    missing, checked before any work.

    Raises
    ------
    OutputWriteError
        The folder cannot be created or written into (a read-only file system or folder,
        a file in the way); nothing was written. The command line exits with status 5.
    """
    folder = Path(path)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputWriteError(
            f"{folder}: cannot create the folder for {what} ({exc.strerror or exc}); "
            "nothing was written. Fix: give a folder you can write to"
        ) from exc
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputWriteError(
            f"{folder}: the folder for {what} is not writable; nothing was written. Fix: "
            "give a folder you can write to"
        )
    return folder
