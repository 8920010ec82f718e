"""The `odms-data` command line: a thin click layer over the library.

Every command's errors go through `OdmsGroup.invoke`: the project's own exceptions (and OS
errors such as a full disk) become one line on stderr and exit code 2, never a traceback.
Set ODMS_DEBUG=1 to see the traceback of an unexpected error.
"""

from __future__ import annotations

import difflib
import os
from importlib import import_module

import click

from .._version import __version__
from ..errors import OdmsError


def one_line(message: object) -> str:
    return " ".join(str(message).split())


COMMANDS = {  # command name -> (module of this package, attribute): imported only when used
    "generate": ("generate_command", "generate"),
    "import": ("import_commands", "import_group"),
    "validate": ("store_commands", "validate"),
    "info": ("store_commands", "info"),
    "convert": ("store_commands", "convert"),
    "export": ("export_command", "export"),
    "show": ("store_commands", "show"),
    "score": ("score_commands", "score"),
    "baseline": ("score_commands", "baseline"),
    "leaderboard": ("score_commands", "leaderboard"),
    "train": ("network_commands", "train"),
    "predict": ("network_commands", "predict"),
}


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

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.Abort):
            raise
        except (OdmsError, OSError) as e:
            click.echo(f"odms-data: error: {one_line(e)}", err=True)
            ctx.exit(2)
        except KeyboardInterrupt:
            click.echo("odms-data: interrupted; nothing was left half-written", err=True)
            ctx.exit(130)
        except Exception as e:
            if os.environ.get("ODMS_DEBUG"):
                raise
            click.echo(
                f"odms-data: internal error: {type(e).__name__}: {one_line(e)} "
                "(please report it; ODMS_DEBUG=1 shows the traceback)",
                err=True,
            )
            ctx.exit(3)


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
                   default ~/.cache/odms-data)
      ODMS_DEBUG   set to 1 to see the traceback of an unexpected error
      ODMS_SHARED  the shared/ folder holding data/odms-v1.tar.gz, for the tests that
                   need the official data (default: ../shared beside the project)

    \b
    Shell completion (bash; zsh and fish alike, with zsh_source / fish_source):
      eval "$(_ODMS_DATA_COMPLETE=bash_source odms-data)"
    """
