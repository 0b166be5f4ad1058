"""Flows: functions carried along a field, and fields carried along a flow.

- :mod:`.functional`: the chapter's flow Φ_{v,t} = exp(−t D^V_v) (§3.4–3.5, eq. 42).
- :mod:`.dispatch`: :func:`flow` and :class:`TransportFlow`, one entrance to every method
  (the chapter's, and the upwind, skew, Cayley and spectral flows with guarantees).
- :mod:`.field_transport`: transport of fields Ad_{Φ_{v,t}} (eq. 67) and interpolation
  (eq. 68).
- :mod:`.fluid`: ideal fluids by vorticity transport.

A new flow method goes beside the others in :mod:`.dispatch` (its generator and integrator)
and is listed in :data:`.dispatch.METHODS`. A method that needs a layer above this one (the
spectral flow and fluid, which need Laplace–Beltrami bases) lives there and registers with
the dispatcher (:func:`.dispatch.register_flow_method`, :func:`.fluid.register_fluid_method`):
this package never imports upward (docs/architecture.md).
"""

from .dispatch import TransportFlow, dual_edge_fluxes, flow, skew_operator, upwind_operator
from .field_transport import Ad, FieldTransport, TransportResult, interpolate
from .fluid import FluidResult, fluid_time_step, ideal_fluid
from .functional import FunctionalFlow

__all__ = [
    "FunctionalFlow",
    "flow",
    "TransportFlow",
    "dual_edge_fluxes",
    "upwind_operator",
    "skew_operator",
    "Ad",
    "FieldTransport",
    "TransportResult",
    "interpolate",
    "ideal_fluid",
    "fluid_time_step",
    "FluidResult",
]

#: Every name of ``__all__`` is also ``fvf.name`` (the flat namespace leaves none out).
NOT_FLAT: frozenset[str] = frozenset()
