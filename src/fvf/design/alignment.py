r"""Alignment targets for field design: principal curvature directions or a user field.

:func:`fvf.design_field` with ``align=`` adds a soft alignment term to the smoothness
energy of an N-field in its power representation z (:mod:`fvf.design.nfields`),

.. math::

    E(z) = z^* L_N z + \beta \sum_t \omega_t A_t \, |z_t - \tau_t|^2 ,

with β = ``align_strength`` (dimensionless), ω_t ≥ 0 a per-face weight (units 1/length²)
and τ_t the N-th power of the target direction:

* ``align="curvature"``: τ_t = e^{iNθ_t} with θ_t the angle of the κ_1 principal direction
  (:func:`fvf.principal_curvatures`) in the face frame, and ω_t = (κ_1 − κ_2)², the squared
  curvature anisotropy. Umbilic and flat faces get ω_t = 0 and are left to smoothness,
  and the term has the units of the smoothness energy (∫|∇z|² and ∫(κ_1 − κ_2)²|z − τ|²
  are both dimensionless), so β = 1 is a balanced default at every scale. The principal
  directions are a line field (defined up to sign), so N must be even; N = 4 aligns a
  cross to both principal directions.
* ``align=u`` (float (m, 3)): τ_t = power of u_t (its direction only), ω_t =
  ``align_weights`` (default 4π/area, the squared curvature of a sphere of the mesh's
  area; faces where u is zero get ω_t = 0).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..errors import ConstraintError, DirectionCountError, format_indices
from ..mesh.curvature import principal_curvatures_transient
from ..mesh.inputs import as_face_field
from ..mesh.trimesh import TriMesh

__all__ = ["alignment_targets", "ALIGN_STRENGTH"]

#: Default β of the alignment term.
ALIGN_STRENGTH = 1.0


def _unit_power(z: np.ndarray, n: int) -> np.ndarray:
    r = np.abs(z)
    return np.where(r > 0, (z / np.where(r > 0, r, 1.0)) ** n, 0.0)


def _user_weights(
    mesh: TriMesh, align_weights: npt.ArrayLike | float | None, default: float
) -> np.ndarray:
    m = mesh.n_faces
    if align_weights is None:
        return np.full(m, default)
    w = np.asarray(align_weights, dtype=float)
    if w.ndim == 0:
        w = np.full(m, float(w))
    if w.shape != (m,):
        raise ConstraintError(
            f"align_weights must be a scalar or have shape ({m},), one weight per face; got "
            f"{w.shape}."
        )
    bad = np.flatnonzero(~(np.isfinite(w) & (w >= 0)))
    if bad.size:
        raise ConstraintError(
            f"align_weights must be finite and >= 0; faces {format_indices(bad)} are not."
        )
    return w


def alignment_targets(
    mesh: TriMesh,
    align: str | npt.ArrayLike,
    n: int,
    align_weights: npt.ArrayLike | float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Power targets τ and weights ω of an alignment term (see the module docstring).

    Parameters
    ----------
    mesh : TriMesh
    align : "curvature" or array_like float (m, 3)
    n : int
        Symmetry order N (checked by the caller); even for ``"curvature"``.
    align_weights : float or array_like (m,), optional
        ω per face (1/length²). Default: (κ_1 − κ_2)² for ``"curvature"`` (a given array
        then multiplies it), 4π/area for a user field.

    Returns
    -------
    tau : complex128 (m,)
        Unit-modulus targets e^{iNθ} (0 where the direction is undefined).
    weights : float64 (m,)
        ω_t ≥ 0.

    Raises
    ------
    DirectionCountError
        ``"curvature"`` with an odd N.
    ConstraintError
        Unknown ``align`` string, bad weights.
    """
    if isinstance(align, str):
        if align != "curvature":
            raise ConstraintError(
                f"align must be 'curvature' or a per-face field (m, 3); got {align!r}."
            )
        if n % 2:
            raise DirectionCountError(
                f"align='curvature' needs an even n (principal directions are defined up to "
                f"sign: n=2 lines, n=4 crosses); got n={n}."
            )
        pc = principal_curvatures_transient(mesh)  # not kept through the design's solve
        tau = _unit_power(mesh.to_complex(pc.d1), n)
        w = pc.anisotropy**2
        if align_weights is not None:
            w = w * _user_weights(mesh, align_weights, 1.0)
        return tau, w
    u = as_face_field(mesh, align, "align")
    tau = _unit_power(mesh.to_complex(u), n)
    w = _user_weights(mesh, align_weights, 4.0 * np.pi / mesh.total_area)
    return tau, np.where(tau != 0, w, 0.0)
