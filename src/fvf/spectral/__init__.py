"""Spectral tools: Laplace–Beltrami bases and operators reduced to them (:mod:`.basis`),
and functional maps between shapes (:mod:`.fmaps`)."""

from .basis import SpectralBasis, gradient_field_basis, laplace_basis
from .fmaps import functional_map, functional_map_from_bases, map_quality

__all__ = [
    "SpectralBasis",
    "laplace_basis",
    "gradient_field_basis",
    "functional_map",
    "functional_map_from_bases",
    "map_quality",
]
