"""Line integral convolution computed the operator way (chapter §3.5, Fig. 3).

Classical LIC averages a noise image along each streamline. With functional vector
fields the averaging is a flow of functions: transporting the noise N along v for
time s is ``Φ_{v,s} N`` (eq. 42 for the chapter's flow exp(−s D^V_v)), so the texture is

    T = (1 / 2L) ∫_{−L}^{L} Φ_{v̂,s} N ds,

the noise flowed forward and backward and averaged. v̂ = v / |v| is the unit field
(zero where v vanishes), so L is an arc length in mesh units and the streaks have the
same length everywhere. The integral is the trapezoid rule over ``samples`` equally
spaced times, all computed by one call of :func:`fvf.flows.dispatch.flow` (which chains the
times, so the work is that of flowing to ±L once).

Noise (:func:`lic_noise`): independent uniform values at the vertices (seeded), smoothed
by one implicit heat step ``(M + τ² K) N = M N_0`` with τ one mean edge length (M the
lumped mass, K the stiffness matrix, eq. 31): features about two edges wide, the finest
that the upwind flow carries without smearing them across the streamlines. A streak is
then about two edges wide and 2L long. On a coarse mesh, render the texture on a
subdivided copy (:func:`fvf.viz.subdivide`) for finer streaks; pass ``noise`` to use
another function.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..flows.dispatch import flow
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field, as_vertex_function
from ..mesh.trimesh import TriMesh

__all__ = ["DEFAULT_LIC_LENGTH", "lic_noise", "lic_texture", "unit_field"]

#: Default half-length L of the convolution, in mean edge lengths.
DEFAULT_LIC_LENGTH = 12.0


@takes_mesh
def unit_field(mesh: TriMesh, v: npt.ArrayLike, rtol: float = 1e-8) -> np.ndarray:
    """v / |v| per face, float64 (m, 3); zero where |v| ≤ rtol · max |v|."""
    v = as_face_field(mesh, v, "v")
    speed = np.sqrt((v * v).sum(1))
    keep = speed > rtol * speed.max() if speed.size else speed > 0
    return np.divide(v, speed[:, None], out=np.zeros_like(v), where=keep[:, None])


@takes_mesh
def lic_noise(mesh: TriMesh, seed: int = 0, smoothing: float = 1.0) -> np.ndarray:
    """Seeded vertex noise smoothed at ``smoothing`` mean edge lengths, float64 (n,).

    Uniform [0, 1) values N_0, then ``(M + τ² K) N = M N_0`` with
    τ = ``smoothing`` · mean edge length (M = :func:`fvf.vertex_mass`,
    K = :func:`fvf.stiffness`). ``smoothing=0`` returns N_0.
    """
    import scipy.sparse.linalg as sla

    from ..calculus import stiffness, vertex_mass

    N0 = np.random.default_rng(seed).random(mesh.n_vertices)
    if smoothing <= 0:
        return N0
    tau = smoothing * mesh.mean_edge_length
    M = vertex_mass(mesh)
    return sla.spsolve((M + tau**2 * stiffness(mesh)).tocsc(), M @ N0)


@takes_mesh
def lic_texture(
    mesh: TriMesh,
    v: npt.ArrayLike,
    *,
    length: float | None = None,
    samples: int = 25,
    seed: int = 0,
    noise: npt.ArrayLike | None = None,
    method: str = "upwind",
) -> np.ndarray:
    """The LIC texture of a field: noise averaged along its flow, ``(1/2L)∫ Φ_{v̂,s} N ds``.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
        Tangent field per face; only its direction matters (it is normalised).
    length : float, optional
        Half-length L of the convolution in mesh units (default
        :data:`DEFAULT_LIC_LENGTH` mean edge lengths).
    samples : int
        Number of flow times s_k = linspace(−L, L, samples) (odd counts include s = 0).
    seed : int
        Seed of the noise :func:`lic_noise` (ignored when ``noise`` is given).
    noise : array_like (n,), optional
        The function to convolve instead of the seeded white noise.
    method : {"upwind", "chapter", "skew", "cayley", "spectral"}
        The flow (:func:`fvf.flows.dispatch.flow`). ``"upwind"`` (default) is a convex
        combination of noise values at every time, so T stays in [min N, max N] and
        cannot blow up on any mesh. ``"chapter"`` is the chapter's exp(−s D^V_v)
        (eq. 42), sharper but it may warn (FlowGrowthWarning) for compressible fields,
        and the unit field of a divergence-free field is compressible.

    Returns
    -------
    ndarray float64 (n,)
        T at the vertices. Use a grey colormap with limits at T's 1st and 99th
        percentiles (what :func:`fvf.viz.render` does for ``texture=``).
    """
    if samples < 2:
        raise ValueError(f"samples must be at least 2; got {samples}")
    u = unit_field(mesh, v)
    L = DEFAULT_LIC_LENGTH * mesh.mean_edge_length if length is None else float(length)
    if noise is None:
        N = lic_noise(mesh, seed)
    else:
        N = as_vertex_function(mesh, noise, "noise")
    s = np.linspace(-L, L, samples)
    frames = flow(mesh, u, N, s, method=method)  # (samples, n)
    w = np.full(samples, 1.0)
    w[[0, -1]] = 0.5
    return (w @ frames) / w.sum()
