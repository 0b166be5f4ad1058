"""The ``fvf`` command: the chapter's operations on your meshes, from the shell.

It contains no math: every number comes from a library call. Meshes are OBJ, OFF,
PLY, STL, VTK or glTF files; functions and fields are read from and written to ``.npz``
data files whose keys are documented in :mod:`fvf.io.datafile` and ``docs/cli.md``
(``f`` vertex functions, ``v`` and ``u`` per-face fields, ``t`` times, ...).

Each subcommand is one module of :mod:`fvf.cli.commands` registering itself
(:func:`fvf.cli.registry.register_command`: its name, help, arguments and handler); what
they share (exit codes, option types, reading inputs, checking and writing outputs) is
:mod:`fvf.cli.common`. This module builds the parser from the registry, runs the handler
and maps its errors to exit statuses.

Exit status: 0 success; 1 ``fvf info`` found problems in the mesh, or ``fvf batch``
finished with failed meshes; 2 bad input (a missing
or unreadable file, an invalid mesh, wrong data keys or shapes, bad options, an output
that is an input); 3 a feature unavailable here (``fvf.viz`` or its ``[viz]`` extra
missing, no display for ``view``); 4 the computation failed (e.g. a flow overflowed, out
of memory); 5 an output could not be written (disk full, file size limit); 6 a flow grew
beyond ``--growth-limit`` (the output is written); 130 / 143
interrupted (SIGINT / SIGTERM). Errors are one line on stderr, ``fvf: error: <cause>``
(the lines of a longer message as clauses separated by ``"; "``);
``--debug`` shows the traceback instead. Warnings (fvf's :class:`~fvf.errors.FvfWarning`)
are one line each, ``fvf: warning: <cause>``.

Files (``docs/files.md``): every output is written whole or not at all (a temporary file
beside it, renamed when complete), and no command writes onto one of its inputs (also
through a link) unless given ``--force``.
"""

from __future__ import annotations

import argparse
import atexit
import errno
import os
import re
import shlex
import signal
import sys
import threading
import warnings
from typing import Any, NoReturn

from .commands.info import info
from .common import (
    EXIT_BAD_INPUT,
    EXIT_FAILED,
    EXIT_GREW,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_PROBLEMS,
    EXIT_TERMINATED,
    EXIT_UNAVAILABLE,
    EXIT_WRITE_FAILED,
    Unavailable,
)
from .registry import Command, registered_commands

__all__ = [
    "main",
    "parser",
    "info",
    "Unavailable",
    "EXIT_OK",
    "EXIT_PROBLEMS",
    "EXIT_BAD_INPUT",
    "EXIT_UNAVAILABLE",
    "EXIT_FAILED",
    "EXIT_GREW",
    "EXIT_WRITE_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
]

_EXIT_TEXT = """exit status: 0 success, 1 `fvf info` found problems, `fvf batch` had failed
meshes or `fvf demo` failed checks, 2 bad input,
3 feature unavailable (fvf.viz / [viz] extra / display), 4 computation failed,
5 output not written (disk full...), 6 the result grew beyond --growth-limit (written;
--growth-limit inf accepts it), 130/143 interrupted.
Outputs are written whole or not at all, never onto an input (unless --force).
Data files: .npz with keys f (n,)|(n,k), v (m,3), u (m,3), u1 (m,3), t (T,); see docs/cli.md.
A key option can name another file: --field designed.npz:v. -o *.ply/.vtp/.vtu writes the
results as mesh properties (ParaView, MeshLab); a .ply output is a valid fvf input."""


_DEBUG = "show the traceback of an error instead of one line"


def _version() -> str:
    from fvf._version import __version__

    return __version__


class _Terminated(BaseException):
    """SIGTERM, raised in the main thread so that outputs being written are cleaned up."""


