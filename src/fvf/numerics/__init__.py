"""Numerical kernels that know nothing about meshes: the action of the matrix exponential
(:mod:`.expm`), symmetric eigensolvers (:mod:`.eigen`, :mod:`.multilevel`), sparse
positive definite factorizations (:mod:`.cholesky`) and fill-reducing orderings
(:mod:`.ordering`). Reusable and testable alone."""

from .eigen import eigen_residuals, smallest_eigenpairs
from .expm import expm_action

__all__ = ["expm_action", "smallest_eigenpairs", "eigen_residuals"]

#: Names of ``__all__`` that the flat namespace ``fvf`` leaves out (reach them as
#: ``fvf.numerics.name``); every other name here is also ``fvf.name``.
NOT_FLAT: frozenset[str] = frozenset({"expm_action"})
