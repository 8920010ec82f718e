"""The `odms-data` command line: a thin click layer over the library.

Every error the user sees is one line `odms-data: error: ...` on stderr with exit code 2, never a
traceback: the project's own exceptions and OS errors (`OdmsGroup.invoke`) and click's usage
errors alike (`OdmsGroup.main`). SIGTERM and SIGHUP stop a command the way Ctrl-C does: what it
was writing is removed, and the exit code is 128 + the signal's number (130 for Ctrl-C).
Set ODMS_DEBUG=1 to see the traceback of an unexpected error (exit code 3).
"""

from __future__ import annotations

import difflib
import json
import math
import os
import signal
import sys
from importlib import import_module
from typing import Any, NoReturn

import click

from .._version import __version__
from ..errors import OdmsError
from ..interrupts import stop_signal, stops_interrupt
from ..parallel import commands_use_one_opencv_thread, safe_children
from ..shown_text import for_terminal
from ..urls import refuse_transient


def one_line(message: object) -> str:
    """`message` on one line, safe to print (names and ids in it may come from data)."""
    return for_terminal(" ".join(str(message).split()))


def echo_text(text: str, *, err: bool = False, nl: bool = True) -> None:
    """Print text that holds names, ids or sources from data, its line breaks kept and each line
    made safe for the terminal (shown_text.for_terminal)."""
    click.echo("\n".join(map(for_terminal, text.split("\n"))), err=err, nl=nl)


