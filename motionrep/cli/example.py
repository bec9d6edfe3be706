"""``motionrep example``: write the demo clip motionrep ships."""

from __future__ import annotations

import shutil
from pathlib import Path

import click

from ._common import check_outputs, force_option, quiet_option

__all__ = ["example"]


@click.command("example")
@click.argument("output", metavar="OUT.bvh", type=click.Path(dir_okay=False, path_type=Path))
@force_option
@quiet_option
def example(output: Path, force: bool, quiet: bool) -> None:
    """Write the demo clip shipped with motionrep (a synthetic 450-frame walk) to OUT.bvh.

    \b
    Quick start (as in the README, in a scratch directory):
      cd "$(mktemp -d)"
      motionrep example walk.bvh
      motionrep compress walk.bvh -o walk.mrc
    """
    from ..io._demo import demo_path
    from ..io import atomic_path

    from ..formats import suffix_format

    if suffix_format(output) != "bvh":
        raise click.UsageError(f"output {output}: the demo clip is a .bvh file")
    check_outputs([output], force)
    with atomic_path(output) as tmp:
        shutil.copyfile(demo_path(), tmp)
    if not quiet:
        click.echo(f"wrote {output} (synthetic walk, 450 frames at 30 fps, 15 joints)")
