"""Loaded by each worker process of the local cluster of :func:`fvf.batch.run` (Dask's
``distributed.worker.preload``): the worker ignores SIGINT.

A terminal's Ctrl-C goes to every process of its foreground group, the workers included.
The driver handles it (:mod:`fvf.batch.interrupts`: it cancels the tasks, closes the
cluster and writes ``summary.csv``); a worker that took it too ended its event loop with
``KeyboardInterrupt`` and printed the traceback of it before the driver's one line.
"""

from __future__ import annotations

import signal
from typing import Any

__all__ = ["dask_setup"]


def dask_setup(worker: Any) -> None:
    """Ignore SIGINT in this worker process (run by Dask as the worker starts)."""
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread (a worker run in a thread): nothing to do
        pass
