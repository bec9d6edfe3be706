"""``motionrep plugins``: list the loaded plugins, their versions and what each registers."""

from __future__ import annotations

import json

import click

from . import hookspecs
from .cli import cli

__all__ = ["plugins_command"]

_HOOKS = sorted(name for name in hookspecs.__all__ if name not in ("hookspec", "hookimpl"))


def _source(info) -> str:
    if info.shipped:
        return "shipped"
    return info.distribution or "registered at runtime"


def _registers(info) -> str:
    parts = []
    if info.representations:
        parts.append("representations: " + ", ".join(info.representations))
    if info.codecs:
        parts.append("codecs: " + ", ".join(info.codecs))
    return "; ".join(parts) or "-"


@cli.command("plugins")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list instead of a table.")
@click.option("--hook", type=click.Choice(_HOOKS), default=None,
              help="Only the plugins that implement this hook.")
@click.option("--third-party", is_flag=True, help="Only the plugins that are not shipped with motionrep.")
def plugins_command(as_json: bool, hook: str | None, third_party: bool) -> None:
    """List every loaded plugin: name, version, where it comes from and what it registers.

    Shipped plugins (the representations and codecs motionrep comes with) are listed too, marked "shipped";
    they load through the same hooks as third-party ones.  Third-party plugins come from the "motionrep"
    entry-point group; MOTIONREP_LOAD_PLUGINS (comma-separated entry-point or distribution names, empty for
    none) limits which of them load.

    \b
    JSON: a list of {name, version, shipped, distribution, hooks, representations, codecs}.

    \b
    Examples:
      motionrep plugins
      motionrep plugins --json
      motionrep plugins --hook register_codecs
      MOTIONREP_LOAD_PLUGINS= motionrep plugins      # shipped plugins only
    """
    from .plugins import plugin_infos

    infos = [i for i in plugin_infos() if (hook is None or hook in i.hooks) and not (third_party and i.shipped)]
    if as_json:
        click.echo(json.dumps([i.as_dict() for i in infos], indent=2))
        return
    if not infos:
        click.echo("No loaded plugin matches." if hook or third_party else "No plugins loaded.")
        return
    rows = [("NAME", "VERSION", "SOURCE", "REGISTERS")]
    rows += [(i.name, i.version or "-", _source(i), _registers(i)) for i in infos]
    widths = [max(len(r[k]) for r in rows) for k in range(3)]
    for r in rows:
        click.echo("  ".join(c.ljust(w) for c, w in zip(r[:3], widths)) + "  " + r[3])
