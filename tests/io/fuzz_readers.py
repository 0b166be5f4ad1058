"""Long fuzzing campaigns for the mesh readers (a script, not collected by pytest).

Every input must either load (a valid (V, F) pair) or raise an ``fvf.errors.FvfError``;
anything else is a *finding*. An OBJ that loads must also agree with a plain reading of its
text (:func:`obj_oracle`): one vertex per ``v`` statement whatever the byte order mark
and line endings, and no coordinate that is only a number to Python's ``float()``
(``1_0``, ``nan``, ``infinity``). PLY inputs also go through ``read_ply_properties`` (arrays
aligned with the mesh), and every mesh that loads goes on through ``mesh_report`` (must not
raise) and ``repair_mesh`` (``FvfError`` only), the path a user's file takes. Findings are
recorded (input bytes + traceback) in ``--findings`` and the campaign continues, so one run
counts them all.

Two engines:

* atheris (coverage-guided libFuzzer; ``pip install atheris`` into the dev venv, it is not
  a dependency of fvf). The first input byte picks the reader (``.obj``, ``.off``,
  ``.ply``, ``.stl``), the rest is the file; arguments starting with ``-`` go to
  libFuzzer, the others are corpus directories (seeded when empty)::

      python tests/io/fuzz_readers.py corpus/ -atheris_runs=500000 -max_len=4096

* hypothesis (no extra install): the byte mutations of ``tests/io/test_io.py`` applied to the
  same seeds, with many more examples than the test suite runs::

      python tests/io/fuzz_readers.py --hypothesis 20000

Seeds are the fuzz bases of ``tests/io/test_io.py`` and ``tests/io/test_formats.py`` (STL), a
few extra shapes of each format, and the byte-level entries of ``tests/corpus.py``'s
:func:`hostile_files` (byte order marks, CR-only lines, 4OFF, Python-only number
spellings, binary junk).
"""

from __future__ import annotations

import argparse
import atexit
import shutil
import sys
import tempfile
import traceback
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]  # tests/io and tests (corpus.py)

SUFFIXES = [".obj", ".off", ".ply", ".stl"]
COUNTS = {"runs": 0, "loaded": 0, "fvf_errors": 0, "repair_errors": 0, "findings": 0}
API: dict = {}  # the fvf functions under test, imported by load_fvf (instrumented or not)


def load_fvf() -> None:
    import fvf.io.meshfile
    from fvf.errors import FvfError
    from fvf.mesh.diagnostics import mesh_report
    from fvf.mesh.repair import repair_mesh

    API.update(io=fvf.io, mesh_report=mesh_report, FvfError=FvfError, repair_mesh=repair_mesh)


def seeds() -> list[bytes]:
    """Seed inputs: selector byte + file bytes."""
    from test_formats import STL_BASES
    from test_io import ASCII_PLY, FUZZ_BASES, binary_ply

    out = []
    for name, data in {**FUZZ_BASES, **STL_BASES}.items():
        out.append(bytes([SUFFIXES.index(Path(name).suffix.lower())]) + data)
    out.append(b"\x02" + ASCII_PLY.encode())
    out.append(b"\x02" + binary_ply(">", [[0, 1, 2], [0, 2, 3], [4, 0, 1]], "int", "uint"))
    out.append(b"\x02" + binary_ply("<", [[0, 1, 2, 3], [4, 0, 1]], "ushort", "short"))
    out.append(
        b"\x01COFF\r\n3 1 0\r\n0 0 0 1 0 0 1\r\n1 0 0 1 0 0 1\r\n0 1 0 0 0 1 1\r\n3 0 1 2\r\n"
    )
    out.append(b"\x00v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nf 1/1/1 2//1 3 4\nf -1 -2 -3\n")
    from corpus import hostile_files

    for entry in hostile_files().values():
        if isinstance(entry.data, bytes) and len(entry.data) < 4096:
            out.append(bytes([SUFFIXES.index(entry.suffix)]) + entry.data)
    return out


_QUIRKS = ("nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity")


def obj_oracle(data: bytes, n_vertices: int) -> str | None:
    """What is wrong with an OBJ that loaded with ``n_vertices`` vertices, or None.

    A plain reading of the text: BOM dropped, LF / CRLF / CR line ends, one vertex per
    line whose first word is ``v``; its first three words must be C-syntax numbers.
    """
    text = data.removeprefix(b"\xef\xbb\xbf").decode("latin-1")
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    v_lines = [line.split("#", 1)[0].split() for line in lines if line.split()[:1] == ["v"]]
    if len(v_lines) != n_vertices:
        return f"{len(v_lines)} 'v' statements but {n_vertices} vertices read"
    for words in v_lines:
        for tok in words[1:4]:
            if "_" in tok or tok.lower() in _QUIRKS:
                return f"accepted the coordinate {tok!r}"
    return None


