"""The command registry of ``fvf``: one registered handler per subcommand.

A command is a module of :mod:`fvf.cli.commands` with a function adding its arguments to
its subparser and a handler returning the exit status; registering it is one decorated
function::

    from fvf.cli.common import EXIT_OK, MESH_FILE, add_output
    from fvf.cli.registry import register_command


    def _arguments(p):
        p.add_argument("mesh", help=MESH_FILE)
        add_output(p, "output .npz")


    @register_command(
        "area",
        help="total surface area of a mesh",
        example="fvf area mesh.obj -o area.npz",
        arguments=_arguments,
    )
    def run(args):
        ...
        return EXIT_OK

The example runs as written: each of its lines whose first word is ``fvf`` is a command
line (text after three spaces is a comment; `` [...]`` marks optional arguments), and
``tests/cli/test_cli_front.py`` runs every one of them on meshes and data files of the names
it uses.

``fvf --help`` lists the commands in registration order: the order in which
:mod:`fvf.cli.commands` imports its modules. The parser itself (help layout, ``--debug``,
the exit-status epilog) is built by :func:`fvf.cli.main.parser`.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["Command", "register_command", "registered_commands"]


@dataclass(frozen=True)
class Command:
    """A registered subcommand of ``fvf``.

    Attributes
    ----------
    name : str
        What the shell calls it: ``fvf NAME``.
    help : str
        One line for ``fvf --help``, also the description of ``fvf NAME --help``.
    example : str or callable
        The example of ``fvf NAME --help`` (lines after the first indented by the caller),
        or a function returning it when it is built from other registries (``fvf batch``
        lists the batch tasks).
    arguments : callable
        ``arguments(parser)`` adds the command's arguments to its subparser.
    run : callable
        ``run(args) -> int``: the handler, returning the exit status; errors it raises are
        mapped to exit statuses by :func:`fvf.cli.main.main`.
    """

    name: str
    help: str
    example: str | Callable[[], str]
    arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]

    def example_text(self) -> str:
        """The example, built now if it is a function."""
        return self.example() if callable(self.example) else self.example


_REGISTRY: dict[str, Command] = {}


def register_command(
    name: str,
    *,
    help: str,
    example: str | Callable[[], str],
    arguments: Callable[[argparse.ArgumentParser], None],
) -> Callable[[Callable[[argparse.Namespace], int]], Callable[[argparse.Namespace], int]]:
    """Decorator: register ``run(args) -> int`` as the handler of ``fvf NAME``.

    Parameters are the attributes of :class:`Command`. Registering a name again replaces
    the earlier command (keeping its place in ``fvf --help``).

    Returns
    -------
    callable
        The decorator; it returns the handler unchanged.
    """

    def decorate(run: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
        _REGISTRY[name] = Command(name, help, example, arguments, run)
        return run

    return decorate


def registered_commands() -> dict[str, Command]:
    """The registered commands by name, in registration order (the built-in commands of
    :mod:`fvf.cli.commands` first)."""
    from . import commands  # noqa: F401  (importing it registers the built-in commands)

    return dict(_REGISTRY)
