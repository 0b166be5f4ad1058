r"""Other projects' tools wrapped for comparisons: Instant Meshes, a reference quad remesher.

The top layer, beside :mod:`fvf.cli` and :mod:`fvf.viz`: the demo and the benchmarks
import it, the library never does (``tests/test_layers.py``). Each wrapper imports its
project lazily and raises :class:`fvf.MissingExtraError` with the ``pip install`` line
when it is absent; none is an fvf dependency.

Instant Meshes (Jakob, Tarini, Panozzo & Sorkine-Hornung 2015, *Instant field-aligned
meshes*) is field-aligned remeshing without a parameterization; it is on PyPI as
``pynanoinstantmeshes`` (not an fvf dependency: ``pip install pynanoinstantmeshes``).
:func:`instant_meshes` runs it on an fvf mesh at about a given number of pure quads, so
that ``fvf demo`` and ``benchmarks/bench_quads.py`` compare both at equal quad counts with
:func:`fvf.quad_quality`.
"""

from __future__ import annotations

import os

import numpy as np

from .errors import MissingExtraError, ParameterError
from .mesh.convert import takes_mesh
from .mesh.trimesh import TriMesh

__all__ = ["instant_meshes", "has_instant_meshes"]


def has_instant_meshes() -> bool:
    """Whether ``pynanoinstantmeshes`` can be imported."""
    try:
        import pynanoinstantmeshes  # noqa: F401
    except ImportError:
        return False
    return True


@takes_mesh
def instant_meshes(mesh: TriMesh, quads: int) -> tuple[np.ndarray, np.ndarray]:
    """A pure-quad mesh of about ``quads`` quads by Instant Meshes.

    Parameters
    ----------
    mesh : TriMesh
    quads : int
        Quads wanted (≥ 32). Instant Meshes subdivides its quad-dominant result 1-to-4 into
        pure quads, so it is asked for ``quads // 4``; the result has about ``quads``.

    Returns
    -------
    vertices : float64 (k, 3)
    quads : int64 (q, 4)

    Raises
    ------
    MissingExtraError
        ``pynanoinstantmeshes`` is not installed.
    ParameterError
        ``quads`` below 32 or not an integer.
    """
    if isinstance(quads, bool) or not isinstance(quads, int | np.integer) or quads < 32:
        raise ParameterError(f"quads must be an integer >= 32; got {quads!r}")
    try:
        import pynanoinstantmeshes as pim
    except ImportError as exc:
        raise MissingExtraError(
            "Instant Meshes is not installed: pip install pynanoinstantmeshes"
        ) from exc
    target = int(quads) // 4
    devnull = os.open(os.devnull, os.O_WRONLY)  # it prints its progress on stdout
    saved = os.dup(1)
    os.dup2(devnull, 1)
    try:
        V, Q = pim.remesh(
            mesh.vertices.astype(np.float32),
            mesh.faces.astype(np.uint32),
            target,
            face_count=target,
            deterministic=True,
        )
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)
    return np.asarray(V, dtype=np.float64), np.asarray(Q, dtype=np.int64)
