"""mkdocs hook: one API reference page per public module of fvf, generated at build time.

Every public module ``src/fvf/<package>/<name>.py`` gets a page ``api/<package>.<name>.md``
containing ``::: fvf.<package>.<name>`` (rendered by mkdocstrings from the docstrings),
listed in the navigation under "API reference" by layer (``GROUPS``); a module added
later appears under "More modules" without editing anything. Pages listed in ``OPTIONAL``
are added to the navigation only when their file exists, so the strict build tolerates
pages not written yet.

Docstrings write the chapter's matrices in brackets, ``[A_V][div v]`` or ``K[perm][:, perm]``,
which Markdown reads as a reference link ``[text][target]``; mkdocs-autorefs then warns that
the target ("div v", ":, perm") is not a documented object. Such a target is not a Python
name, so it cannot be a cross-reference: :class:`NotAReference` drops exactly those
warnings. Unresolved targets that *are* dotted names (a broken ``[x][fvf.missing]``) still
warn and fail the strict build.
"""

from __future__ import annotations

import logging
import re
from pathlib import Path

from mkdocs.structure.files import File

SRC = Path(__file__).resolve().parents[2] / "src" / "fvf"

#: Navigation groups: (title, modules or packages), in the order of the layers.
GROUPS = {
    "Meshes and files": ["mesh", "io"],
    "Calculus and operators (§3.1–3.3, §3.6, §4)": ["calculus", "operators"],
    "Flows and transport (§3.4–3.5, §4.5)": ["flows"],
    "Spectral tools and maps": ["spectral"],
    "Field design": ["design"],
    "Parameterization and quad meshes": ["param"],
    "Numerics": ["numerics"],
    "Chapter names, scenes and errors": ["chapter", "examples", "errors"],
    "Batch processing": ["batch"],
    "Command line and pictures": ["cli", "viz"],
}

# (nav title, file) pairs written by other work; listed only once the file exists.
OPTIONAL = [
    ("Pictures (fvf.viz)", "viz.md"),
    ("Command line", "cli.md"),
    ("Mesh repair", "repair.md"),
    ("Meshes with boundary", "boundary.md"),
    ("Files: what fvf guarantees", "files.md"),
    ("Meshes from other libraries", "interop.md"),
]


_TARGET = re.compile(r"Could not find cross-reference target '(.*)'")
_DOTTED_NAME = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")
_AUTOREFS_LOGGERS = (
    "mkdocs.plugins.mkdocs_autorefs._internal.plugin",
    "mkdocs.plugins.mkdocs_autorefs",
)


class NotAReference(logging.Filter):
    """Drop autorefs' "could not find target" warnings whose target is not a Python name."""

    def filter(self, record: logging.LogRecord) -> bool:
        match = _TARGET.search(record.getMessage())
        return match is None or _DOTTED_NAME.fullmatch(match.group(1)) is not None


def public_modules() -> list[str]:
    """Dotted names (below ``fvf``) of the public modules: ``calculus``, ``mesh.trimesh``,
    ... Every ``.py`` file whose path has no part starting with ``_``, and ``viz`` (its
    package's public names)."""
    names = []
    for path in sorted(SRC.rglob("*.py")):
        parts = path.relative_to(SRC).with_suffix("").parts
        if parts[0] == "viz":  # one page for the pictures: fvf.viz's public names
            if parts == ("viz", "__init__"):
                names.append("viz")
            continue
        if not any(part.startswith("_") for part in parts):
            names.append(".".join(parts))
    return sorted(set(names))


def _api_nav() -> list:
    modules = public_modules()
    nav: list = [{"Overview": "api/index.md"}]
    seen: set[str] = set()
    for title, heads in GROUPS.items():
        present = [n for n in modules if n.split(".")[0] in heads]
        seen.update(present)
        if present:
            nav.append({title: [{f"fvf.{n}": f"api/{n}.md"} for n in present]})
    rest = [n for n in modules if n not in seen]
    if rest:
        nav.append({"More modules": [{f"fvf.{n}": f"api/{n}.md"} for n in rest]})
    return nav


def on_config(config):
    for name in _AUTOREFS_LOGGERS:
        logger = logging.getLogger(name)
        if not any(isinstance(f, NotAReference) for f in logger.filters):
            logger.addFilter(NotAReference())
    docs = Path(config["docs_dir"])
    nav = config["nav"]
    for i, entry in enumerate(nav):
        if isinstance(entry, dict) and "API reference" in entry:
            nav[i] = {"API reference": _api_nav()}
    extra = [{title: path} for title, path in OPTIONAL if (docs / path).exists()]
    for entry in nav:
        if isinstance(entry, dict) and "Guides" in entry:
            entry["Guides"] = list(entry["Guides"]) + extra
    return config


def on_files(files, config):
    for name in public_modules():
        uri = f"api/{name}.md"
        if files.get_file_from_path(uri) is None:
            # the module's own heading (level 1) is the page title and its link target
            options = "    options:\n      show_root_heading: true\n      heading_level: 1\n"
            content = f"::: fvf.{name}\n{options}"
            files.append(File.generated(config, uri, content=content))
    return files
