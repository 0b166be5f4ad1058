"""Pictures of meshes, functions and tangent fields (optional extra ``[viz]``).

``pip install 'fvf[viz]'`` brings matplotlib, pillow and polyscope. Importing
:mod:`fvf` or :mod:`fvf.viz` imports none of them; each function imports what it
needs and raises :class:`MissingExtraError` (with the install command) when it is
missing. ``docs/viz.md`` documents the conventions.

- :func:`render`: one PNG of a mesh with a colormapped function (robust colour limits,
  :func:`robust_limits`), arrows or N-direction strokes sized in pixels, singularity
  markers with a legend (:func:`index_color`, :func:`index_label`), streamlines and/or a
  grey texture, in one or several views (:func:`two_sides`; the up axis from
  :func:`detect_up_axis`); headless polyscope (EGL) when it starts, else matplotlib; the
  backend used is reported in the returned :class:`RenderInfo`. How the picture looks
  (colours, glyph sizes, camera and up axis, size, title, backend) is one frozen
  :class:`RenderStyle` (``style=``); its options are also accepted one by one as keywords.
- :func:`view`: polyscope's interactive window.
- :func:`arrow_segments`: the arrows' start and end points (in the faces' planes);
  :func:`direction_set`: the N directions of an N-direction field.
- :func:`streamlines`: integral curves traced exactly from face to face.
- :func:`surface_lic`: line integral convolution traced on the surface at a resolution
  of its own (a :class:`LicTexture` for ``render(texture=...)``).
- :func:`lic_texture`: line integral convolution the operator way,
  ``(1/2L) ∫_{−L}^{L} Φ_{v̂,s} N ds`` (chapter §3.5, Fig. 3).
- :func:`write_gif`: an animated GIF of frames.
- :func:`render_quads`, :func:`render_checkerboard`: quad meshes (wireframe, irregular
  vertices by valence) and the checkerboard of a parameterization.
- :func:`render_correspondence`, :func:`render_error_map`, :func:`plot_error_curves`:
  pictures of a vertex map between two meshes (transferred colours, errors, curves).
"""

from ..errors import MissingExtraError, NoDisplayError, RenderBackendWarning  # noqa: F401
from . import camera, scene  # noqa: F401  (fvf.viz.scene.NO_DATA_COLOR, ...)
from .arrows import (
    DEFAULT_ARROW_LENGTH,
    arrow_segments,
    default_arrow_scale,
    direction_set,
    spread_faces,
)
from .backends import BACKENDS, RenderInfo, available_backends, polyscope_status, render, view
from .camera import View, detect_up_axis, two_sides
from .colors import index_color, index_label, robust_limits
from .correspondence import (
    coordinate_stripes,
    plot_error_curves,
    render_correspondence,
    render_error_map,
)
from .gif import write_gif
from .lic import (
    DEFAULT_LIC_LENGTH,
    DEFAULT_LIC_RESOLUTION,
    LicTexture,
    lic_noise,
    lic_texture,
    surface_lic,
    unit_field,
)
from .quads import render_checkerboard, render_quads
from .refine import subdivide
from .style import RenderStyle
from .tracing import streamlines

__all__ = [
    "BACKENDS",
    "DEFAULT_ARROW_LENGTH",
    "DEFAULT_LIC_LENGTH",
    "DEFAULT_LIC_RESOLUTION",
    "LicTexture",
    "RenderInfo",
    "RenderStyle",
    "View",
    "arrow_segments",
    "available_backends",
    "coordinate_stripes",
    "default_arrow_scale",
    "detect_up_axis",
    "direction_set",
    "index_color",
    "index_label",
    "lic_noise",
    "lic_texture",
    "plot_error_curves",
    "polyscope_status",
    "render",
    "robust_limits",
    "render_checkerboard",
    "render_quads",
    "render_correspondence",
    "render_error_map",
    "spread_faces",
    "streamlines",
    "subdivide",
    "surface_lic",
    "two_sides",
    "unit_field",
    "view",
    "write_gif",
]
