"""Lazy imports of the optional ``[viz]`` extra, and the errors and warnings of fvf.viz.

``import fvf`` never imports matplotlib, pillow or polyscope: each fvf.viz function
imports what it needs when it is called, through :func:`require`.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from ..errors import FvfError, FvfWarning, MissingExtraError, NoDisplayError, RenderBackendWarning  # noqa: F401 (re-exported)

__all__ = [
    "require",
]

INSTALL_HINT = "pip install 'fvf[viz]'"


def require(module: str, what: str = "rendering") -> ModuleType:
    """Import ``module`` (e.g. ``"matplotlib"``) or raise :class:`MissingExtraError`.

    Parameters
    ----------
    module : str
        Importable name.
    what : str
        What needs it, for the message.

    Returns
    -------
    module

    Raises
    ------
    MissingExtraError
        With the install command ``pip install 'fvf[viz]'``.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        raise MissingExtraError(
            f"{what} needs {top}, which is not installed. Fix: {INSTALL_HINT}"
        ) from exc