#: What counts as a negative number after an option (argparse's own pattern takes -1 and
#: -.5 but not -1e-3 or -inf, which it reads as unknown options: ``--clim -1e-3 1e-3``
#: failed with "expected 2 arguments").
NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)(e[-+]?\d+)?$|^-(inf|infinity|nan)$", re.I)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit status 2) that reads -1e-3 and -inf as
    values (:data:`NEGATIVE_NUMBER`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# ---------------------------------------------------------------------------- parser
def _add(sub: Any, command: Command) -> argparse.ArgumentParser:
    """The subparser of a registered command: its help, example and exit statuses, and
    ``--debug`` after the command too."""
    p = sub.add_parser(
        command.name,
        help=command.help,
        description=command.help,
        epilog=f"example:\n  {command.example_text()}\n\n{_EXIT_TEXT}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    # --debug after the command too (SUPPRESS keeps the top-level value when absent)
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=_DEBUG)
    command.arguments(p)
    p.set_defaults(run=command.run)
    return p


def parser() -> argparse.ArgumentParser:
    """The argument parser of the ``fvf`` command: one subparser per registered command
    (:func:`fvf.cli.registry.registered_commands`)."""
    top = _Parser(
        prog="fvf",
        description="Operator-based tangent vector fields on your meshes (fvf "
        f"{_version()}): run `fvf COMMAND --help` for a command's options and an example.",
        epilog="examples:\n  fvf demo --out results/\n  fvf info bunny.off\n"
        f"  fvf flow bunny.off fields.npz --t 0 1 -o flowed.npz\n\n{_EXIT_TEXT}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    top.add_argument("--debug", action="store_true", help=_DEBUG)
    top.add_argument(
        "--version", action="version", version=f"fvf {_version()}", help="print fvf X.Y.Z"
    )
    sub = top.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in registered_commands().values():
        _add(sub, command)
    return top


# ---------------------------------------------------------------------------- main
def _one_line(exc: BaseException) -> str:
    from fvf.errors import thread_limit_text

    if thread_limit_text(exc):
        return str(thread_limit_text(exc))
    if isinstance(exc, OSError) and exc.filename is not None and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}"
    else:
        text = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
        text = f"{type(exc).__name__}: {text}" if type(exc).__module__.startswith("fvf") else text
    lines = [" ".join(line.split()) for line in text.splitlines()]
    out = ""
    for line in filter(None, lines):  # a multi-line message's lines (one per attempt) as clauses
        out += line if not out else ("; " if out[-1] not in ":.;" else " ") + line
    return out or type(exc).__name__


#: Python spellings in the library's messages and the options that say the same, with the
#: ``args`` attribute a command has when it takes that option (None: no command does); a
#: command without it gets the clause left out (``fvf transport`` has no ``--method``).
_CLI_SPELLINGS = (
    (
        r"pass growth_limit=np\.inf to (accept it|silence this)",
        "pass --growth-limit inf to accept it",
        "growth_limit",
    ),
    (r"growth_limit=np\.inf", "--growth-limit inf", "growth_limit"),
    (r"method='upwind'", "--method upwind", "method"),
    (r"raise max_products", "", None),
    (r" ?\(and pass progress= to follow it\)", "", None),
)


def _cli_words(text: str, args: argparse.Namespace | None = None) -> str:
    """A library message in the command's words: its options, not Python keywords, and
    no clause naming an option the command does not take."""
    for python, cli, attr in _CLI_SPELLINGS:
        if args is not None and attr is not None and hasattr(args, attr):
            text = re.sub(python, cli, text)
            continue
        clause = r"(,? (or |and )?(use |pass )?)" + python + r"( \([^)]*\))?"
        text = re.sub(clause, "", text)
    return re.sub(r";(\s*;)+", ";", re.sub(r",(\s*[.;])", r"\1", text))


def _show_warning(message, category, filename, lineno, file=None, line=None):
    from fvf.errors import FlowGrowthWarning

    if issubclass(category, FlowGrowthWarning):
        _GREW.append(str(message))
    words = _cli_words(" ".join(str(message).split()), _ARGS[-1] if _ARGS else None)
    text = f"fvf: warning: {category.__name__}: {words}"
    if text not in _SHOWN:  # once per distinct message, wherever it was raised
        _SHOWN.add(text)
        print(text, file=sys.stderr)


_SHOWN: set[str] = set()
_GREW: list[str] = []
_ARGS: list[argparse.Namespace] = []  # the command running (its options name the advice)


def main(argv: list[str] | None = None) -> int:
    """Run the ``fvf`` command with ``argv`` (default ``sys.argv[1:]``); return the exit status.

    Exit status: :data:`EXIT_OK` (0), :data:`EXIT_PROBLEMS` (1, ``info`` found problems,
    ``demo`` failed checks), :data:`EXIT_BAD_INPUT` (2), :data:`EXIT_UNAVAILABLE` (3),
    :data:`EXIT_FAILED` (4),
    :data:`EXIT_WRITE_FAILED` (5), :data:`EXIT_GREW` (6, a flow grew beyond
    ``--growth-limit``; the output was written), :data:`EXIT_INTERRUPTED` (130),
    :data:`EXIT_TERMINATED` (143).

    A reader of the standard output that leaves early (``fvf info MESH | head -1``) is not
    an error: what is printed after it left is dropped, the command runs on (its output
    files are written) and the exit status is the command's own.
    """
    command = argv is None  # the process is the command (not a call from Python)
    argv = list(sys.argv[1:] if argv is None else argv)
    with _ClosedPipeQuiet():
        status = _run(argv, command)
    if command and status == EXIT_INTERRUPTED:
        _exit_on_next_interrupt()
    return status


def _exit_on_next_interrupt() -> None:
    """After an interrupted command has cleaned up, a further Ctrl-C ends the process at
    once with :data:`EXIT_INTERRUPTED`: the interpreter's shutdown (a Dask cluster closing
    in its ``atexit`` hooks) would otherwise print a traceback for each one. After the
    exit hooks, SIGINT is ignored (:func:`_ignore_interrupts_at_exit`)."""
    if threading.current_thread() is not threading.main_thread():
        return

    def exit_now(signum: int, frame: Any) -> None:
        os._exit(EXIT_INTERRUPTED)

    signal.signal(signal.SIGINT, exit_now)
    _QUIET_EXIT.append(True)


_QUIET_EXIT: list[bool] = []


@atexit.register  # at import, before the libraries a command loads: so it runs after theirs
def _ignore_interrupts_at_exit() -> None:
    """The last exit hook of an interrupted command: SIGINT ignored from here on. The
    interpreter then resets every Python-level handler (``exit_now`` included) to the
    system default before tearing its modules down, which takes a while with Dask
    loaded; a Ctrl-C then would kill the process by SIGINT instead of exit status 130.
    An ignored signal stays ignored."""
    if _QUIET_EXIT and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run(argv: list[str], command: bool = False) -> int:
    """:func:`main` with ``sys.stdout`` guarded against a reader that left; ``command``:
    the process ends with the command (``args.own_process``)."""
    import numpy as np

    try:
        args = parser().parse_args(argv)
    except SystemExit as exc:  # --help, --version (0) or a usage error (2), already printed
        return int(exc.code or 0)
    args.command_line = shlex.join(["fvf", *argv])
    args.force = getattr(args, "force", False)
    args.own_process = command
    _SHOWN.clear()
    _GREW.clear()
    _ARGS[:] = [args]
    from fvf.errors import OutputWriteError

    with warnings.catch_warnings(), _terminate_cleanly():
        warnings.simplefilter("default")
        warnings.showwarning = _show_warning
        try:
            status = args.run(args)
            if status == EXIT_OK and _GREW:
                upwind = "--method upwind (bounded on every mesh, with or without boundary), "
                print(
                    "fvf: error: the result grew beyond its limit (see the warning); it was "
                    "written, but do not trust it: use "
                    + (upwind if hasattr(args, "method") else "")
                    + "shorter times"
                    + (
                        ", or pass --growth-limit inf to accept it"
                        if hasattr(args, "growth_limit")
                        else ""
                    ),
                    file=sys.stderr,
                )
                return EXIT_GREW
            return status
        except Exception as exc:
            if args.debug:
                raise
            if isinstance(exc, OutputWriteError):
                status = EXIT_WRITE_FAILED
            elif isinstance(exc, (Unavailable, ImportError)):
                status = EXIT_UNAVAILABLE
            elif isinstance(exc, (FloatingPointError, np.linalg.LinAlgError, RuntimeError)):
                status = EXIT_FAILED
            elif isinstance(exc, MemoryError):
                exc = MemoryError(
                    f"out of memory ({exc or 'allocation failed'}); use a smaller "
                    "mesh, fewer times or fewer functions"
                )
                status = EXIT_FAILED
            elif isinstance(exc, (ValueError, OSError, KeyError)):
                status = EXIT_BAD_INPUT
            else:
                raise
            print(f"fvf: error: {_cli_words(_one_line(exc), args)}", file=sys.stderr)
            return status
        except KeyboardInterrupt:
            print("fvf: interrupted; no output was half-written", file=sys.stderr)
            return EXIT_INTERRUPTED
        except _Terminated:
            print("fvf: terminated; no output was half-written", file=sys.stderr)
            return EXIT_TERMINATED


class _ClosedPipeQuiet:
    """While the command runs, ``sys.stdout`` and ``sys.stderr`` drop what they are given
    once their reader has closed the pipe or the device is full (:class:`_PipeWriter`:
    ``fvf quad … 2>&1 | head -1`` still writes its mesh, ``fvf repair … >/dev/full`` its
    files, with the exit status of the work); on leaving, the rest is flushed (or
    dropped) so that the interpreter's last flush finds nothing to complain about."""

    def __enter__(self):
        self.previous = sys.stdout, sys.stderr
        if sys.stdout is not None:
            sys.stdout = _PipeWriter(sys.stdout)
        if sys.stderr is not None:
            sys.stderr = _PipeWriter(sys.stderr)
        return self

    def __exit__(self, *exc):
        writers = sys.stdout, sys.stderr
        sys.stdout, sys.stderr = self.previous
        for writer in writers:
            if isinstance(writer, _PipeWriter):
                writer.flush()
        return False


#: errno values of a standard stream whose reader is gone or whose device is full: the
#: command's messages are lost, its work and its files are not.
_STREAM_GONE = {errno.EPIPE, errno.ENOSPC, errno.EIO}


class _PipeWriter:
    """A text stream over ``stream`` for which a closed pipe (:class:`BrokenPipeError`)
    or a full device (``ENOSPC``, ``EIO``) is the end of the output, not an error: the
    file descriptor is pointed at the null device and further text is dropped."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self.reader_left = False

    def write(self, text: str) -> int:
        if not self.reader_left:
            try:
                return self._stream.write(text)
            except OSError as exc:
                if exc.errno not in _STREAM_GONE:
                    raise
                self._left()
        return len(text)

    def flush(self) -> None:
        if not self.reader_left:
            try:
                self._stream.flush()
            except OSError as exc:
                if exc.errno not in _STREAM_GONE:
                    raise
                self._left()

    def _left(self) -> None:
        self.reader_left = True
        try:  # the stream's own buffer is flushed again at exit: into the null device
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self._stream.fileno())
            os.close(null)
        except (OSError, ValueError, AttributeError):  # not a file (a test's capture)
            pass

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


class _terminate_cleanly:
    """While a command runs in the main thread, SIGTERM raises :class:`_Terminated` (so
    the temporary file of an output being written is removed) instead of killing the
    process outright; the previous handler is restored afterwards."""

    def __enter__(self):
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGTERM, self._raise)
        return self

    @staticmethod
    def _raise(signum, frame):
        raise _Terminated()

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGTERM, self.previous)
        return False


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
