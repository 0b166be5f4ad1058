"""The front door of ``fvf``: ``--version``, a reader that leaves the pipe early, and the
examples of ``fvf COMMAND --help`` run as written."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import fvf
from fvf.cli.main import main
from fvf.mesh.builtin import spot_path

SRC = str(Path(fvf.__file__).resolve().parents[1])


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([SRC, env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"fvf {fvf.__version__}"


def test_version_subprocess():
    out = subprocess.run(
        [sys.executable, "-m", "fvf", "--version"], capture_output=True, text=True, env=_env()
    )
    assert out.returncode == 0 and out.stdout == f"fvf {fvf.__version__}\n", out


@pytest.mark.parametrize(
    "command", [["info", "SPOT"], ["info", "SPOT", "--json"], ["--help"], ["info", "--help"]]
)
def test_reader_leaving_after_one_line_is_not_an_error(command):
    """``fvf info MESH | head -1``: exit status 0 and nothing on stderr."""
    argv = [sys.executable, "-m", "fvf", *[str(spot_path()) if a == "SPOT" else a for a in command]]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env())
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()
    proc.stdout.close()
    status, err = proc.wait(timeout=120), proc.stderr.read().decode()
    proc.stderr.close()
    assert first and status == 0 and err == "", (status, err)


def test_closed_stdout_before_any_output(tmp_path):
    """The pipe is closed before the command prints: it still runs to the end, writes
    its output file, exits 0 and says nothing about the pipe."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    mesh = tmp_path / "m.obj"
    V, F = fvf.read_mesh(spot_path())
    fvf.write_mesh(mesh, V, F)
    repaired = tmp_path / "fixed.obj"
    try:
        runs = [
            subprocess.run(
                [sys.executable, "-m", "fvf", *args],
                stdout=write_end,
                stderr=subprocess.PIPE,
                env=_env(),
                timeout=300,
            )
            for args in (["info", str(mesh)], ["repair", str(mesh), "-o", str(repaired)])
        ]
    finally:
        os.close(write_end)
    for run in runs:
        assert run.returncode == 0 and run.stderr == b"", run
    assert repaired.is_file()
