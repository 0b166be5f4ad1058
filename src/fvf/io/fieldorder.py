"""How files store the N of an N-field (:class:`fvf.NField`), in every format fvf writes.

A field written under the name ``key`` keeps its N as

* ``.npz``: the integer key ``n_<key>`` (and, for the field ``v`` of the ``fvf``
  command, also ``n``, as ``fvf design`` has always written it);
* PLY: the header line ``comment fvf n_<key>: <N>``;
* VTK (``.vtu``, ``.vtp``, ``.vtk``): the field data array ``n_<key>`` (one integer).

Reading (:func:`fvf.io.read_data`) gives the array under ``key`` back as an
:class:`fvf.NField` of that N. A field of N = 1 written by fvf is marked too, so every
field fvf designed comes back as what it was.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from typing import Any

from ..mesh.nfield import NField

__all__ = ["order_key", "orders_of", "order_comments", "orders_from_comments"]

_COMMENT = re.compile(r"^fvf n_(?P<key>[A-Za-z0-9_.\-]+): (?P<n>\d+)$")


def order_key(key: str) -> str:
    """The key (npz) or field data name (VTK) holding the N of the field ``key``."""
    return f"n_{key}"


def orders_of(arrays: Mapping[str, Any]) -> dict[str, int]:
    """``{key: N}`` of the :class:`fvf.NField` values of ``arrays``."""
    return {k: a.n for k, a in arrays.items() if isinstance(a, NField)}


def order_comments(orders: Mapping[str, int]) -> tuple[str, ...]:
    """The PLY comment lines (without ``comment``) recording ``orders``."""
    return tuple(f"fvf {order_key(k)}: {n}" for k, n in orders.items())


def orders_from_comments(lines: Iterable[str]) -> dict[str, int]:
    """``{key: N}`` recorded in comment lines (:func:`order_comments`); others ignored."""
    out = {}
    for line in lines:
        match = _COMMENT.match(" ".join(line.split()))
        if match is not None and int(match["n"]) >= 1:
            out[match["key"]] = int(match["n"])
    return out
