"""The command-line options of motionrep's borders with other tools, shared by the commands that take them
(re-exported by :mod:`motionrep.cli._common`): the cross-tool comparison options of ``evaluate``, ``view`` and
``render`` (:mod:`motionrep.pipeline.pairing`) and the glTF size options of ``convert`` and ``decompress``
(:func:`motionrep.io.gltf_scale`), and the SMPL-H body model of AMASS inputs (``--body-model``)."""

from __future__ import annotations

import os
from typing import Any, Callable, Sequence

import click

__all__ = ["comparison_options", "match_options", "gltf_unit_options", "gltf_write_options", "check_gltf_units",
           "body_model_option"]


def comparison_options(command: Callable) -> Callable:
    """``--match``, ``--strip-prefix``, ``--ignore-extra`` and ``--resample`` (see :mod:`motionrep.pipeline.pairing`), the
    same for evaluate, view and render; :func:`match_options` turns them into options."""
    for option in reversed([
        click.option("--match", "match", type=click.Choice(["order", "names"]), default="order", show_default=True,
                     help="How joints are paired: 'order' (same joints in the same order, the strict default) or "
                          "'names' (by name, any order; end sites missing on one side or turned into bone tails "
                          "are left out or paired by position, and listed)."),
        click.option("--strip-prefix", "strip_prefix", metavar="PREFIX", multiple=True,
                     help="With --match names: remove this prefix from joint names first (a namespace such as "
                          "'mixamorig:'); repeatable."),
        click.option("--ignore-extra", "ignore_extra", is_flag=True,
                     help="With --match names: leave out (and list) joints only one side has instead of refusing."),
        click.option("--resample", is_flag=True,
                     help="A candidate at another frame rate or length is sampled at the reference's frame times "
                          "(rotations slerped, translations linear); frames outside the overlap are listed."),
    ]):
        command = option(command)
    return command


def match_options(match: str, strip_prefix: Sequence[str], ignore_extra: bool, resample: bool) -> Any:
    """The :class:`motionrep.pipeline.pairing.MatchOptions` of the comparison options (the strict default when none is
    given, so the report still says what it compared; a usage error for --strip-prefix or --ignore-extra without
    --match names)."""
    if match != "names" and (strip_prefix or ignore_extra):
        raise click.UsageError(f"{'--strip-prefix' if strip_prefix else '--ignore-extra'} needs --match names")
    from ..pipeline.pairing import MatchOptions

    return MatchOptions(match=match, strip_prefix=tuple(strip_prefix), ignore_extra=ignore_extra,
                        resample=resample)


def gltf_unit_options(command: Callable) -> Callable:
    """``--scale`` and ``--units`` of the commands that write glTF (:func:`gltf_write_options` reads them)."""
    command = click.option("--units", type=click.Choice(["cm", "m", "in", "mm"]), default=None,
                           help="glTF output: the clip's length unit (written scaled to metres). Default: the "
                                "units the input states, else a guess that makes the character 1-2.5 m tall "
                                "(one line says what was assumed).")(command)
    return click.option("--scale", "gltf_scale", type=float, default=None, metavar="M",
                        help="glTF output: metres per file unit (instead of --units).")(command)


def gltf_write_options(motion: Any, path: Any, scale: float | None, units: str | None,
                       shown: Any = None) -> dict[str, Any]:
    """The ``scale`` write option of a glTF output ``path`` (an empty dict for other formats), printing on stderr
    the one line saying what was assumed when neither ``--scale`` nor ``--units`` was given."""
    from ..io import format_of, gltf_scale

    if format_of(path) != "gltf":
        return {}
    value, note = gltf_scale(motion, scale, units)
    if note:
        from ._flags import flagged

        click.echo(f"note: {shown if shown is not None else path}: {flagged(note)}", err=True)
    return {"scale": value}


def check_gltf_units(scale: float | None, units: str | None, gltf_out: bool) -> None:
    """Usage errors: ``--scale`` with ``--units``, either without glTF output, a scale that is not > 0."""
    if scale is not None and units is not None:
        raise click.UsageError("give --scale or --units, not both")
    if (scale is not None or units is not None) and not gltf_out:
        raise click.UsageError(f"{'--scale' if scale is not None else '--units'} applies only to glTF output "
                               "(.glb, .gltf)")
    if scale is not None and not (scale > 0 and scale < float("inf")):
        raise click.BadParameter("must be a positive number of metres per file unit", param_hint="--scale")


def _set_body_model(ctx: click.Context, param: click.Parameter, value: str | None) -> None:
    if value is not None:  # the readers (and worker processes) take it from the environment
        from ..io._amass import BODY_MODEL_ENV

        os.environ[BODY_MODEL_ENV] = str(value)


def body_model_option(command: Callable) -> Callable:
    """``--body-model MODEL.npz``: the SMPL-H body model that AMASS ``.npz`` inputs are posed with (sets
    ``MOTIONREP_SMPLH_MODEL`` for the readers)."""
    return click.option("--body-model", metavar="MODEL.npz", expose_value=False, callback=_set_body_model,
                        is_eager=True,
                        help="SMPL-H body model (.npz: v_template, shapedirs, J_regressor, kintree_table) for AMASS "
                             ".npz inputs (default: $MOTIONREP_SMPLH_MODEL).")(command)
