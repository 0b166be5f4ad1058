"""Picture outputs: the format named by the output's suffix."""

from __future__ import annotations

from pathlib import Path

from ..errors import OutputError

__all__ = ["PICTURE_FORMATS", "picture_format"]

#: The picture formats, by the output's suffix (any case). PDF and SVG hold the title,
#: colorbar and legend as vector graphics and the rendered panels as an image.
PICTURE_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}


def picture_format(path: str | Path) -> str:
    """The format of the picture written to ``path``: ``"png"``, ``"pdf"`` or ``"svg"``.

    Raises
    ------
    OutputError
        The suffix is none of :data:`PICTURE_FORMATS`: a picture written under another
        name (``result.npz``, ``mesh.obj``, no suffix) would replace a file of that kind
        with an image, so nothing is written.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in PICTURE_FORMATS:
        shown = f"suffix '{Path(path).suffix}'" if suffix else "no suffix"
        raise OutputError(
            f"{path}: a picture is written as PNG, PDF or SVG by its suffix; this has "
            f"{shown}, so nothing was written. Fix: name it "
            f"{Path(path).with_suffix('.png').name}"
        )
    return PICTURE_FORMATS[suffix]
