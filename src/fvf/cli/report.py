"""The demo's report: sections of pictures and numbers checked against what they should be.

The report is data: a :class:`Story` holds :class:`Section` s, each with

- numbers (:class:`Number`): a measured value, what it should be (``expect``), the
  tolerance and whether it passed (✓ / ✗), or an informative value (``ok=None``) with a
  note saying what it means;
- pictures: a PNG, its caption, what its colours show and their range, and optionally a
  link (an animation);
- skipped pictures and why.

:func:`render_html` lays the sections out as ``index.html``; ``summary.json`` carries the
same data (:meth:`Story.as_dict`), which ``docs/gen_gallery.py`` reads. A new demo section
is one function: ``st = story.begin(title, fn)``, then ``st.check(...)`` / ``st.info(...)``
and ``story.picture(st, ...)``, appended to the demo's ``STAGES``.
"""

from __future__ import annotations

import html
import inspect
from collections.abc import Callable, Iterator, MutableMapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "Number",
    "Section",
    "Story",
    "fmt",
    "render_html",
    "print_numbers",
    "section_not_done",
    "json_default",
    "strict_json",
]

#: Significant digits of the numbers shown.
DIGITS = 4
OK, FAIL, INFO = "✓", "✗", "·"


def fmt(value: Any, digits: int = DIGITS) -> str:
    """A value for people: floats to ``digits`` significant digits, lists element-wise."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return f"{float(value):.{digits}g}"
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(fmt(v, digits) for v in value) + "]"
    return str(value)


@dataclass
class Number:
    """One reported value and what it should be.

    Attributes
    ----------
    label : str
    value : float, int, bool, str or list
    expect : str
        What it should be, in words or symbols ("0", "< 1", "[1, 1, 3]"); "" for an
        informative value.
    tol : str
        The tolerance of the check ("≤ 1e-10", "exact"); "" when there is none.
    ok : bool or None
        Passed, failed, or None for an informative value (no check).
    note : str
        What the value is (units, per vertex or per face, where the expectation comes from).
    """

    label: str
    value: Any
    expect: str = ""
    tol: str = ""
    ok: bool | None = None
    note: str = ""

    @property
    def mark(self) -> str:
        """✓, ✗ or · (informative)."""
        return INFO if self.ok is None else (OK if self.ok else FAIL)


def _within(value: Any, target: Any, tol: float) -> bool:
    v = np.asarray(value, dtype=float)
    return bool(np.all(np.isfinite(v)) and np.all(np.abs(v - np.asarray(target, float)) <= tol))


class _Numbers(MutableMapping):
    """``st["numbers"][label] = value`` records an informative number (the older API)."""

    def __init__(self, section: Section):
        self._section = section

    def __getitem__(self, key: str) -> Any:
        for n in self._section.numbers:
            if n.label == key:
                return n.value
        raise KeyError(key)

    def __setitem__(self, key: str, value: Any) -> None:
        self._section.info(key, value)

    def __delitem__(self, key: str) -> None:
        self._section.numbers = [n for n in self._section.numbers if n.label != key]

    def __iter__(self) -> Iterator[str]:
        return iter([n.label for n in self._section.numbers])

    def __len__(self) -> int:
        return len(self._section.numbers)


@dataclass
class Section:
    """One stage of the demo: its numbers, pictures, skipped pictures and source."""

    title: str
    code: Callable | None = None
    numbers: list[Number] = field(default_factory=list)
    pictures: list[dict] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def _add(self, number: Number) -> Number:
        self.numbers = [n for n in self.numbers if n.label != number.label] + [number]
        return number

    def check(
        self,
        label: str,
        value: Any,
        *,
        expect: Any = None,
        tol: float | None = None,
        below: float | None = None,
        above: float | None = None,
        at_most: float | None = None,
        equals: Any = None,
        note: str = "",
    ) -> Number:
        """Record a value with what it should be and whether it is.

        Exactly one criterion: ``expect`` with ``tol`` (``|value − expect| ≤ tol``,
        element-wise for lists), ``below`` (``value < below``), ``above``
        (``value > above``), ``at_most`` (``value ≤ at_most``), or ``equals`` (exact, for
        counts, flags and lists of them). Non-finite values fail.
        """
        if at_most is not None:
            ok = bool(np.all(np.isfinite(value)) and np.all(np.asarray(value) <= at_most))
            return self._add(Number(label, value, f"≤ {fmt(at_most)}", "", ok, note))
        if equals is not None:
            ok = bool(np.array_equal(np.asarray(value), np.asarray(equals)))
            return self._add(Number(label, value, fmt(equals), "exact", ok, note))
        if below is not None:
            ok = bool(np.all(np.isfinite(value)) and np.all(np.asarray(value) < below))
            return self._add(Number(label, value, f"< {fmt(below)}", "", ok, note))
        if above is not None:
            ok = bool(np.all(np.isfinite(value)) and np.all(np.asarray(value) > above))
            return self._add(Number(label, value, f"> {fmt(above)}", "", ok, note))
        if expect is None or tol is None:
            raise ValueError("check needs expect and tol, below, above or equals")
        ok = _within(value, expect, tol)
        return self._add(Number(label, value, fmt(expect), f"≤ {fmt(tol, 2)}", ok, note))

    def closed_check(
        self, closed: bool, label: str, value: Any, note: str, **criterion: Any
    ) -> Number:
        """:meth:`check` of an identity that holds on closed surfaces only (div J∇g = 0
        needs g constant along the boundary, Poincaré–Hopf counts no boundary turning);
        on a mesh with boundary the value is reported with that said, not judged."""
        if closed:
            return self.check(label, value, note=note, **criterion)
        return self.info(label, value, note=f"{note}; holds on closed surfaces, this one is open")

    def info(self, label: str, value: Any, note: str = "") -> Number:
        """Record an informative value (no expectation): say in ``note`` what it is."""
        return self._add(Number(label, value, "", "", None, note))

    def __getitem__(self, key: str) -> Any:  # the older dict-style API
        if key == "numbers":
            return _Numbers(self)
        if key in ("title", "pictures", "skipped", "code", "seconds"):
            return getattr(self, key)
        raise KeyError(key)

    def __setitem__(self, key: str, value: Any) -> None:
        if key not in ("seconds", "code", "title"):
            raise KeyError(key)
        setattr(self, key, value)

    def as_dict(self) -> dict:
        """Title, numbers (with expectations and marks), pictures, skipped, seconds."""
        return {
            "title": self.title,
            "numbers": [dict(asdict(n), mark=n.mark, shown=fmt(n.value)) for n in self.numbers],
            "pictures": [{k: v for k, v in p.items() if k != "info"} for p in self.pictures],
            "skipped": list(self.skipped),
            "seconds": self.seconds,
        }


class Story:
    """Collects sections, renders pictures (or records why not), writes the report."""

    def __init__(
        self,
        out: Path,
        pictures: bool,
        size: tuple[int, int],
        skip_reason: str | None = None,
        options: dict | None = None,
    ):
        self.out, self.size = Path(out), tuple(size)
        self.options = dict(options or {})  # RenderStyle options of every picture (up, dpi)
        self.skip_reason = None if pictures else "pictures were turned off (pictures=False)"
        if self.skip_reason is None:
            self.skip_reason = skip_reason
        self.stages: list[Section] = []
        self.backend: str | None = None
        self.files: list[str] = []

    def begin(self, title: str, fn: Callable | None = None) -> Section:
        """Start a section (``fn``: the function whose source the report shows)."""
        st = Section(title, fn)
        self.stages.append(st)
        return st

    def picture(
        self,
        st: Section,
        name: str,
        mesh: Any,
        caption: str,
        *,
        listed: bool = True,
        wide: bool = False,
        link: str | None = None,
        draw: Any = None,
        **kwargs: Any,
    ) -> Path | None:
        """Render ``name`` into the output folder, or record why it was skipped.

        ``listed=False`` renders without showing the picture in the report (frames of an
        animation); ``wide=True`` makes it 1.6 times as wide (two views side by side);
        ``link`` is a file the picture links to (an animation); ``draw`` renders something
        other than ``mesh`` (a ``fvf.viz`` function taking the path and ``render``'s
        keywords, e.g. ``functools.partial(fvf.viz.render_quads, V, Q)``). Returns the PNG's
        path.
        """
        if self.skip_reason is not None:
            if listed:
                st.skipped.append(f"{name}: {self.skip_reason}")
            return None
        import fvf.viz

        w, h = self.size
        kwargs.setdefault("size", (int(1.6 * w), h) if wide else (w, h))
        for key, value in self.options.items():
            if key == "view":  # the camera angles, each view keeping its turn
                kwargs["view"] = fvf.viz.camera.aim(kwargs.get("view"), *value)
            else:
                kwargs.setdefault(key, value)
        if draw is None:
            info = fvf.viz.render(mesh, self.out / name, title=caption, **kwargs)
        else:
            info = draw(self.out / name, title=caption, **kwargs)
        self.backend = info.backend
        self.files.append(name)
        if listed:
            entry = {"file": name, "caption": caption, "backend": info.backend, "wide": wide}
            if info.clim is not None:
                entry["colors"] = _color_note(kwargs, info.clim, mesh)
            if link:
                entry["link"] = link
            st.pictures.append(entry)
        return info.path

    def add_file(self, st: Section, name: str, caption: str, *, link: str | None = None) -> None:
        """List a file written by the section itself (a strip of frames)."""
        self.files.append(name)
        entry = {"file": name, "caption": caption, "wide": True}
        if link:
            entry["link"] = link
        st.pictures.append(entry)

    def as_dict(self) -> dict:
        """Every section as data (for ``summary.json``)."""
        return {"sections": [st.as_dict() for st in self.stages]}


def _color_note(kwargs: dict, clim: tuple, mesh: Any) -> str:
    """What a picture's colours show: the label, per vertex or per face, and the range."""
    f = kwargs.get("function")
    where = ""
    if f is not None:
        n = np.shape(f)[0]
        where = "per vertex" if n == getattr(mesh, "n_vertices", -1) else "per face"
    label = kwargs.get("colorbar_label") or "colour"
    return f"{label} {where}, colour range [{fmt(clim[0], 3)}, {fmt(clim[1], 3)}]".replace(
        "  ", " "
    )


