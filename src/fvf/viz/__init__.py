"""Pictures of meshes, functions and tangent fields (optional extra ``[viz]``).

``pip install 'fvf[viz]'`` brings matplotlib, pillow and polyscope. Importing
:mod:`fvf` or :mod:`fvf.viz` imports none of them; each function imports what it
needs and raises :class:`MissingExtraError` (with the install command) when it is
missing. ``docs/viz.md`` documents the conventions.

- :func:`render`: one PNG of a mesh with a colormapped function, arrows, singularity
  markers, streamlines and/or a grey texture; headless polyscope (EGL) when it starts,
  else matplotlib; the backend used is reported in the returned :class:`RenderInfo`.
- :func:`view`: polyscope's interactive window.
- :func:`arrow_segments`: the arrows' start and end points (in the faces' planes).
- :func:`streamlines`: integral curves traced exactly from face to face.
- :func:`lic_texture`: line integral convolution the operator way,
  ``(1/2L) ∫_{−L}^{L} Φ_{v̂,s} N ds`` (chapter §3.5, Fig. 3).
- :func:`write_gif`: an animated GIF of frames.
- :func:`render_correspondence`, :func:`render_error_map`, :func:`plot_error_curves`:
  pictures of a vertex map between two meshes (transferred colours, errors, curves).
"""

from ..errors import MissingExtraError, NoDisplayError, RenderBackendWarning  # noqa: F401
from .arrows import DEFAULT_ARROW_LENGTH, arrow_segments, default_arrow_scale, spread_faces
from .backends import BACKENDS, RenderInfo, available_backends, polyscope_status, render, view
from .camera import View
from .correspondence import (
    coordinate_stripes,
    plot_error_curves,
    render_correspondence,
    render_error_map,
)
from .gif import write_gif
from .lic import DEFAULT_LIC_LENGTH, lic_noise, lic_texture, unit_field
from .refine import subdivide
from .tracing import streamlines

__all__ = [
    "BACKENDS",
    "DEFAULT_ARROW_LENGTH",
    "DEFAULT_LIC_LENGTH",
    "RenderInfo",
    "View",
    "arrow_segments",
    "available_backends",
    "coordinate_stripes",
    "default_arrow_scale",
    "lic_noise",
    "lic_texture",
    "plot_error_curves",
    "polyscope_status",
    "render",
    "render_correspondence",
    "render_error_map",
    "spread_faces",
    "streamlines",
    "subdivide",
    "unit_field",
    "view",
    "write_gif",
]
