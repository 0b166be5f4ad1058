"""Ctrl-C during a batch: the first press stops it, later ones cannot cut its cleanup short.

On the first SIGINT the running batch raises :class:`KeyboardInterrupt` as usual and, in the
same handler, SIGINT is ignored: the tasks in flight are cancelled, the Dask cluster is
closed and the partial ``summary.csv`` is written without a second press aborting any of
them (an aborted ``LocalCluster.close`` leaves its work to the interpreter's exit hooks,
an aborted summary loses the finished rows). When the batch returns, the handler it found
is restored; a command that ends the process after it keeps SIGINT ignored instead
(:func:`held`, ``for_good=True``), so that no press between the batch's return and the
command's own quiet-exit handler meets the default handler.

Only the main thread can change signal handlers; elsewhere (and when a handler other
than Python's default one is installed, e.g. by an application embedding the batch)
nothing is changed.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = ["held", "pressed"]

#: The presses seen by the outermost :func:`held` in force (None when none is).
_active: list[list[bool]] = []


def pressed() -> bool:
    """Whether a SIGINT arrived within the :func:`held` in force."""
    return bool(_active and _active[-1])


@contextlib.contextmanager
def held(for_good: bool = False) -> Iterator[None]:
    """Within: the first SIGINT raises :class:`KeyboardInterrupt` and ignores the later
    ones; on leaving, the previous handler comes back unless ``for_good`` and a SIGINT
    arrived. Nested within another :func:`held`, the outer one rules."""
    if (
        _active
        or threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        yield
        return
    seen: list[bool] = []

    def first_press(signum: int, frame: object) -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        seen.append(True)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, first_press)
    _active.append(seen)
    try:
        yield
    finally:
        _active.pop()
        if not (for_good and seen):
            signal.signal(signal.SIGINT, previous)