_CSS = (
    "body{font-family:sans-serif;max-width:1280px;margin:2em auto;color:#222;padding:0 1em}"
    "figure{display:inline-block;margin:6px;vertical-align:top;width:600px}"
    "figure.wide{width:940px}figure img{width:100%;border:1px solid #ddd}"
    "figcaption{font-size:85%;color:#333}figcaption .colors{color:#666}"
    "table{border-collapse:collapse;margin:.5em 0}"
    "td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;vertical-align:top}"
    "th{background:#f3f3f3}td.num{font-family:monospace;white-space:nowrap}"
    "td.ok{color:#187a2f;font-weight:bold;text-align:center}"
    "td.fail{color:#b00020;font-weight:bold;text-align:center}"
    "td.info{color:#888;text-align:center}td.note{font-size:85%;color:#555}"
    "pre{background:#f6f6f6;padding:8px;overflow-x:auto;font-size:80%}"
    ".skip{color:#a40}.summary{font-size:110%}"
)


def _table(st: Section) -> list[str]:
    esc = html.escape
    rows = [
        "<table><tr><th>quantity</th><th>measured</th><th>should be</th><th>tolerance</th>"
        "<th></th><th>what it is</th></tr>"
    ]
    for n in st.numbers:
        cls = "info" if n.ok is None else ("ok" if n.ok else "fail")
        rows.append(
            f"<tr><td>{esc(n.label)}</td><td class='num'>{esc(fmt(n.value))}</td>"
            f"<td class='num'>{esc(n.expect or '—')}</td><td class='num'>{esc(n.tol or '—')}"
            f"</td><td class='{cls}'>{n.mark}</td><td class='note'>{esc(n.note)}</td></tr>"
        )
    rows.append(f"</table><p class='note'>{st.seconds:.2f} s</p>")
    return rows


