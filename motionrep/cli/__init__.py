"""The ``motionrep`` command line: one click group, one module per command.

Each command lives in its own module of this package (``convert``, ``info``, ``compress``, ``decompress``,
``evaluate``, ``merge``, ``bench``, ``render``, ``view``, ``plugins``, ``example``) and is added to the group here with
``add_command``; command modules never import this one (no import circle), and share only
:mod:`motionrep.cli._common`.  Commands parse each option once and pass the resulting objects (a
:class:`~motionrep.pipeline.compress.Pipeline`, open :class:`~motionrep.pipeline.sources.Source` s) to the library; heavy
imports happen inside the commands.

Library errors (:class:`~motionrep.errors.MotionrepError`) and operating-system errors are turned into one-line
messages and exit code 1 here, in one place; ``--debug`` shows the traceback instead.  Bad flags exit with code
2 (click's usage errors).  Ctrl-C, SIGTERM and SIGHUP end every command the same way: temporary files removed,
finished work kept, one line on stderr (``Interrupted (Ctrl-C): ...``) and exit code ``128 + signal``: 130 for
Ctrl-C, 143 for SIGTERM, 129 for SIGHUP (:mod:`motionrep.cli._common`).
"""

from __future__ import annotations

import sys

import click

from .._version import __version__
from .._signals import check as check_interrupted
from ..errors import MotionrepError
from . import bench, compress, convert, decompress, evaluate, example, info, merge, plugins, render, view
from ._common import display_name, flagged, handling_signals, interrupt_line

__all__ = ["cli", "main"]


class _Group(click.Group):
    """Turns motionrep's errors into clean one-line messages (exit 1) unless ``--debug`` is given, which may stand
    anywhere on the line (``motionrep info x.bvh --debug``), not only before the command."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        end = args.index("--") if "--" in args else len(args)
        if "--debug" in args[1:end]:  # hoisted in front of the command, where the group's option is parsed
            args = ["--debug"] + [a for a in args[:end] if a != "--debug"] + args[end:]
        return super().parse_args(ctx, args)

    def invoke(self, ctx: click.Context):
        try:
            with handling_signals():
                try:
                    return super().invoke(ctx)
                except Exception:
                    check_interrupted()  # a library turned the interrupt into another exception: it is the interrupt
                    raise
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM / SIGHUP (Interrupted)
            if ctx.obj and ctx.obj.get("debug"):
                raise
            line, code = interrupt_line(exc)
            click.echo(line, err=True)
            ctx.exit(code)
        except MotionrepError as exc:
            if ctx.obj and ctx.obj.get("debug"):
                raise
            raise click.ClickException(display_name(flagged(exc))) from None
        except BrokenPipeError:  # `motionrep convert walk.bvh - | head`: the reader stopped; stop quietly, exit 0
            _quiet_stdout()  # exit 0: the output was not wanted any more, not an error (scripts with pipefail pass)
            ctx.exit(0)
        except OSError as exc:  # disk full, permission denied... on a path the library did not name
            if ctx.obj and ctx.obj.get("debug"):
                raise
            where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
            raise click.ClickException(display_name(f"{where}{exc.strerror or exc}")) from None


def _quiet_stdout() -> None:
    """Point standard output at /dev/null, so that Python's final flush of a closed pipe says nothing."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no real file descriptor (a test runner's stream)
        pass


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="motionrep")
@click.option("--debug", is_flag=True, help="Show full tracebacks instead of one-line errors (anywhere on the line).")
@click.pass_context
def cli(ctx: click.Context, debug: bool) -> None:
    """motionrep: convert, compress and evaluate skeletal motion capture.

    \b
    Examples:
      motionrep info walk.bvh
      motionrep convert walk.bvh walk.npz
      motionrep convert clips/ database.h5
      motionrep compress walk.bvh -o walk.mrc --max-error 2%
      motionrep decompress walk.mrc -o walk2.bvh
      motionrep evaluate walk.bvh walk2.bvh
      motionrep compress clips/ -o clips.h5 --codec svd --jobs 2 --resume
      motionrep merge part1.h5 part2.h5 -o all.h5
      motionrep view walk.bvh walk.mrc -o walk.html
      motionrep plugins
    """
    ctx.ensure_object(dict)
    ctx.obj["debug"] = debug


for _command in (convert.convert, info.info, compress.compress, decompress.decompress, evaluate.evaluate,
                 merge.merge, bench.bench, render.render, view.view, plugins.plugins_command, example.example):
    cli.add_command(_command)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    cli.main(args=argv, prog_name="motionrep")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
