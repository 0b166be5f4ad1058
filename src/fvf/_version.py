"""The installed version of fvf, read once from the package metadata.

It sits below every layer (docs/architecture.md), so the file writers of ``fvf.io``,
``fvf.batch`` and ``fvf.cli`` stamp their outputs without importing the package root.
"""

from __future__ import annotations

from importlib import metadata

__all__ = ["__version__"]

try:
    __version__ = metadata.version("fvf")
except metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"
