"""Colours that read: robust colour limits, overlay colours that contrast, index colours.

- :func:`robust_limits`: colour limits at area-weighted percentiles, widened back to the
  data's min / max when nothing lies far beyond them, so a few needle faces or spikes no
  longer wash out the rest of the picture while well-behaved data keeps its exact range.
- :func:`contrast_color`: the overlay colour (arrows, strokes, curves) farthest in CIELAB
  from every colour the surface can take (colormap × shading), and :func:`outline_color`
  the black or white halo drawn around it.
- :func:`index_color`, :func:`index_label`: singularity colours and labels for integer and
  fractional indices (±1/N, …) of N-direction fields.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import numpy.typing as npt

from ..errors import FvfError

__all__ = [
    "ROBUST_PERCENTILES",
    "contrast_color",
    "equalize",
    "index_color",
    "index_label",
    "outline_color",
    "resolve_clim",
    "robust_limits",
    "simulate_color_blindness",
    "srgb_to_lab",
    "weighted_percentile",
]

#: Default colour limits: these area-weighted percentiles of the function.
ROBUST_PERCENTILES = (1.0, 99.0)
#: A limit is widened back to the data's min (max) when that lies within this fraction of
#: the percentile range beyond it: no outliers, so nothing needs clipping.
_WIDEN = 0.1

#: Overlay colour candidates (sRGB), in order of preference on ties.
OVERLAY_CANDIDATES = {
    "black": (0.06, 0.06, 0.08),
    "white": (1.0, 1.0, 1.0),
    "crimson": (0.86, 0.08, 0.24),
    "orange": (1.0, 0.55, 0.0),
    "magenta": (0.92, 0.25, 0.85),
    "green": (0.25, 0.80, 0.20),
    "cyan": (0.0, 0.85, 0.95),
}


def weighted_percentile(
    values: npt.ArrayLike, q: npt.ArrayLike, weights: npt.ArrayLike | None = None
) -> np.ndarray:
    """Percentiles ``q`` (in [0, 100]) of ``values`` weighted by ``weights``.

    Parameters
    ----------
    values : array_like (k,)
    q : array_like (p,) or float
        Percentiles in [0, 100].
    weights : array_like (k,), optional
        Non-negative weights (e.g. vertex or face areas); None weighs every value equally.

    Returns
    -------
    ndarray float64 (p,) or float
        The smallest value whose cumulative weight reaches ``q`` percent of the total (a
        step function, so a percentile is always one of the values).
    """
    v = np.asarray(values, dtype=float).ravel()
    qs = np.atleast_1d(np.asarray(q, dtype=float))
    if v.size == 0:
        raise FvfError("weighted_percentile needs at least one value")
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=float).ravel()
    order = np.argsort(v, kind="stable")
    cw = np.cumsum(w[order])
    total = cw[-1]
    if not total > 0:
        cw, total = np.arange(1.0, v.size + 1), float(v.size)
    pos = np.searchsorted(cw, qs / 100.0 * total, side="left")
    out = v[order][np.clip(pos, 0, v.size - 1)]
    return out if np.ndim(q) else out[0]


def robust_limits(
    values: npt.ArrayLike,
    weights: npt.ArrayLike | None = None,
    percentiles: tuple[float, float] = ROBUST_PERCENTILES,
    symmetric: bool = False,
) -> tuple[float, float, bool, bool]:
    """Colour limits that ignore a few extreme values.

    ``lo, hi`` are the area-weighted ``percentiles`` of the values; each is moved back to the
    data's min (max) when that is within 10% of ``hi − lo`` beyond it, so data without
    outliers keeps its exact range and only real outliers are clipped. ``symmetric`` gives
    ``(−a, a)`` with ``a`` the same robust maximum of ``|values|`` (for signed data and a
    diverging colormap).

    Parameters
    ----------
    values : array_like (k,)
    weights : array_like (k,), optional
        Areas of the vertices or faces the values live on.
    percentiles : (float, float)
    symmetric : bool

    Returns
    -------
    lo, hi : float
        ``lo < hi`` (a constant function gets ``c ∓ 0.5``).
    clipped_low, clipped_high : bool
        Whether some values lie below ``lo`` / above ``hi`` (the colorbar then shows
        extension arrows).
    """
    v = np.asarray(values, dtype=float).ravel()
    if symmetric:
        a = np.abs(v)
        top = float(weighted_percentile(a, percentiles[1], weights))
        if a.max() - top <= _WIDEN * top:
            top = float(a.max())
        if not top > 0:
            top = 1.0
        return -top, top, bool(v.min() < -top), bool(v.max() > top)
    lo, hi = (float(x) for x in weighted_percentile(v, list(percentiles), weights))
    span = hi - lo
    if lo - v.min() <= _WIDEN * span:
        lo = float(v.min())
    if v.max() - hi <= _WIDEN * span:
        hi = float(v.max())
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    return lo, hi, bool(v.min() < lo), bool(v.max() > hi)


def resolve_clim(
    values: np.ndarray, weights: np.ndarray | None, clim: tuple | str | None
) -> tuple[float, float, bool, bool]:
    """Colour limits for :func:`fvf.viz.render`'s ``clim`` option.

    ``None`` or ``"robust"``: :func:`robust_limits`; ``"symmetric"``: the symmetric robust
    limits; ``"full"``: min and max; a pair ``(lo, hi)``: as given. Returns ``lo, hi`` and
    whether values fall below / above them.
    """
    v = np.asarray(values, dtype=float)
    if clim is None or (isinstance(clim, str) and clim == "robust"):
        return robust_limits(v, weights)
    if isinstance(clim, str):
        if clim == "symmetric":
            return robust_limits(v, weights, symmetric=True)
        if clim == "full":
            lo, hi = float(v.min()), float(v.max())
        else:
            raise FvfError(
                f"clim must be None, 'robust', 'symmetric', 'full' or (lo, hi); got {clim!r}"
            )
    else:
        try:
            lo, hi = (float(x) for x in clim)
        except (TypeError, ValueError) as exc:
            raise FvfError(f"clim must be a pair (lo, hi); got {clim!r}") from exc
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    return lo, hi, bool(v.min() < lo), bool(v.max() > hi)


def srgb_to_lab(rgb: npt.ArrayLike) -> np.ndarray:
    """CIELAB (D65) coordinates of sRGB colours in [0, 1], float64 (..., 3)."""
    c = np.clip(np.asarray(rgb, dtype=float)[..., :3], 0.0, 1.0)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    M = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
    xyz = lin @ M.T / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack(
        [116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])],
        axis=-1,
    )


#: Dichromat simulation in linear RGB (Machado, Oliveira and Fernandes 2009, severity 1).
_DICHROMAT = {
    "deuteranopia": np.array(
        [
            [0.367322, 0.860646, -0.227968],
            [0.280085, 0.672501, 0.047413],
            [-0.01182, 0.04294, 0.968881],
        ]
    ),
    "protanopia": np.array(
        [
            [0.152286, 1.052583, -0.204868],
            [0.114503, 0.786281, 0.099216],
            [-0.003882, -0.048116, 1.051998],
        ]
    ),
}


def simulate_color_blindness(rgb: npt.ArrayLike, kind: str) -> np.ndarray:
    """sRGB colours (..., 3) in [0, 1] as a reader with ``kind`` ("deuteranopia" or
    "protanopia", the red-green dichromacies) sees them (Machado et al. 2009)."""
    c = np.clip(np.asarray(rgb, dtype=float)[..., :3], 0.0, 1.0)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    out = np.clip(lin @ _DICHROMAT[kind].T, 0.0, 1.0)
    return np.where(out <= 0.0031308, 12.92 * out, 1.055 * out ** (1 / 2.4) - 0.055)


def _distances(a: np.ndarray, b: npt.ArrayLike, color_blind: bool) -> np.ndarray:
    """ΔE*76 from the colours ``a`` (k, 3) to ``b`` (3,); with ``color_blind``, the
    smallest of the distances seen with normal vision, deuteranopia and protanopia."""
    d = np.linalg.norm(srgb_to_lab(a) - srgb_to_lab(b), axis=1)
    if color_blind:
        for kind in _DICHROMAT:
            sa, sb = simulate_color_blindness(a, kind), simulate_color_blindness(b, kind)
            d = np.minimum(d, np.linalg.norm(srgb_to_lab(sa) - srgb_to_lab(sb), axis=1))
    return d


def contrast_color(
    surface: npt.ArrayLike,
    avoid: npt.ArrayLike | None = None,
    exclude: tuple[str, ...] = (),
) -> tuple[float, float, float]:
    """The overlay colour most distinct from every surface colour.

    Parameters
    ----------
    surface : array_like (k, 3)
        Colours the surface can show (e.g. a colormap sampled and multiplied by the range
        of shading factors), sRGB in [0, 1].
    avoid : array_like (j, 3), optional
        Further colours to stay away from (singularity markers, other overlays): each
        overlay is named by its colour in the legend, so these distances are the smallest
        seen with normal vision and the two red-green dichromacies
        (:func:`simulate_color_blindness`): a second field is never green beside an
        orange one.
    exclude : tuple of str
        Candidate names (keys of :data:`OVERLAY_CANDIDATES`) not to use.

    Returns
    -------
    (r, g, b)
        The candidate of :data:`OVERLAY_CANDIDATES` whose smallest CIELAB distance
        (ΔE*76) to the surface and avoided colours is largest.
    """
    targets = np.asarray(surface, dtype=float).reshape(-1, 3)
    others = np.zeros((0, 3))
    if avoid is not None and np.size(avoid):
        others = np.asarray(avoid, dtype=float).reshape(-1, 3)
    best, best_d = OVERLAY_CANDIDATES["black"], -1.0
    for name, rgb in OVERLAY_CANDIDATES.items():
        if name in exclude:
            continue
        d = float(
            np.concatenate([_distances(targets, rgb, False), _distances(others, rgb, True)]).min()
        )
        if d > best_d + 1e-9:
            best, best_d = rgb, d
    return best


def outline_color(color: npt.ArrayLike) -> tuple[float, float, float]:
    """The halo around an overlay: black, or white around a dark colour (L* < 35)."""
    return (1.0, 1.0, 1.0) if srgb_to_lab(color)[0] < 35.0 else (0.0, 0.0, 0.0)


#: Singularity colours by index, from the colour-blind-safe palette of Okabe and Ito:
#: warm for positive indices, cool for negative, and for each sign the colours differ in
#: lightness as well as hue (so they stay apart for deuteranopes and in greyscale).
_INDEX_COLORS = {
    Fraction(1, 4): (0.94, 0.89, 0.26),  # yellow
    Fraction(1, 2): (0.90, 0.62, 0.00),  # orange
    Fraction(1): (0.84, 0.37, 0.00),  # vermilion
    Fraction(2): (0.50, 0.15, 0.00),  # dark brown
    Fraction(-1, 4): (0.34, 0.71, 0.91),  # sky blue
    Fraction(-1, 2): (0.00, 0.45, 0.70),  # blue
    Fraction(-1): (0.00, 0.20, 0.45),  # dark blue
    Fraction(-2): (0.10, 0.10, 0.20),  # near black
}
_OTHER_POSITIVE = (0.80, 0.47, 0.65)  # reddish purple
_OTHER_NEGATIVE = (0.00, 0.62, 0.45)  # bluish green


def _fraction(index: float) -> Fraction:
    return Fraction(float(index)).limit_denominator(24)


def index_color(index: float) -> tuple[float, float, float]:
    """Marker colour of a singularity of the given index.

    Okabe–Ito colours (distinguishable by colour-blind readers), warm for positive
    indices, cool for negative, darker as ``|index|`` grows: +1/4 yellow, +1/2 orange,
    +1 vermilion, +2 dark brown; −1/4 sky blue, −1/2 blue, −1 dark blue, −2 near black.
    Other positive indices (1/6, 3/4, …) are reddish purple, other negative ones bluish
    green; 0 is grey. A quad mesh's vertex of valence v takes the colour of index
    (4 − v)/4: valence 3 yellow, 5 sky blue.
    """
    f = _fraction(index)
    if f in _INDEX_COLORS:
        return _INDEX_COLORS[f]
    if f == 0:
        return (0.6, 0.6, 0.6)
    return _OTHER_POSITIVE if f > 0 else _OTHER_NEGATIVE


def index_label(index: float) -> str:
    """The index as a signed fraction: ``+1``, ``-1``, ``+1/4``, ``-1/2`` …"""
    f = _fraction(index)
    if f == 0:
        return "0"
    return f"{f.numerator:+d}" if f.denominator == 1 else f"{f.numerator:+d}/{f.denominator}"


def equalize(values: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Histogram equalization: each value's weighted rank, float64 in [0, 1].

    The contrast normalization of LIC textures: averaging noise along streamlines shrinks
    its spread, and ranks spread it over the whole grey range again. Equal values get
    one rank, the middle of their group's weight.
    """
    v = np.asarray(values, dtype=float)
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=float)
    order = np.argsort(v, kind="stable")
    ws = w[order]
    cw = np.cumsum(ws)
    # equal values share one rank (the middle of their group): a checkerboard's two
    # values stay two grey levels, not a ramp over the faces' order
    _, start, inverse = np.unique(v[order], return_index=True, return_inverse=True)
    middle = cw[start] - ws[start] + 0.5 * np.add.reduceat(ws, start)
    out = np.empty_like(v)
    out[order] = middle[inverse.ravel()] / max(cw[-1], 1e-300)
    return out
