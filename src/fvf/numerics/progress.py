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

__all__ = ["ProgressCallback", "make_progress", "fraction_reporter", "raised_by_callback"]

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


#: The attribute set on an exception raised by a user's progress callback.
_FROM_CALLBACK = "_fvf_raised_by_progress_callback"


class _UserProgress:
    """A user's callback, whose exceptions (a cancel) are marked so that no fallback of
    a solver mistakes them for its own failure (:func:`raised_by_callback`)."""

    def __init__(self, callback: ProgressCallback) -> None:
        self._callback = callback

    def __call__(self, stage: str, done: int, total: int) -> Any:
        try:
            return self._callback(stage, done, total)
        except BaseException as exc:
            try:
                setattr(exc, _FROM_CALLBACK, True)
            except (AttributeError, TypeError):  # an exception type with __slots__
                pass
            raise


def raised_by_callback(exc: BaseException) -> bool:
    """Whether ``exc`` came out of a user's progress callback: a solver that falls back
    to another method on failure must re-raise it instead (the user asked to stop)."""
    return bool(getattr(exc, _FROM_CALLBACK, False))


def _check_signature(callback: Callable[..., Any]) -> None:
    """:class:`fvf.ParameterError` for a callable that cannot be called as
    ``(stage, done, total)`` (checked before any work, not as a TypeError mid-solve);
    callables whose signature Python cannot read pass."""
    import inspect

    try:
        signature = inspect.signature(callback)
    except (TypeError, ValueError):
        return
    try:
        signature.bind("stage", 0, 1)
    except TypeError as exc:
        raise ParameterError(
            f"progress must be callable as progress(stage, done, total); {callback!r} "
            f"is not ({exc})"
        ) from None


def make_progress(
    progress: bool | ProgressCallback | None, *, delay: float = 0.0
) -> ProgressCallback:
    """A callable ``(stage, done, total)`` from the user's ``progress`` option.

    Parameters
    ----------
    progress : None, bool or callable
        ``None``/``False``: silent. ``True``: a tqdm bar per stage when tqdm imports, else
        silent. A callable: called as ``progress(stage, done, total)``; an exception it
        raises (a cancel) propagates out of the solver unchanged, never taken for a
        failure of a method that another one replaces.
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
    if isinstance(progress, (_UserProgress, _TqdmProgress)) or progress is _silent:
        return progress
    if callable(progress):
        _check_signature(progress)
        return _UserProgress(progress)
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
