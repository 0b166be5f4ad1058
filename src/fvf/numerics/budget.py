"""Bounds on work and memory asked of this machine, checked before allocating.

A request whose size comes from the user (a quad count, a number of eigenpairs on a large
mesh) is estimated from measured costs and compared with the memory the machine has
available; beyond it :class:`fvf.ProblemSizeError` is raised at once, naming the estimate
and what to change, instead of swapping or being killed minutes later.
"""

from __future__ import annotations

import os

from ..errors import ProblemSizeError

__all__ = ["available_memory", "check_memory"]


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation, or None when unknown.

    ``MemAvailable`` of ``/proc/meminfo`` (Linux), else the available physical pages
    (``os.sysconf``); the smaller of that and an address-space limit (``ulimit -v``).
    """
    found: list[int] = []
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError):
        pass
    if not found:
        try:
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (AttributeError, ValueError, OSError):
            pass
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft != resource.RLIM_INFINITY:
            found.append(int(soft))
    except (ImportError, OSError, ValueError):
        pass
    return min(found) if found else None


def check_memory(what: str, estimate: float, fix: str) -> None:
    """Raise :class:`fvf.ProblemSizeError` when ``estimate`` bytes exceed the available
    memory (:func:`available_memory`; nothing is checked when it is unknown).

    Parameters
    ----------
    what : str
        The request, e.g. ``"fvf.quad_mesh with target_faces=100000000"``.
    estimate : float
        Its estimated peak memory in bytes.
    fix : str
        What to change, appended after "Fix: ".
    """
    limit = available_memory()
    if limit is not None and estimate > limit:
        raise ProblemSizeError(
            f"{what} would need about {estimate / 2**30:.3g} GiB of memory; this machine "
            f"has {limit / 2**30:.3g} GiB available. Fix: {fix}"
        )
