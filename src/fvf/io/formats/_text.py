"""Tokens and numbers of text mesh files (OBJ, OFF, ascii PLY, ascii STL).

Numbers follow C/printf decimal syntax, stricter than Python's ``float()`` and ``int()``
(:func:`strict`); every failure is a :class:`fvf.errors.MeshReadError` naming the line and
the token. Everything works on whole token lists at once: no Python loop per vertex or
face on a clean file.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Protocol

import numpy as np

from ...errors import MeshReadError


class LineNumbers(Protocol):
    """``lineno[i]``: the line of the i-th statement (a list, or computed when asked)."""

    def __getitem__(self, i: int, /) -> int: ...


def statement_tokens(lines: list[str], at: list[int], key: str) -> tuple[list[str], np.ndarray]:
    """Tokens of the OBJ statements ``lines[at]``, without the ``key`` and comments.

    Returns the concatenated tokens and the token count of each line. When all lines have
    one width and no comment, a single join + split does the work: the key then occurs once
    per line, at multiples of the width, so the lines are aligned.
    """
    if not at:
        return [], np.zeros(0, dtype=np.int64)
    chosen = [lines[i] for i in at]
    joined = " ".join(chosen)
    tokens = joined.split()
    width = len(chosen[0].split())
    if (
        "#" not in joined
        and len(tokens) == width * len(at)
        and tokens.count(key) == len(at) == tokens[::width].count(key)
    ):
        del tokens[::width]
        return tokens, np.full(len(at), width - 1, dtype=np.int64)
    return flatten([words(line)[1:] for line in chosen])


def words(line: str) -> list[str]:
    """The whitespace-separated tokens of a line, without its ``#`` comment."""
    return (line.split("#", 1)[0] if "#" in line else line).split()


def flatten(rows: list[list[str]]) -> tuple[list[str], np.ndarray]:
    """Concatenated tokens of ``rows`` and the number of tokens of each row."""
    return [t for row in rows for t in row], np.fromiter(map(len, rows), np.int64, len(rows))


#: Numbers in text mesh files: C/printf decimal syntax. Python's float() and int() also
#: take underscores ("1_0" is 10), "nan", "inf" and "infinity": not part of these formats.
_REAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]+")
_REAL_CHARS = frozenset("0123456789+-.eE")
_INTEGER_CHARS = frozenset("0123456789+-")


def strict(
    path: Path, tokens: list[str], counts: np.ndarray, lineno: LineNumbers, kind: type, what: str
) -> None:
    """Refuse tokens that Python would convert but the file format does not allow."""
    allowed = _INTEGER_CHARS if kind is np.int64 else _REAL_CHARS
    if set("".join(tokens)) <= allowed:  # only digits, signs, '.', 'e': float()/int() decide
        return
    grammar = _INTEGER if kind is np.int64 else _REAL
    for k, tok in enumerate(tokens):
        if grammar.fullmatch(tok) is None:
            line = lineno[int(np.searchsorted(np.cumsum(counts), k, side="right"))]
            if kind is not np.int64 and tok.lower().lstrip("+-") in ("nan", "inf", "infinity"):
                why = "is not a finite number; vertex positions and values must be finite"
            elif "_" in tok:
                why = "has an underscore, which is not part of numbers in mesh files"
            else:
                need = "an integer" if kind is np.int64 else "a decimal number"
                why = f"is not {need}"
            raise MeshReadError(
                f"{path}: line {line}: {tok!r} in {what} {why}; fix or delete that line"
            )


def numbers(
    path: Path, tokens: list[str], counts: np.ndarray, lineno: LineNumbers, kind: type, what: str
) -> np.ndarray:
    """``np.array(tokens, kind)``; on failure a MeshReadError naming the line and the token.

    ``counts[i]`` tokens come from the line ``lineno[i]``. Tokens must be numbers in C
    syntax (:func:`strict`), not merely something ``float()`` accepts.
    """
    strict(path, tokens, counts, lineno, kind, what)
    try:
        values: np.ndarray = np.array(tokens, dtype=kind).reshape(len(tokens))
    except (ValueError, OverflowError):
        pass
    else:
        if kind is np.int64 or np.isfinite(values).all():
            return values
        k = int(np.flatnonzero(~np.isfinite(values))[0])  # 1e999: beyond float64
        line = lineno[int(np.searchsorted(np.cumsum(counts), k, side="right"))]
        raise MeshReadError(
            f"{path}: line {line}: {tokens[k]!r} in {what} is beyond the float64 range "
            "(about 1.8e308); vertex positions and values must be finite: fix that line"
        )
    for k, tok in enumerate(tokens):
        try:
            np.array([tok], dtype=kind)
        except (ValueError, OverflowError):
            line = lineno[int(np.searchsorted(np.cumsum(counts), k, side="right"))]
            need = "an integer" if kind is np.int64 else "a number"
            raise MeshReadError(
                f"{path}: line {line}: cannot read {tok!r} as {need} in {what}; "
                "fix or delete that line"
            ) from None
    raise MeshReadError(f"{path}: cannot convert the values of {what}; check the file")


def first3(
    path: Path, tokens: list[str], counts: np.ndarray, lineno: LineNumbers, what: str
) -> np.ndarray:
    """Vertex positions, shape (k, 3), from the first three numbers of each vertex line."""
    short = np.flatnonzero(counts < 3)
    if short.size:
        i = short[0]
        raise MeshReadError(
            f"{path}: line {lineno[i]}: {what} has {counts[i]} coordinates, but needs x y z; "
            "fix or delete that line"
        )
    if np.any(counts != 3):
        starts = (np.cumsum(counts) - counts).tolist()
        tokens = [t for s in starts for t in tokens[s : s + 3]]
        counts = np.full(len(counts), 3, dtype=np.int64)
    return numbers(path, tokens, counts, lineno, np.float64, what).reshape(-1, 3)


def text_lines(data: bytes) -> list[str]:
    """The lines of a text file, whatever its line endings (LF, CRLF or CR alone)."""
    text = data.decode("latin-1")
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text.split("\n")
