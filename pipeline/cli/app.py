"""The ``skatelib`` command line: the app, its commands (:mod:`.build_commands`,
:mod:`.library_commands`, :mod:`.track_commands`) and the entry point that turns errors into messages and exit codes."""

from __future__ import annotations

import logging
import re
import warnings
from typing import Annotated, Any

import typer
from rich.markup import escape
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.build import interrupt
from skatelib.pipeline.cli import (
    build_commands,
    certify_commands,
    diff_commands,
    frontier_commands,
    library_commands,
    track_commands,
)
from skatelib.pipeline.views.console import console, err_console
from typer._click.core import Context
from typer.core import TyperArgument, TyperCommand, TyperOption


def _plain_metavar(option: TyperOption, command: TyperCommand) -> str | None:
    """What an option's help shows for its value, without Python's type names: ``<float>`` for a
    number in a range (the range is printed beside it), ``<str>`` for a repeatable option (its help
    says it repeats), ``<a|b>`` for choices; None keeps typer's."""
    shown = option.display_type(typer.Context(command))
    plain = shown.replace(" range>", ">")
    if plain.startswith("<list[") and plain.endswith("]>"):
        plain = "<" + plain[len("<list["):-len("]>")] + ">"
    return plain if plain != shown else None


# Each command's line in ``skatelib --help`` (click cuts a summary it makes itself at about 45 characters).
SUMMARIES = {
    "model": "Print the robot and board model of a config (or write the twin).",
    "build": "Build a motion library: speeds x stride counts, in parallel.",
    "frontier": "The fastest label that converges, per stride count.",
    "solve": "Solve one push-off and write it as a one-entry library.",
    "info": "Summarize a motion library: provenance, model and entries.",
    "validate": "Re-check a library: checksum, fields and every entry's physics.",
    "inspect": "Look at trajectories in Rerun: robot, board, forces, margins.",
    "plot": "Figures of a library (matplotlib).",
    "diff": "What changed between two libraries, channel by channel.",
    "export": "Write a library as npz, csv or an MCAP ROS 2 bag.",
    "track": "Ride the entries in closed loop on the model plant or the twin.",
    "certify": "Ride each entry N times on the twin under drawn errors and shoves.",
}


def _plain_help(text: str) -> str:
    """Help as a terminal shows it: reStructuredText's ``literal`` quotes become 'literal'."""
    return re.sub(r"``([^`]+)``", r"'\1'", text)


class _Command(TyperCommand):
    """A command whose help names values as a user reads them (see :func:`_plain_metavar`), whose
    usage line names its arguments as Unix tools do (``LIBRARY``, ``[CONFIG]``) and whose summary in
    the program's help is not cut."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        for param in self.params:
            if isinstance(param, TyperOption) and param.metavar is None:
                param.metavar = _plain_metavar(param, self)
        if self.help:
            self.help = _plain_help(self.help)
        for param in self.params:
            if isinstance(param, (TyperOption, TyperArgument)) and param.help:
                param.help = _plain_help(param.help)
        if self.short_help is None and self.name in SUMMARIES:
            self.short_help = SUMMARIES[self.name]

    def collect_usage_pieces(self, ctx: Context) -> list[str]:
        pieces = [self.options_metavar] if self.options_metavar else []
        for param in self.get_params(ctx):
            if isinstance(param, TyperArgument):
                name = (param.metavar or param.name or "").upper() + ("..." if param.nargs != 1 else "")
                pieces.append(name if param.required else f"[{name}]")
            else:
                pieces.extend(param.get_usage_pieces(ctx))
        return pieces


app = typer.Typer(add_completion=True, no_args_is_help=True, rich_markup_mode=None,
                  context_settings={"help_option_names": ["-h", "--help"]},
                  help="Offline motion-library pipeline for legged robots on skateboards.")
for _command in (*build_commands.COMMANDS, *frontier_commands.COMMANDS, *library_commands.COMMANDS,
                 *diff_commands.COMMANDS, *track_commands.COMMANDS, *certify_commands.COMMANDS):
    app.command(cls=_Command)(_command)

__all__ = ["app", "main"]

# The import names of the optional packages -> the extra that brings each (pyproject.toml; a test
# holds the two equal), so that every missing package is reported with what to install.
EXTRA_OF = {"rerun": "viz", "matplotlib": "plot", "daqp": "control", "proxsuite": "control", "osqp": "control",
            "threadpoolctl": "control", "mujoco": "sim", "PIL": "video", "imageio_ffmpeg": "video",
            "distributed": "dask", "dask": "dask", "mcap_ros2": "export"}


def install_hint(error: ImportError) -> str:
    """The message for a missing package: its own words, and the extra to install when they do not
    name one already."""
    text = str(error)
    if "skatelib[" in text:
        return text
    extra = EXTRA_OF.get((error.name or "").split(".")[0])
    if extra is None:
        return f"{text}; `make venv` (or pip install 'skatelib[build,viz,plot,control,sim,video]') installs every extra"
    return f"{text}; pip install 'skatelib[{extra}]'"


def _print_version(value: bool) -> None:
    if value:
        from importlib import metadata

        console.print(f"skatelib {metadata.version('skatelib')}")
        raise typer.Exit()


def _root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
) -> None:
    """Offline motion-library pipeline for legged robots on skateboards.

    Exit codes: 0 ok, 1 entries failed, 2 usage/config/output error, 3 bad library file,
    4 missing optional package, 130 interrupted. Add --debug for a traceback instead of a message.
    """
    interrupt.reset()  # an interrupt of an earlier command in this process is not this one's


app.callback()(_root)


class _ConsoleLine(logging.Handler):
    """Prints the pipeline's one-line notices (``skatelib.compile``: stage functions being compiled)."""

    def emit(self, record: logging.LogRecord) -> None:
        console.print(escape(record.getMessage()))


def _warning_line(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """A warning as one line on stderr (a library of another minor format version, a cache note),
    not Python's source excerpt."""
    err_console.print(f"[yellow]warning:[/] {escape(str(message))}")


def main() -> None:
    """Entry point: errors become a one-paragraph message on stderr and a documented exit code
    (README "Exit codes"), not a traceback; ``--debug`` anywhere on the line shows the traceback."""
    import sys

    from skatelib.library.errors import EXIT_INTERRUPTED, exit_code

    debug = "--debug" in sys.argv
    if debug:
        sys.argv.remove("--debug")
    interrupt.install()  # Ctrl-C and SIGTERM stop a solve in this process even when CasADi swallows them
    warnings.showwarning = _warning_line
    notices = logging.getLogger("skatelib.compile")  # a line when (only when) code is compiled
    notices.addHandler(_ConsoleLine())
    notices.setLevel(logging.INFO)
    try:
        app()
    except SystemExit as e:
        if e.code == EXIT_INTERRUPTED:  # typer's answer to Ctrl-C in a command that does not say more
            err_console.print("interrupted")
        raise
    except (SkatelibError, ImportError) as e:
        if debug:
            raise
        text = install_hint(e) if isinstance(e, ImportError) else str(e)
        err_console.print(f"[bold red]error:[/] {escape(text)}")
        raise SystemExit(exit_code(e)) from None
