"""A picture of a scalar as colours, in numpy alone: the colours fvf writes into mesh files
for viewers that show colours but not named properties (MeshLab's PLY vertex and face
``red green blue``, :mod:`fvf.io.formats.ply`).

The colormap is sequential and perceptual, built here rather than taken from matplotlib
(the core depends on numpy and scipy only): entry ``t`` in [0, 1] is the OKLab colour of
lightness $L(t) = 0.28 + 0.66\\,t$ (so equal steps of the scalar are equal steps of
perceived lightness, and it reads in grey print), hue $h(t) = 295° - 185°\\,t$ (violet,
blue, teal, green, yellow: viridis-like), chroma $C(t) = 0.10 + 0.07\\,t$, reduced where
needed to stay inside the sRGB gamut, then converted to 8-bit sRGB.

A scalar is mapped linearly from its finite minimum (the first entry) to its finite
maximum (the last); a constant scalar gets the middle entry and a non-finite value
(NaN, inf) mid grey :data:`NOT_FINITE`.
"""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt

__all__ = ["colormap_table", "scalar_colours", "scalar_positions", "NOT_FINITE", "SIZE"]

#: Entries of the table.
SIZE = 256
#: The colour of a non-finite value: mid grey, not in the table.
NOT_FINITE = np.array([128, 128, 128], dtype=np.uint8)

# OKLab -> linear sRGB (Ottosson 2020): LMS' = M1 (L, a, b), LMS = LMS'^3, RGB = M2 LMS.
_M1 = np.array(
    [[1.0, 0.3963377774, 0.2158037573], [1.0, -0.1055613458, -0.0638541728],
     [1.0, -0.0894841775, -1.2914855480]]
)  # fmt: skip
_M2 = np.array(
    [[4.0767416621, -3.3077115913, 0.2309699292], [-1.2684380046, 2.6097574011, -0.3413193965],
     [-0.0041960863, -0.7034186147, 1.7076147010]]
)  # fmt: skip


def _linear_srgb(L: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Linear sRGB (k, 3) of OKLab colours (k,)."""
    lms = np.column_stack([L, a, b]) @ _M1.T
    return (lms**3) @ _M2.T


def _encode(rgb: np.ndarray) -> np.ndarray:
    """sRGB transfer function of linear values in [0, 1]."""
    rgb = np.clip(rgb, 0.0, 1.0)
    return np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055)


@functools.cache
def colormap_table(size: int = SIZE) -> np.ndarray:
    """The colormap (see the module docstring) as ``size`` sRGB colours.

    Returns
    -------
    numpy.ndarray of uint8, shape (size, 3)
        Row i is the colour of ``t = i / (size - 1)``; read-only.
    """
    t = np.linspace(0.0, 1.0, size)
    L = 0.28 + 0.66 * t
    h = np.deg2rad(295.0 - 185.0 * t)
    chroma = 0.10 + 0.07 * t
    # the largest fraction of the chroma that stays in gamut, by bisection (all rows at once)
    lo, hi = np.zeros(size), np.ones(size)
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        c = mid * chroma
        rgb = _linear_srgb(L, c * np.cos(h), c * np.sin(h))
        inside = np.all((rgb >= -1e-9) & (rgb <= 1 + 1e-9), axis=1)
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    c = lo * chroma
    rgb = _encode(_linear_srgb(L, c * np.cos(h), c * np.sin(h)))
    table = np.rint(255.0 * rgb).astype(np.uint8)
    table.flags.writeable = False
    return table


def scalar_positions(values: npt.ArrayLike) -> np.ndarray:
    """Where each value falls in the colormap: ``t`` in [0, 1], NaN for non-finite values.

    Linear from the finite minimum (0) to the finite maximum (1); 0.5 for all values when
    they are equal.

    Parameters
    ----------
    values : array_like of float, shape (k,)

    Returns
    -------
    numpy.ndarray of float64, shape (k,)
    """
    x = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(x)
    t = np.full(x.shape, np.nan)
    if not finite.any():
        return t
    lo, hi = float(x[finite].min()), float(x[finite].max())
    span = hi - lo
    if span > 0 and np.isfinite(span):
        t[finite] = (x[finite] - lo) / span
    elif span > 0:  # a range beyond float64: scale first
        s = max(abs(lo), abs(hi))
        t[finite] = (x[finite] / s - lo / s) / (hi / s - lo / s)
    else:
        t[finite] = 0.5
    return np.clip(t, 0.0, 1.0)


def scalar_colours(values: npt.ArrayLike) -> np.ndarray:
    """A picture of a scalar: the colormap's colour of each value (module docstring).

    Parameters
    ----------
    values : array_like of float, shape (k,)

    Returns
    -------
    numpy.ndarray of uint8, shape (k, 3)
        sRGB red, green, blue; :data:`NOT_FINITE` grey for NaN and inf.
    """
    t = scalar_positions(values)
    table = colormap_table()
    out = np.empty((t.size, 3), dtype=np.uint8)
    finite = np.isfinite(t)
    out[finite] = table[np.rint(t[finite] * (len(table) - 1)).astype(np.int64)]
    out[~finite] = NOT_FINITE
    return out