class Checker:
    """Runs one input through the readers and the repair path; counts and records findings."""

    def __init__(self, findings: Path) -> None:
        self.findings = findings
        findings.mkdir(exist_ok=True)
        self.work = Path(tempfile.mkdtemp(prefix="fvf_fuzz_"))
        self.paths = [self.work / f"input{s}" for s in SUFFIXES]
        self.seen: set[str] = set()

    def finding(self, exc: BaseException, path: Path, data: bytes) -> None:
        COUNTS["findings"] += 1
        where = traceback.extract_tb(exc.__traceback__)[-1]
        key = f"{type(exc).__name__}:{Path(where.filename).name}:{where.lineno}"
        if key not in self.seen:
            self.seen.add(key)
            stem = self.findings / f"finding{len(self.seen)}{path.suffix}"
            stem.write_bytes(data)
            stem.with_suffix(".txt").write_text(traceback.format_exc())

    def __call__(self, data: bytes) -> None:
        COUNTS["runs"] += 1
        if not data:
            return
        path = self.paths[data[0] % len(SUFFIXES)]
        body = data[1:]
        path.write_bytes(body)
        io, FvfError = API["io"], API["FvfError"]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                V, F = io.read_mesh(path)
                if path.suffix == ".ply":
                    vprops, fprops = io.read_ply_properties(path)
                    if any(len(a) != len(V) for a in vprops.values()) or any(
                        len(a) != len(F) for a in fprops.values()
                    ):
                        raise AssertionError("read_ply_properties: arrays not aligned")
            ok = (
                V.dtype.kind == "f"
                and V.ndim == 2
                and V.shape[1] == 3
                and F.dtype.kind == "i"
                and F.ndim == 2
                and F.shape[1] == 3
                and len(F) > 0
                and F.min() >= 0
                and F.max() < len(V)
            )
            if not ok:
                raise AssertionError(f"read_mesh contract: {V.shape} {F.shape} {F.dtype}")
            if path.suffix == ".obj":
                wrong = obj_oracle(body, len(V))
                if wrong is not None:
                    raise AssertionError(f"read_mesh against the text: {wrong}")
        except FvfError:
            COUNTS["fvf_errors"] += 1
            return
        except Exception as exc:  # noqa: BLE001 - a finding, recorded and counted
            self.finding(exc, path, body)
            return
        COUNTS["loaded"] += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                API["mesh_report"](V, F)
                try:
                    API["repair_mesh"](V, F)
                except FvfError:
                    COUNTS["repair_errors"] += 1
        except Exception as exc:  # noqa: BLE001
            self.finding(exc, path, body)

    def close(self) -> None:
        print(f"\nfvf fuzz summary: {COUNTS}; distinct findings: {sorted(self.seen)}", flush=True)
        shutil.rmtree(self.work, ignore_errors=True)


def run_hypothesis(check: Checker, examples: int) -> None:
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from test_io import MUTATION, mutated

    base = seeds()

    @settings(
        max_examples=examples,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(k=st.integers(0, len(base) - 1), mutations=st.lists(MUTATION, min_size=1, max_size=8))
    def campaign(k, mutations):
        check(base[k][:1] + mutated(base[k][1:], mutations))

    campaign()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--findings", default="fuzz_findings", help="directory for findings")
    parser.add_argument("--hypothesis", type=int, metavar="N", help="run N hypothesis examples")
    args, rest = parser.parse_known_args()
    if args.hypothesis:
        load_fvf()
        check = Checker(Path(args.findings))
        try:
            run_hypothesis(check, args.hypothesis)
        finally:
            check.close()
        return

    import atheris

    with atheris.instrument_imports(include=["fvf"]):
        load_fvf()
    check = Checker(Path(args.findings))
    corpus = [Path(a) for a in rest if not a.startswith("-")]
    if corpus and corpus[0].is_dir() and not any(any(c.iterdir()) for c in corpus if c.is_dir()):
        for k, s in enumerate(seeds()):
            (corpus[0] / f"seed{k}").write_bytes(s)
    atexit.register(check.close)
    atheris.Setup([sys.argv[0], *rest], check)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
