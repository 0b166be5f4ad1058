"""Griffe extension: Sphinx roles in fvf's docstrings become links in the API reference.

fvf's numpy-style docstrings cross-reference with Sphinx roles (``:func:`fvf.ad```,
``:class:`~fvf.errors.FlowGrowthWarning```, ``:data:`DENSE_MAX```), which mkdocstrings
would print literally. Before rendering, each role is replaced by an *optional*
mkdocs-autorefs reference to the object's canonical path: a link when that object is
rendered somewhere on the site, plain code otherwise (numpy, scipy), never a warning.
Relative names are looked up in the enclosing class, then the module, then ``fvf``.
"""

from __future__ import annotations

import re
from html import escape
from typing import Any

import griffe

_ROLE = re.compile(r":(?:func|class|mod|data|meth|attr|exc|obj|const):`(~?)([\w.]+)(?:\(\))?`")


def _canonical(collection, path: str) -> str | None:
    """The canonical path of the object at ``path`` (following aliases), or None."""
    try:
        obj = collection.get_member(path)
    except (KeyError, ValueError, griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None
    try:
        return obj.target_path if obj.is_alias else obj.path
    except (griffe.AliasResolutionError, griffe.CyclicAliasError):  # pragma: no cover
        return path


def _scopes(obj) -> list[str]:
    """Where a relative name is looked up: the class, the module, then the package."""
    scopes = []
    node = obj
    while node is not None:
        if node.is_class or node.is_module:
            scopes.append(node.path)
        node = node.parent
    return scopes


class RstRoles(griffe.Extension):
    """Replace Sphinx roles by optional autorefs, after the whole package is loaded."""

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        collection = loader.modules_collection

        def link(obj, match: re.Match) -> str:
            short, name = match.group(1) == "~", match.group(2)
            target = None
            for scope in [*_scopes(obj), ""]:
                candidate = f"{scope}.{name}" if scope else name
                if candidate.split(".")[0] in collection.members:
                    target = _canonical(collection, candidate)
                    if target:
                        break
            title = name.rsplit(".", 1)[-1] if short else name
            identifier = escape(target or name, quote=True)
            return f'<autoref identifier="{identifier}" optional><code>{title}</code></autoref>'

        def visit(obj) -> None:
            if obj.is_alias:
                return
            if obj.docstring is not None:
                obj.docstring.value = _ROLE.sub(lambda m: link(obj, m), obj.docstring.value)
            for member in obj.members.values():
                if not member.is_alias:
                    visit(member)

        visit(pkg)
