"""The documentation site: it builds in strict mode, and the tutorial's snippets run.

The build needs the ``[docs]`` extra (mkdocs, mkdocs-material, mkdocstrings); the test is
skipped cleanly without it. The tutorial runs with the library alone.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SRC = ROOT / "src" / "fvf"


def _public_modules() -> list[str]:
    """Every module file of src/fvf without a private part (``fvf.viz``: its package)."""
    names = {"viz"}
    for path in SRC.rglob("*.py"):
        parts = path.relative_to(SRC).with_suffix("").parts
        if parts[0] != "viz" and not any(part.startswith("_") for part in parts):
            names.add(".".join(parts))
    return sorted(names)


def _python_blocks(page: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (DOCS / page).read_text(), flags=re.S)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """Build the site once with ``mkdocs build --strict``; returns (output dir, log)."""
    for module in ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python"):
        pytest.importorskip(module, reason="the [docs] extra is not installed")
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    return out, proc


def test_site_builds_strict_without_warnings(site):
    out, proc = site
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log
    assert "WARNING" not in log, log
    assert (out / "index.html").exists()


def test_every_public_module_has_a_rendered_api_page(site):
    out, _ = site
    for name in _public_modules():
        page = out / "api" / name / "index.html"
        assert page.exists(), f"no API page for fvf.{name}"
        html = page.read_text()
        # mkdocstrings rendered the module's objects, not just the heading
        assert "doc-contents" in html and f"fvf.{name}" in html, name


def test_site_pages_are_in_the_navigation(site):
    out, _ = site
    nav = (out / "index.html").read_text()
    for page in ("tutorial", "examples", "gallery", "conventions", "operators", "api/calculus"):
        assert f'href="{page}/"' in nav or f'href="./{page}/"' in nav, page


def test_api_reference_renders_parameters_from_numpy_docstrings(site):
    out, _ = site
    html = (out / "api" / "operators.directional" / "index.html").read_text()
    assert "D_V" in html and "Parameters" in html and "eq. 36" in html


def test_tutorial_snippets_run_in_order():
    import fvf.errors

    blocks = _python_blocks("tutorial.md")
    assert len(blocks) >= 15, "the tutorial follows the chapter section by section"
    namespace: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error", fvf.errors.FvfWarning)
        for i, block in enumerate(blocks):
            exec(compile(block, f"docs/tutorial.md block {i}", "exec"), namespace)
    # the sections' results are there: flows, brackets, ACAP fields, Fig. 12's interpolant
    assert namespace["frames"].shape == (5, namespace["n"])
    assert namespace["acap"].shape == (2, namespace["m"], 3)
    assert namespace["BF"].shape == (namespace["n"], namespace["n"])


def test_index_snippet_runs():
    for block in _python_blocks("index.md"):
        exec(compile(block, "docs/index.md", "exec"), {})


def test_tutorial_follows_the_chapter():
    text = (DOCS / "tutorial.md").read_text()
    headings = re.findall(r"^##+ (.*)$", text, flags=re.M)
    wanted = ["§3.1", "§3.2", "§3.4", "§3.6", "§4.1", "§4.3", "Fig. 9", "Figs. 7", "§4.4"]
    wanted += ["Fig. 10", "Fig. 11", "Fig. 12"]
    for key in wanted:
        assert any(key in h for h in headings), f"no tutorial section for {key}"


def test_sphinx_roles_in_docstrings_become_links(site):
    """docs/_hooks/rst_roles.py turns :func:`...` roles into links (or plain code)."""
    out, _ = site
    pages = [p.read_text() for p in (out / "api").glob("*/index.html")]
    assert not any(re.search(r":(func|class|mod|data|meth|attr):`", html) for html in pages)
    links = sum(html.count('class="autorefs autorefs-internal"') for html in pages)
    assert links > 100, links
    flows = (out / "api" / "flows.dispatch" / "index.html").read_text()
    assert 'href="#fvf.flows.dispatch.upwind_operator"' in flows


def _gen_gallery():
    import importlib.util

    spec = importlib.util.spec_from_file_location("gen_gallery", DOCS / "gen_gallery.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_gallery_generator_lays_out_the_demo_report():
    """docs/gen_gallery.py turns the demo's report data into Markdown: a section per
    section, its numbers with what they should be and ✓/✗, its pictures and skip notes."""
    gen = _gen_gallery()
    number = {"label": "nnz |x|", "shown": "12", "expect": "≤ 20", "tol": "", "mark": "✓"}
    report = {
        "mesh": "m.obj",
        "n_vertices": 4,
        "n_faces": 4,
        "euler_characteristic": 2,
        "backend": "matplotlib",
        "checks": [{"ok": True}, {"ok": None}],
        "sections": [
            {
                "title": "Brackets (eqs. 46, 54)",
                "numbers": [dict(number, note="1-ring")],
                "pictures": [
                    {"file": "a.png", "caption": "first [v,w]", "colors": "h per vertex"},
                    {"file": "b.png", "caption": "second", "wide": True, "link": "b.gif"},
                ],
                "skipped": [],
            },
            {"title": "Fig. 11", "numbers": [], "pictures": [], "skipped": ["needs [viz]"]},
        ],
    }
    text = gen.page(report)
    assert "## Brackets (eqs. 46, 54)" in text and "## Fig. 11" in text
    assert "| nnz \\|x\\| | `12` | ≤ 20 | — | ✓ | 1-ring |" in text
    assert "![first [v,w]](gallery/a.png)" in text and "h per vertex" in text
    assert '(gallery/b.png){ width="100%" }' in text and "(gallery/b.gif)" in text
    assert "*skipped: needs [viz]*" in text
    assert "Rendered with: matplotlib. 1 of 1 checks pass.*" in text


def test_gallery_page_shows_every_committed_picture():
    text = (DOCS / "gallery.md").read_text()
    pictures = sorted(p.name for p in (DOCS / "gallery").glob("*") if p.suffix in (".png", ".gif"))
    if not pictures:
        pytest.skip("gallery not generated (docs/gen_gallery.py needs the [viz] extra)")
    assert sorted(re.findall(r"\]\(gallery/([^)]+)\)", text)) == pictures
    for figure in ("Fig. 3", "Fig. 7", "Fig. 9", "Fig. 10", "Fig. 11", "Fig. 12"):
        assert figure in text, figure


def test_rst_markup_in_docstrings_becomes_markdown(site):
    """``.. math::`` blocks are display math, and no reST directive is printed literally."""
    out, _ = site
    connection = (out / "api" / "design.connection" / "index.html").read_text()
    assert 'class="arithmatex"' in connection and "w_{st}" in connection
    for page in (out / "api").glob("*/index.html"):
        assert ".. math::" not in page.read_text(), page


_EXTERNAL = re.compile(r"""^(?:[a-z][a-z0-9+.-]*:)?//""", re.I)  # http://, https://, //host


