"""Coverage-guided fuzzing of fvf.read_mesh with atheris (not collected by pytest).

Every input must either load (a valid (V, F) pair) or raise an ``fvf.errors.FvfError``;
anything else is a *finding*. PLY inputs also go through ``read_ply_properties`` (arrays
aligned with the mesh), and every mesh that loads goes on through ``mesh_report`` (must not
raise) and ``repair_mesh`` (``FvfError`` only), the path a user's file takes. Findings are
recorded (input bytes + traceback) in ``--findings`` and the campaign continues, so one run
counts them all.

The first input byte picks the reader (``.obj``, ``.off``, ``.ply``); the rest is the file.
Seeds are the fuzz bases of ``tests/test_io.py`` plus a few extra shapes of each format.

Usage (atheris is not a dependency of fvf: ``pip install atheris`` into the dev venv)::

    python tests/fuzz_readers.py -atheris_runs=200000 -max_len=4096 -rss_limit_mb=2048

Options that do not start with ``-`` are libFuzzer corpus directories.
"""

from __future__ import annotations

import argparse
import atexit
import os
import sys
import tempfile
import traceback
import warnings
from pathlib import Path

import atheris

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

with atheris.instrument_imports():
    import fvf.io
    from fvf.diagnostics import mesh_report
    from fvf.errors import FvfError
    from fvf.repair import repair_mesh

SUFFIXES = [".obj", ".off", ".ply"]
COUNTS = {"runs": 0, "loaded": 0, "fvf_errors": 0, "repair_errors": 0, "findings": 0}


def seeds() -> list[bytes]:
    """Seed inputs: selector byte + file bytes."""
    from test_io import ASCII_PLY, FUZZ_BASES, binary_ply

    out = []
    for name, data in FUZZ_BASES.items():
        out.append(bytes([SUFFIXES.index(Path(name).suffix.lower())]) + data)
    out.append(b"\x02" + ASCII_PLY.encode())
    out.append(b"\x02" + binary_ply(">", [[0, 1, 2], [0, 2, 3], [4, 0, 1]], "int", "uint"))
    out.append(b"\x02" + binary_ply("<", [[0, 1, 2, 3], [4, 0, 1]], "ushort", "short"))
    out.append(
        b"\x01COFF\r\n3 1 0\r\n0 0 0 1 0 0 1\r\n1 0 0 1 0 0 1\r\n0 1 0 0 0 1 1\r\n3 0 1 2\r\n"
    )
    out.append(b"\x00v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nf 1/1/1 2//1 3 4\nf -1 -2 -3\n")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--findings", default="fuzz_findings", help="directory for findings")
    args, rest = parser.parse_known_args()
    findings = Path(args.findings)
    findings.mkdir(exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="fvf_fuzz_"))
    paths = [work / f"input{s}" for s in SUFFIXES]
    seen: set[str] = set()

    corpus = [a for a in rest if not a.startswith("-")]
    if corpus and not any(any(Path(c).iterdir()) for c in corpus if Path(c).is_dir()):
        for k, s in enumerate(seeds()):
            (Path(corpus[0]) / f"seed{k}").write_bytes(s)

    def one_input(data: bytes) -> None:
        COUNTS["runs"] += 1
        if not data:
            return
        path = paths[data[0] % 3]
        path.write_bytes(data[1:])

        def finding(exc: BaseException) -> None:
            COUNTS["findings"] += 1
            where = traceback.extract_tb(exc.__traceback__)[-1]
            key = f"{type(exc).__name__}:{Path(where.filename).name}:{where.lineno}"
            if key not in seen:
                seen.add(key)
                stem = findings / f"finding{len(seen)}{path.suffix}"
                stem.write_bytes(data[1:])
                stem.with_suffix(".txt").write_text(traceback.format_exc())

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                V, F = fvf.io.read_mesh(path)
                if path.suffix == ".ply":
                    vprops, fprops = fvf.io.read_ply_properties(path)
                    if any(len(a) != len(V) for a in vprops.values()) or any(
                        len(a) != len(F) for a in fprops.values()
                    ):
                        raise AssertionError("read_ply_properties: arrays not aligned")
        except FvfError:
            COUNTS["fvf_errors"] += 1
            return
        except Exception as exc:  # noqa: BLE001 - a finding, recorded and counted
            finding(exc)
            return
        COUNTS["loaded"] += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mesh_report(V, F)
                try:
                    repair_mesh(V, F)
                except FvfError:
                    COUNTS["repair_errors"] += 1
        except Exception as exc:  # noqa: BLE001
            finding(exc)
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
            COUNTS["findings"] += 1
            (findings / f"contract{COUNTS['findings']}{path.suffix}").write_bytes(data[1:])

    def summary() -> None:
        print(f"\nfvf fuzz summary: {COUNTS} distinct findings: {sorted(seen)}", flush=True)
        for p in paths:
            p.unlink(missing_ok=True)
        os.rmdir(work)

    atexit.register(summary)
    atheris.Setup([sys.argv[0], *rest], one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
