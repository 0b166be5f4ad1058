"""Progress reporting for long solves: a user callback, a tqdm bar, or nothing.

A progress callback receives ``(stage, done, total)``: ``stage`` a short name
(``"assemble"``, ``"factor"``, ``"iterate"``, ``"solve"``), ``done`` the steps finished in
that stage and ``total`` the number expected (an upper bound for ``"iterate"``, which
may stop early). ``progress=True`` draws a tqdm bar when tqdm is installed (it is silently
skipped otherwise); ``None`` or ``False`` reports nothing.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from ..errors import ParameterError

__all__ = ["ProgressCallback", "make_progress", "fraction_reporter"]

ProgressCallback = Callable[[str, int, int], Any]


def _silent(stage: str, done: int, total: int) -> None:
    return None


class _TqdmProgress:
    """One tqdm bar per stage, closed when the stage changes or completes."""

    def __init__(self, tqdm: Callable[..., Any]) -> None:
        self._tqdm = tqdm
        self._bar: Any = None  # a tqdm.tqdm bar while a stage runs
        self._stage: str | None = None

    def __call__(self, stage: str, done: int, total: int) -> None:
        if stage != self._stage:
            self.close()
            self._bar = self._tqdm(total=total, desc=stage, leave=False)
            self._stage = stage
        self._bar.n = done
        self._bar.refresh()
        if done >= total:
            self.close()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
        self._bar, self._stage = None, None


def make_progress(
    progress: bool | ProgressCallback | None, *, delay: float = 0.0
) -> ProgressCallback:
    """A callable ``(stage, done, total)`` from the user's ``progress`` option.

    Parameters
    ----------
    progress : None, bool or callable
        ``None``/``False``: silent. ``True``: a tqdm bar per stage when tqdm imports, else
        silent. A callable: called as ``progress(stage, done, total)``.
    delay : float
        With ``True``: a stage's bar appears only once the stage has run this many
        seconds (tqdm's ``delay``; the command line uses 2 s).

    Raises
    ------
    ParameterError
        Anything else.
    """
    if progress is None or progress is False:
        return _silent
    if progress is True:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            return _silent
        return _TqdmProgress(functools.partial(tqdm, delay=delay) if delay > 0 else tqdm)
    if callable(progress):
        return progress
    raise ParameterError(
        f"progress must be None, True/False or a callable (stage, done, total); got {progress!r}"
    )


def fraction_reporter(
    progress: bool | ProgressCallback | None, stage: str, steps: int = 1000
) -> Callable[[float], Any] | None:
    """A callback taking the fraction done (0..1), as the exponential action reports it,
    that forwards to the user's ``progress`` as ``(stage, done, steps)``; None when the
    user asked for no progress (so that the caller does no extra work)."""
    if progress is None or progress is False:
        return None
    report = make_progress(progress)

    def fraction(x: float) -> None:
        report(stage, min(int(round(steps * float(x))), steps), steps)

    return fraction
