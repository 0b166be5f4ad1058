"""Animated GIFs from frames (pillow)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FvfError
from ..io.atomic import atomic_path
from ._deps import require

__all__ = ["write_gif"]


def write_gif(frames: list, path: str | Path, fps: float = 4.0, loop: int = 0) -> Path:
    """Write frames as an animated GIF.

    Parameters
    ----------
    frames : list of path or ndarray
        PNG/JPEG paths, or RGB(A) images (h, w, 3|4), uint8 or float in [0, 1]. Frames
        of another size than the first are resized to it.
    path : str or Path
        Output ``.gif``.
    fps : float
        Frames per second.
    loop : int
        0 loops forever.

    Returns
    -------
    Path
        ``path``.
    """
    Image = require("PIL.Image", "writing a GIF")
    if not frames:
        raise FvfError("write_gif needs at least one frame")
    if not fps > 0:
        raise FvfError(f"fps must be positive; got {fps!r}")
    images: list[Any] = []
    for fr in frames:
        if isinstance(fr, (str, Path)):
            im = Image.open(fr).convert("RGB")
        else:
            a = np.asarray(fr)
            if a.dtype != np.uint8:
                a = (np.clip(a, 0.0, 1.0) * 255 + 0.5).astype(np.uint8)
            im = Image.fromarray(a[:, :, :3])
        if images and im.size != images[0].size:
            im = im.resize(images[0].size)
        images.append(im)
    path = Path(path)
    with atomic_path(path) as tmp:  # whole or not at all
        images[0].save(
            tmp,
            format="GIF",
            save_all=True,
            append_images=images[1:],
            duration=int(1000 / fps),
            loop=loop,
            optimize=False,
        )
    return path