def _figure(pic: dict) -> str:
    esc = html.escape
    target = pic.get("link") or pic["file"]
    cls = " class='wide'" if pic.get("wide") else ""
    extra = ""
    if pic.get("colors"):
        extra += f"<br><span class='colors'>{esc(pic['colors'])}</span>"
    if pic.get("link"):
        extra += f" <a href='{esc(pic['link'])}'>(animation: {esc(pic['link'])})</a>"
    return (
        f"<figure{cls}><a href='{esc(target)}'><img src='{esc(pic['file'])}' "
        f"alt='{esc(pic['caption'])}'></a><figcaption>{esc(pic['caption'])} "
        f"(<code>{esc(pic['file'])}</code>){extra}</figcaption></figure>"
    )


def render_html(story: Story, header: dict, intro: str = "") -> str:
    """``index.html`` of a story: a summary of the checks, then each section."""
    esc = html.escape
    checks = [n for st in story.stages for n in st.numbers if n.ok is not None]
    failed = [n for n in checks if not n.ok]
    verdict = (
        f"{len(checks) - len(failed)} of {len(checks)} checks pass {OK}"
        if not failed
        else f"{len(failed)} of {len(checks)} checks FAIL {FAIL}: "
        + ", ".join(esc(n.label) for n in failed)
    )
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'><title>fvf demo</title>",
        f"<style>{_CSS}</style></head><body>",
        "<h1>fvf demo: operator-based tangent vector fields</h1>",
        f"<p>Mesh: {esc(str(header['mesh']))} ({header['n_vertices']} vertices, "
        f"{header['n_faces']} faces, Euler characteristic {header['euler_characteristic']}). "
        f"Rendered with: {esc(str(story.backend or 'nothing (pictures skipped)'))}. "
        f"Total time {header['seconds']:.1f} s.</p>",
        f"<p class='summary'>{verdict}. Each number is shown with what it should be and "
        f"the tolerance of the check ({OK} pass, {FAIL} fail, {INFO} informative: no "
        "expected value, the note says what it is).</p>",
        intro,
    ]
    for st in story.stages:
        parts.append(f"<h2>{esc(st.title)}</h2>")
        parts += _table(st)
        parts += [_figure(p) for p in st.pictures]
        parts += [f"<p class='skip'>skipped: {esc(s)}</p>" for s in st.skipped]
        if st.code is not None:
            code = inspect.getsource(st.code)
            parts.append(
                f"<details><summary>the library calls</summary><pre>{esc(code)}</pre></details>"
            )
    parts.append("</body></html>")
    return "\n".join(parts)


