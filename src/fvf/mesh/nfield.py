"""N-direction fields that know their N: :class:`NField`, and how consumers read it.

An N-direction field (``docs/nfields.md``) is stored as one representative tangent vector
per face, float64 ``(m, 3)`` in ambient coordinates; its other directions are the
rotations by :math:`2\\pi j/N` about the face normal. A bare array does not say N, so
every function taking a field also takes ``n=``. The design functions return an
:class:`NField` instead: the same ``(m, 3)`` float64 array (a :class:`numpy.ndarray`
subclass, usable wherever an array is) that also carries ``n``, so the consumers
(:func:`fvf.singularities`, :func:`fvf.comb`, :func:`fvf.quad_mesh`, the pictures, the
file writers) read it from the field.

Only the whole field is an N-field: arithmetic, ufuncs, reductions, indexing and slicing
(``u[mask]``, ``u[:, 0]``, ``2 * u``, ``u.sum(0)``, ``np.concatenate``) give plain
ndarrays, so ``n`` is never carried silently into a value that is not the field. The
exceptions are the views and copies of the whole array (``u.copy()``, ``u.view()``,
``u.astype(...)``, pickling), in-place operations (``u *= 2`` changes the field itself,
which stays what it was), and a stack of fields ``(k, m, 3)`` (the smoothest fields),
whose ``stack[i]`` is the i-th field, an :class:`NField` too.

A consumer given both an :class:`NField` and an explicit ``n`` that differs from
``field.n`` raises :class:`~fvf.errors.DirectionCountConflictError`; to read the same
vectors as a field of another order, pass ``np.asarray(field)`` (or ``NField(field,
n=k)``).
"""

from __future__ import annotations

import enum
from typing import Any, Final, Literal

import numpy as np
import numpy.typing as npt

from ..errors import DirectionCountConflictError, DirectionCountError, FieldShapeError
from .inputs import as_direction_count

__all__ = [
    "NField",
    "FROM_FIELD",
    "FromField",
    "direction_count",
    "field_order",
    "fields_order",
    "require_order",
    "with_order",
]


class _FromField(enum.Enum):
    FROM_FIELD = "the field's n"

    def __repr__(self) -> str:
        return "FROM_FIELD"


#: The default ``n=`` of the functions that take an N-field: the ``n`` of an
#: :class:`NField`; for a bare array the function's documented default (or an error when
#: it has none). ``n=None`` is not this: it is an invalid N, as always.
FROM_FIELD: Final = _FromField.FROM_FIELD
#: The type of :data:`FROM_FIELD`, for signatures: ``n: int | FromField = FROM_FIELD``.
FromField = Literal[_FromField.FROM_FIELD]

#: What the rows of an :class:`NField` hold (``NField.representation``).
REPRESENTATION = "representative"


def _plain(a: Any) -> Any:
    """``a`` with every :class:`NField` inside (tuples, lists, dicts one level) as a plain
    ndarray view."""
    if isinstance(a, NField):
        return a.view(np.ndarray)
    if isinstance(a, tuple | list):
        return type(a)(_plain(x) for x in a)
    if isinstance(a, dict):
        return {k: _plain(v) for k, v in a.items()}
    return a


class NField(np.ndarray):
    """A tangent N-direction field: float64 ``(m, 3)``, one representative per face, with N.

    Behaves as the ``(m, 3)`` array of ambient per-face vectors (it is an ndarray
    subclass); ``field.n`` is its symmetry order N. Arithmetic, ufuncs, reductions and
    indexing return plain ndarrays (see the module docstring).

    Parameters
    ----------
    field : array_like, float (m, 3) or (k, m, 3)
        One representative vector per face (ambient xyz, tangent to the face), or a stack
        of k such fields. Copied only when not already float64.
    n : int
        The symmetry order N >= 1: 1 vector field, 2 line field, 4 cross field, ...

    Attributes
    ----------
    n : int
        N.
    representation : str
        ``"representative"``: each row is one of the face's N directions (any of them, of
        the field's magnitude), ambient coordinates, per face (``docs/nfields.md``).

    Raises
    ------
    DirectionCountError
        ``n`` not an integer >= 1.
    FieldShapeError
        ``field`` not real of shape (m, 3) or (k, m, 3).

    Examples
    --------
    >>> import numpy as np
    >>> import fvf
    >>> u = fvf.NField(np.tile([1.0, 0.0, 0.0], (5, 1)), n=4)
    >>> u.n, u.shape
    (4, (5, 3))
    >>> type(2 * u).__name__, type(u[:2]).__name__
    ('ndarray', 'ndarray')
    """

    _n: int
    representation = REPRESENTATION
    __array_priority__ = -1.0  # a plain ndarray operand decides the result's type

    def __new__(cls, field: npt.ArrayLike, n: int) -> NField:
        order = as_direction_count(n)
        a = np.asarray(field)
        if a.dtype.kind not in "biuf" or a.ndim not in (2, 3) or a.shape[-1] != 3:
            raise FieldShapeError(
                f"an N-field is real numbers of shape (m, 3) (one vector per face) or "
                f"(k, m, 3); got dtype {a.dtype} and shape {a.shape}"
            )
        obj = np.asarray(a, dtype=np.float64).view(cls)
        obj._n = order
        return obj

    def __init__(self, field: npt.ArrayLike, n: int) -> None:
        """Checked and set by ``__new__`` (an ndarray is made there)."""

    def __array_finalize__(self, obj: Any) -> None:
        self._n = getattr(obj, "_n", 1)

    @property
    def n(self) -> int:
        """The symmetry order N of the field."""
        return self._n

    # ---------------------------------------------------------------- plain results
    def __array_ufunc__(self, ufunc: Any, method: str, *inputs: Any, **kwargs: Any) -> Any:
        out = kwargs.get("out")
        if out is not None:
            kwargs["out"] = _plain(out)
        result = getattr(ufunc, method)(*_plain(inputs), **kwargs)
        if out is not None and method == "__call__":  # in place (u *= 2): the arrays given
            return out[0] if len(out) == 1 else out
        return _plain(result)

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        return _plain(func(*_plain(args), **_plain(kwargs)))

    def __getitem__(self, key: Any) -> Any:
        plain = self.view(np.ndarray)
        item = plain[key]
        if self.ndim == 3 and isinstance(key, int | np.integer):
            return NField(item, self._n)  # one field of a stack
        return item

    def __reduce__(self) -> tuple:
        return (_rebuild, (self.view(np.ndarray).copy(), self._n))

    def __copy__(self) -> NField:
        return NField(self.view(np.ndarray).copy(), self._n)

    def __deepcopy__(self, memo: dict[int, Any] | None = None, /) -> NField:
        return self.__copy__()

    # ---------------------------------------------------------------- display
    def __repr__(self) -> str:
        body = np.array_repr(self.view(np.ndarray))
        return f"NField({body[len('array(') : -1]}, n={self._n})"

    def _repr_html_(self) -> str:
        """A table for Jupyter: N, faces, representation, magnitudes."""
        from ..numerics.summary import html_table

        plain = self.view(np.ndarray)
        norms = np.linalg.norm(plain, axis=-1) if plain.size else np.zeros(1)
        rows: list[tuple[str, Any]] = [("n", self._n)]
        if plain.ndim == 3:
            rows.append(("fields", plain.shape[0]))
        rows += [
            ("faces", plain.shape[-2]),
            ("representation", "one representative per face, ambient (m, 3)"),
            ("|u| min / max", f"{norms.min():.3g} / {norms.max():.3g}"),
        ]
        return html_table(f"NField (N = {self._n})", rows)


