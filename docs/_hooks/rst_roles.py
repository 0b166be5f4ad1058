"""Griffe extension: the Sphinx markup of fvf's docstrings, rendered by mkdocstrings.

fvf's numpy-style docstrings use a little reStructuredText that mkdocstrings (Markdown)
would print literally. Before rendering:

- roles (``:func:`fvf.ad```, ``:class:`~fvf.errors.FlowGrowthWarning```,
  ``:data:`DENSE_MAX```) become *optional* mkdocs-autorefs references to the object's
  canonical path: a link when that object is rendered somewhere on the site, plain code
  otherwise (numpy, scipy), never a warning. Relative names are looked up in the
  enclosing class, then the module, then ``fvf``;
- ``.. math::`` blocks become ``$$ … $$`` display math (pymdownx.arithmatex, MathJax);
- a paragraph ending in ``::`` (a literal block follows) ends in ``:``.
"""

from __future__ import annotations

import re
from html import escape
from typing import Any

import griffe

_MATH = re.compile(
    r"^(?P<indent>[ ]*)\.\. math::[ ]*\n\n(?P<body>(?:(?P=indent)[ ]+\S.*\n|[ ]*\n)+)", re.M
)
_LITERAL = re.compile(r"(?<=\S)::[ ]*$", re.M)
_ROLE = re.compile(r":(?:func|class|mod|data|meth|attr|exc|obj|const):`(~?)([\w.]+)(?:\(\))?`")


def _math(match: re.Match) -> str:
    indent, body = match.group("indent"), match.group("body").rstrip()
    lines = [line.strip() for line in body.splitlines()]
    return (
        f"{indent}$$\n" + "".join(f"{indent}{line}\n" for line in lines if line) + f"{indent}$$\n\n"
    )


def markdown(text: str) -> str:
    """Math blocks and literal-block markers of a docstring in Markdown (roles aside)."""
    return _LITERAL.sub(":", _MATH.sub(_math, text if text.endswith("\n") else text + "\n"))


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
                text = _ROLE.sub(lambda m: link(obj, m), obj.docstring.value)
                obj.docstring.value = markdown(text).rstrip("\n")
            for member in obj.members.values():
                if not member.is_alias:
                    visit(member)

        visit(pkg)