def print_numbers(story: Story) -> None:
    """Each stage's numbers on the terminal, a line each, with what they should be."""
    for st in story.stages:
        for n in st.numbers:
            if n.label == "flow times":
                continue
            want = f" (should be {n.expect}" + (f", {n.tol}" if n.tol else "") + ")"
            print(f"  {n.mark} {n.label}: {fmt(n.value)}{want if n.expect else ''}")


def section_not_done(
    story: Story, fn: Callable[..., Any], title: str, begun: int, exc: Exception
) -> str:
    """Record that a section could not be done on this mesh (a typed fvf error, or the
    result of an earlier section that was not done) in its report section; the demo goes
    on with the next one. Returns the section's title."""
    if len(story.stages) == begun:
        story.begin(title, fn)
    st = story.stages[-1]
    st.title = f"{st.title} (not done)"
    why = f"{type(exc).__name__}: {exc}"[:300]
    st.info("section", "not done", note=why)
    print(f"[fvf demo] {title}: not done on this mesh ({why})", flush=True)
    return st.title


def strict_json(x: Any) -> Any:
    """``x`` with every NaN or infinite float (Python or numpy, in dicts, lists and
    arrays) as None: JSON has no NaN (a flat mesh's bracket ratio was ``Infinity``)."""
    if isinstance(x, dict):
        return {k: strict_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [strict_json(v) for v in x]
    if isinstance(x, np.ndarray):
        return strict_json(x.tolist())
    if isinstance(x, (float, np.floating)) and not np.isfinite(x):
        return None
    return x


def json_default(x: Any) -> Any:
    """``json.dumps``' fallback for the report: numpy scalars and arrays as Python values."""
    if isinstance(x, (np.integer, np.floating, np.bool_)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)
