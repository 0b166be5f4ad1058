"""Short text of results holding big arrays: :func:`short_repr`.

A result dataclass (:class:`fvf.MatchResult`, :class:`fvf.SeamlessParameterization`, …)
sets ``__repr__ = short_repr``: its repr names each array by dtype and shape and shows
the numbers, so printing a result in a notebook or a log is a few lines, never the arrays;
``_repr_html_ = html_repr`` shows the same as a table in Jupyter.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

__all__ = ["short_repr", "short_value", "html_table", "html_repr"]

#: A value whose own repr is longer than this is shown by its type (and size).
_WIDTH = 60


def short_value(value: Any) -> str:
    """One short word for a value: ``float64(5856, 3)`` for an array, ``csr(300, 300)``
    for a sparse matrix, a mesh by its sizes, the value of a number or short string,
    ``dict(3 keys)``,
    ``list(12)``, else its repr when short, else its type name."""
    if isinstance(value, np.ndarray):
        order = getattr(value, "n", None) if hasattr(value, "representation") else None
        return f"{value.dtype}{value.shape}" + ("" if order is None else f" n={order}")
    if hasattr(value, "nnz") and hasattr(value, "shape"):  # scipy.sparse, not imported
        return f"{getattr(value, 'format', 'sparse')}{tuple(value.shape)} nnz={value.nnz}"
    if hasattr(value, "n_vertices") and hasattr(value, "n_faces"):  # a mesh
        return f"{type(value).__name__}(n_vertices={value.n_vertices}, n_faces={value.n_faces})"
    if isinstance(value, float | np.floating):
        return f"{float(value):.6g}"
    if isinstance(value, dict):
        return f"dict({len(value)} key{'' if len(value) == 1 else 's'})"
    if isinstance(value, list | tuple) and any(isinstance(v, np.ndarray) for v in value):
        return f"{type(value).__name__}({len(value)} arrays)"
    text = repr(value)
    if len(text) <= _WIDTH and " object at 0x" not in text:
        return text
    if isinstance(value, list | tuple | set | frozenset):
        return f"{type(value).__name__}({len(value)})"
    return f"{type(value).__name__}(...)"


def short_repr(obj: Any) -> str:
    """``ClassName(field=short value, ...)`` of a dataclass instance, each field by
    :func:`short_value` (arrays by dtype and shape); fields declared ``repr=False`` are
    left out.

    Examples
    --------
    >>> import dataclasses, numpy as np
    >>> @dataclasses.dataclass
    ... class R:
    ...     x: np.ndarray
    ...     error: float
    ...     __repr__ = short_repr
    >>> R(np.zeros((5, 3)), 0.125)
    R(x=float64(5, 3), error=0.125)
    """
    parts = [
        f"{f.name}={short_value(getattr(obj, f.name))}"
        for f in dataclasses.fields(obj)
        if f.repr and hasattr(obj, f.name)
    ]
    return f"{type(obj).__name__}({', '.join(parts)})"


def html_repr(obj: Any) -> str:
    """The fields of a result dataclass as a small HTML table (``_repr_html_``, how
    Jupyter shows it), each value by :func:`short_value` like :func:`short_repr`."""
    rows = [
        (f.name, short_value(getattr(obj, f.name)))
        for f in dataclasses.fields(obj)
        if f.repr and hasattr(obj, f.name)
    ]
    return html_table(type(obj).__name__, rows)


def html_table(title: str, rows: list[tuple[str, Any]]) -> str:
    """A small HTML table, ``title`` above ``label | value`` rows (for ``_repr_html_``,
    the display of an object in a Jupyter notebook); text is escaped."""
    from html import escape

    body = "".join(
        f"<tr><th style='text-align:left'>{escape(str(label))}</th>"
        f"<td style='text-align:right'>{escape(str(value))}</td></tr>"
        for label, value in rows
    )
    return f"<table><caption><b>{escape(title)}</b></caption>{body}</table>"
