"""What compiled backends print: kept off the user's terminal and pipes.

CHOLMOD inside the ``cholespy`` wheel reports a matrix that is not positive definite
with ``printf`` — a line such as ``CHOLMOD warning: not positive definite. file: …`` on
the process's standard output (file descriptor 1), below Python's ``sys.stdout`` — before
cholespy raises its exception. fvf turns that exception into
:class:`~fvf.errors.FactorizationError` (or falls back to another backend); the printed
line would still reach a terminal, a ``--json`` pipe or a redirected report.

:func:`backend_output_captured` points descriptor 1 at a temporary file while a backend
call runs and restores it afterwards. Lines the backend printed (those starting with a
name in ``prefixes``) are returned to the caller in the list the context manager yields;
anything else written to descriptor 1 meanwhile (another thread's output) is written back
to the real standard output in order, so nothing of the user's is lost.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import threading
from collections.abc import Iterator

__all__ = ["backend_output_captured"]

_LOCK = threading.Lock()


@contextlib.contextmanager
def backend_output_captured(prefixes: tuple[str, ...] = ("CHOLMOD",)) -> Iterator[list[str]]:
    """Capture what compiled code prints on descriptor 1 during the ``with`` block.

    Parameters
    ----------
    prefixes : tuple of str
        Lines starting with one of these are the backend's: collected, not printed.

    Yields
    ------
    list of str
        Filled when the block ends (also when it raises) with the backend's lines,
        without their line ends.

    Notes
    -----
    Falls back to capturing nothing where descriptor 1 cannot be duplicated (no real
    standard output, e.g. some notebook kernels on Windows).
    """
    lines: list[str] = []
    with _LOCK:
        try:
            sys.stdout.flush()
            saved = os.dup(1)
        except (OSError, ValueError, AttributeError):
            yield lines
            return
        with tempfile.TemporaryFile(mode="w+b") as sink:
            os.dup2(sink.fileno(), 1)
            try:
                yield lines
            finally:
                with contextlib.suppress(OSError, ValueError, AttributeError):
                    sys.stdout.flush()
                os.dup2(saved, 1)
                os.close(saved)
                sink.seek(0)
                _sort_lines(sink.read().decode("utf-8", "replace"), prefixes, lines)


def _sort_lines(text: str, prefixes: tuple[str, ...], backend: list[str]) -> None:
    """Append the backend's lines of ``text`` to ``backend``; write the others back."""
    other = []
    for line in text.splitlines(keepends=True):
        (backend.append(line.rstrip("\n")) if line.startswith(prefixes) else other.append(line))
    if other:
        with contextlib.suppress(OSError, ValueError):
            os.write(1, "".join(other).encode("utf-8"))