def _external_assets(html: str) -> list[str]:
    """URLs of scripts, stylesheets and preloads that a page would fetch from other hosts."""
    found = []
    for tag in re.findall(r"<(?:script|link)\b[^>]*>", html, flags=re.I):
        if tag.lower().startswith("<link") and not re.search(
            r"""rel=["']?(?:stylesheet|preload|modulepreload|prefetch|preconnect|dns-prefetch)""",
            tag,
            flags=re.I,
        ):
            continue  # canonical, icons of this site, alternates: nothing is executed
        for url in re.findall(r"""(?:src|href)=["']([^"']+)["']""", tag, flags=re.I):
            if _EXTERNAL.match(url):
                found.append(url)
    return found


def test_site_loads_no_script_or_stylesheet_from_other_hosts(site):
    """The site works offline: every script and stylesheet is served from the site itself
    (MathJax is bundled under docs/javascripts/mathjax; the theme's web fonts are off)."""
    out, _ = site
    pages = sorted(out.rglob("*.html"))
    assert len(pages) > 20
    external = {str(p.relative_to(out)): _external_assets(p.read_text()) for p in pages}
    assert not {page: urls for page, urls in external.items() if urls}


def test_bundled_mathjax_is_served_with_its_fonts_and_licence(site):
    out, _ = site
    mathjax = out / "javascripts" / "mathjax"
    assert (mathjax / "tex-mml-chtml.js").stat().st_size > 500_000
    assert "Apache License" in (mathjax / "LICENSE").read_text()
    fonts = list((mathjax / "output" / "chtml" / "fonts" / "woff-v2").glob("*.woff"))
    assert len(fonts) >= 20  # CHTML resolves its fonts relative to the script
    html = (out / "chapter" / "index.html").read_text()
    assert re.search(r"""<script[^>]+src=["'][./]*javascripts/mathjax/tex-mml-chtml\.js""", html)