def echo_json(value: Any) -> None:
    """Print `value` as JSON that every parser reads: a non-finite number becomes null."""

    def finite(v: Any) -> Any:
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: finite(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [finite(x) for x in v]
        return v

    click.echo(json.dumps(finite(value), indent=2, allow_nan=False))


COMMANDS = {  # command name -> (module of this package, attribute): imported only when used
    "generate": ("generate_command", "generate"),
    "import": ("import_commands", "import_group"),
    "validate": ("store_commands", "validate"),
    "info": ("store_commands", "info"),
    "convert": ("store_commands", "convert"),
    "export": ("export_command", "export"),
    "show": ("store_commands", "show"),
    "score": ("score_commands", "score"),
    "compare": ("score_commands", "compare"),
    "baseline": ("score_commands", "baseline"),
    "estimate": ("estimate_command", "estimate"),
    "leaderboard": ("leaderboard_commands", "leaderboard"),
    "train": ("network_commands", "train"),
    "predict": ("network_commands", "predict"),
}


def _printable_anywhere() -> None:
    """A character the terminal's encoding lacks (an en dash on a Latin-1 terminal) is printed as
    an escape instead of failing the command."""
    for stream in (sys.stdout, sys.stderr):
        if hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")


def _usage_line(e: click.ClickException) -> str:
    ctx = getattr(e, "ctx", None)
    where = f"; see '{ctx.command_path} --help'" if ctx is not None else ""
    return f"odms-data: error: {one_line(e.format_message()).rstrip('.')}{where}"


def _is_location(param: click.Parameter) -> bool:
    """Whether `param` names a place (a path, a store, a URL or an address), not a text."""
    return isinstance(param.type, click.Path) or param.metavar in ("ADDRESS", "URL")


def _locations(group: click.Group, ctx: click.Context, args: list[str]) -> list[str]:
    """The values of `args` (the whole command line after `odms-data`) that may name a place: those
    of path, URL and address options and every positional one, not those of text, number or choice
    options (a --name holding '://' is a name)."""
    options: dict[str, click.Option] = {}
    command: click.Command = group
    options.update({o: p for p in group.params if isinstance(p, click.Option) for o in p.opts})
    out, rest = [], iter(args)
    for arg in rest:
        sub = command.get_command(ctx, arg) if isinstance(command, click.Group) else None
        if sub is not None:  # a subcommand's name: its options from here on
            command = sub
            options.update({o: p for p in sub.params if isinstance(p, click.Option) for o in p.opts})
            continue
        flag, eq, value = arg.partition("=")
        option = options.get(flag if arg.startswith("--") else arg)
        if option is None:
            out.append(value if eq and arg.startswith("--") else arg)
        elif eq and arg.startswith("--"):
            out += [value] if _is_location(option) else []
        elif not (option.is_flag or option.count):
            values = [next(rest, "") for _ in range(max(option.nargs, 1))]
            out += values if _is_location(option) else []
    return out


class OdmsGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def resolve_command(self, ctx: click.Context, args: list[str]):
        name = args[0] if args else ""
        if name and not name.startswith("-") and name not in COMMANDS:
            close = difflib.get_close_matches(name, COMMANDS, n=1)
            if close:
                ctx.fail(f"No such command '{name}'. Did you mean '{close[0]}'?")
        return super().resolve_command(ctx, args)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in COMMANDS:
            return None
        module, attribute = COMMANDS[name]
        return getattr(import_module(f".{module}", __name__), attribute)

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        _printable_anywhere()
        safe_children()
        commands_use_one_opencv_thread()
        with stops_interrupt():
            try:
                code = super().main(args, prog_name, complete_var, False, **extra)
            except click.exceptions.NoArgsIsHelpError as e:  # a bare `odms-data`: its help
                click.echo(e.ctx.get_help())
                code = 0
            except click.ClickException as e:  # usage errors: bad options, values, missing arguments
                click.echo(_usage_line(e), err=True)
                code = 2
            except click.Abort as e:  # an interrupt while click itself was busy (a prompt, parsing)
                signum = stop_signal(e) or signal.SIGINT
                click.echo(f"odms-data: interrupted ({signal.Signals(signum).name})", err=True)
                code = 128 + signum
        sys.exit(code if isinstance(code, int) else 0)

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        ctx.meta["arguments"] = list(args)  # every argument of the command, for `invoke`
        return super().parse_args(ctx, args)

    def invoke(self, ctx: click.Context):
        try:
            for value in _locations(self, ctx, ctx.meta["arguments"]):
                refuse_transient(value)
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.Abort):
            raise
        except BrokenPipeError:  # stdout's reader went away (`| head`): stop as a Unix tool does, quietly
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # nothing left to flush at exit
            ctx.exit(128 + signal.SIGPIPE)
        except (OdmsError, OSError) as e:
            from .fixes import with_fix

            click.echo(f"odms-data: error: {one_line(with_fix(e))}", err=True)
            ctx.exit(2)
        except KeyboardInterrupt as e:
            _interrupted(ctx, stop_signal(e) or signal.SIGINT)
        except Exception as e:
            if (signum := stop_signal(e)) is not None:  # a stop a C extension returned as another error
                _interrupted(ctx, signum)
            if os.environ.get("ODMS_DEBUG"):
                raise
            click.echo(
                f"odms-data: internal error: {type(e).__name__}: {one_line(e)} "
                "(please report it; ODMS_DEBUG=1 shows the traceback)",
                err=True,
            )
            ctx.exit(3)


def _interrupted(ctx: click.Context, signum: int) -> NoReturn:
    click.echo(f"odms-data: interrupted ({signal.Signals(signum).name}); nothing was left half-written",
               err=True)
    ctx.exit(128 + signum)


@click.group(cls=OdmsGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="odms-data")
def main() -> None:
    """Generate, store, import and score ODMS (object depth from motion and segmentation) data.

    \b
    Example:
      odms-data generate --split sim-val -o sim-val.zarr
      odms-data info sim-val.zarr

    \b
    Environment:
      ODMS_DATA    folders of ground-truth stores for score and baseline (':'-separated;
                   default $XDG_CACHE_HOME/odms-data, else ~/.cache/odms-data)
      ODMS_DEBUG   set to 1 to see the traceback of an unexpected error
      ODMS_SHARED  the shared/ folder holding data/odms-v1.tar.gz, for the tests that
                   need the official data (default: ../shared beside the project)

    \b
    Shell completion (bash; zsh and fish alike, with zsh_source / fish_source):
      eval "$(_ODMS_DATA_COMPLETE=bash_source odms-data)"
    """