def _rebuild(array: np.ndarray, n: int) -> NField:
    return NField(array, n)


def direction_count(field: Any) -> int | None:
    """The N an :class:`NField` carries, None for anything else."""
    return field.n if isinstance(field, NField) else None


def field_order(field: Any, n: Any, default: int | None = 1, name: str = "field") -> int:
    """The symmetry order a consumer uses: ``n`` when given, else the field's own.

    Parameters
    ----------
    field : NField or array_like
        The field passed by the user.
    n : int or FROM_FIELD
        The ``n=`` the user passed (:data:`FROM_FIELD`: not given).
    default : int or None
        Used for a bare array without ``n``; None makes ``n`` required for bare arrays.
    name : str
        The argument's name, for messages.

    Returns
    -------
    int
        N >= 1.

    Raises
    ------
    DirectionCountConflictError
        ``field`` is an :class:`NField` and ``n`` differs from ``field.n``.
    DirectionCountError
        ``n`` is not an integer >= 1, or neither ``n`` nor an NField was given and there
        is no default.
    """
    own = direction_count(field)
    if n is FROM_FIELD:
        if own is not None:
            return own
        if default is None:
            raise DirectionCountError(
                f"{name} is a bare array: give n=, the number of directions of the field "
                "(an integer >= 1, e.g. 4 for a cross field), or pass the NField that "
                "fvf.design_field returns"
            )
        return default
    order = as_direction_count(n)
    if own is not None and own != order:
        raise DirectionCountConflictError(
            f"{name} is an N-field with n={own} but n={order} was given. Fix: drop n= "
            f"(the field says its n), or pass np.asarray({name}) to read its vectors as a "
            f"field with n={order}"
        )
    return order


def with_order(field: Any, n: int) -> NField:
    """``field`` as an :class:`NField` of order ``n`` (no copy when it is float64)."""
    if isinstance(field, NField) and field.n == n:
        return field
    return NField(field if not isinstance(field, NField) else field.view(np.ndarray), n)


def fields_order(fields: Any, n: Any, default: int = 1, name: str = "field") -> int:
    """:func:`field_order` of one field or of a list of fields (their N must agree)."""
    if not isinstance(fields, list | tuple):
        return field_order(fields, n, default, name)
    own = {f.n for f in fields if isinstance(f, NField)}
    if len(own) > 1:
        raise DirectionCountConflictError(
            f"the fields of {name} have different n ({sorted(own)}); draw them separately "
            "or pass bare arrays with one n="
        )
    first = next((f for f in fields if isinstance(f, NField)), None)
    return field_order(first, n, default, name)


def require_order(field: Any, n: int, what: str, name: str = "field") -> None:
    """Raise :class:`~fvf.errors.DirectionCountConflictError` when ``field`` is an
    :class:`NField` whose N is not ``n`` (``what`` needs an N-field of that order)."""
    own = direction_count(field)
    if own is not None and own != n:
        raise DirectionCountConflictError(
            f"{what} needs a field with n={n} but {name} is an N-field with n={own}. Fix: "
            f"pass a field designed with n={n} (fvf.design_field(mesh, n={n}, ...)), or "
            f"np.asarray({name}) to use its vectors as representatives"
        )