def test_chapter_page_has_every_equation_of_the_chapter(site):
    """docs/chapter.md restates eqs. (1)-(68): (1)-(25) in the table of the smooth setting,
    (26)-(68) as display math with their tags, rendered as math (arithmatex)."""
    out, _ = site
    html = (out / "chapter" / "index.html").read_text()
    assert 'class="arithmatex"' in html
    text = (DOCS / "chapter.md").read_text()
    tagged = {int(n) for n in re.findall(r"\\tag\{(\d+)\}", text)}
    in_table = {int(n) for n in re.findall(r"^\| \((\d+)\)", text, flags=re.M)}
    in_table |= {
        k
        for a, b in re.findall(r"^\| \((\d+)\)[–-]\((\d+)\)", text, flags=re.M)
        for k in range(int(a), int(b) + 1)
    }
    missing = sorted(set(range(1, 69)) - tagged - in_table)
    assert not missing, f"equations not on docs/chapter.md: {missing}"
    for n in sorted(tagged):
        assert f"\\tag{{{n}}}" in html, n


def test_changelog_page_includes_the_repository_changelog(site):
    out, _ = site
    html = (out / "changelog" / "index.html").read_text()
    assert "Unreleased" in html and "0.1.0" in html and "FieldValueError" in html


def _unrendered_math(html: str) -> list[str]:
    """``$`` delimiters left in a page's text: math that arithmatex did not pick up (code,
    scripts and the math it rendered removed first)."""
    import html as html_lib

    text = re.sub(r"<(script|style|pre|code)\b[^>]*>.*?</\1>", "", html, flags=re.S)
    text = re.sub(r'<(span|div) class="arithmatex">.*?</\1>', "", text, flags=re.S)
    text = html_lib.unescape(re.sub(r"<[^>]+>", " ", text))
    return [
        " ".join(text[max(m.start() - 30, 0) : m.end() + 30].split())
        for m in re.finditer(r"\$\$|\$[^\s$][^$]*?\$", text)
    ]


def test_no_page_shows_unrendered_math_delimiters(site):
    """Display math inside list items (docs/correspondence.md, the docstrings of
    fvf.param.seamless and fvf.design.cancellation) is rendered, not shown as ``$$``."""
    out, _ = site
    found = {}
    for page in sorted(out.rglob("*.html")):
        left = _unrendered_math(page.read_text())
        if left:
            found[str(page.relative_to(out))] = left[:3]
    assert not found, found
    assert _unrendered_math("<p>$$x$$</p>") and not _unrendered_math("<code>$x$</code>")


def test_wide_display_math_scrolls_in_its_box(site):
    out, _ = site
    css = (out / "stylesheets" / "math.css").read_text()
    assert "overflow-x: auto" in css and "arithmatex" in css
    assert "stylesheets/math.css" in (out / "quads" / "index.html").read_text()
