"""``motionrep plugins``: the loaded plugins, their versions and what each registers; ``--describe`` one codec or
representation."""

from __future__ import annotations

import click

from ._common import echo_json

__all__ = ["plugins_command"]

#: The hooks of motionrep.plugin.hookspecs (written out to keep this module light; a test checks they agree).
HOOKS = ("register_codecs", "register_representations")


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


@click.command("plugins")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list instead of a table.")
@click.option("--hook", type=click.Choice(HOOKS), default=None,
              help="Only the plugins that implement this hook.")
@click.option("--third-party", is_flag=True, help="Only the plugins that are not shipped with motionrep.")
@click.option("--describe", "describe", metavar="NAME", default=None,
              help="Describe one codec or representation: its plugin, versions and (codecs) parameters.")
def plugins_command(as_json: bool, hook: str | None, third_party: bool, describe: str | None) -> None:
    """List every loaded plugin: name, version, where it comes from and what it registers.

    Shipped plugins (the representations and codecs motionrep comes with) are listed too, marked "shipped";
    they load through the same hooks as third-party ones.  Third-party plugins come from the "motionrep"
    entry-point group; MOTIONREP_LOAD_PLUGINS (comma-separated entry-point or distribution names, empty for
    none) limits which of them load.

    \b
    JSON: a list of {name, version, shipped, distribution, hooks, representations, codecs};
    with --describe, one object {name, kind, plugin, description, version,
    readable_versions, min_frames (codecs), params: [{name, type, default,
    help}]}.

    \b
    Examples:
      motionrep plugins
      motionrep plugins --json
      motionrep plugins --hook register_codecs
      motionrep plugins --describe adaptive-fourier   # its -p parameters
      MOTIONREP_LOAD_PLUGINS= motionrep plugins      # shipped plugins only
    """
    from ..plugin.registry import plugin_infos

    if describe is not None:
        _describe(describe, as_json)
        return
    infos = [i for i in plugin_infos() if (hook is None or hook in i.hooks) and not (third_party and i.shipped)]
    if as_json:
        echo_json([i.as_dict() for i in infos])
        return
    if not infos:
        click.echo("No loaded plugin matches." if hook or third_party else "No plugins loaded.")
        return
    rows = [("NAME", "VERSION", "SOURCE", "REGISTERS")]
    rows += [(i.name, i.version or "-", _source(i), _registers(i)) for i in infos]
    widths = [max(len(r[k]) for r in rows) for k in range(3)]
    for r in rows:
        click.echo("  ".join(c.ljust(w) for c, w in zip(r[:3], widths)) + "  " + r[3])


def _describe(name: str, as_json: bool) -> None:
    from ..plugin.codec import params_help
    from ..errors import UnknownPluginError
    from ..plugin.registry import codecs, get_codec, get_representation, provider_of, representations

    if name in codecs():
        codec = get_codec(name)
        d = {"name": name, "kind": "codec", "plugin": provider_of(name, "codec"), "description": codec.description,
             "version": codec.format_version,
             "readable_versions": list(codec.readable_versions or (codec.format_version,)),
             "min_frames": codec.min_frames, "params": params_help(codec.Params)}
    elif name in representations():
        rep = get_representation(name)
        d = {"name": name, "kind": "representation", "plugin": provider_of(name, "representation"),
             "description": rep.description, "version": rep.version, "readable_versions": [rep.version],
             "params": []}
    else:
        raise UnknownPluginError(f"no codec or representation named {name!r}; codecs: {', '.join(sorted(codecs()))}"
                                 f"; representations: {', '.join(sorted(representations()))}")
    if as_json:
        echo_json(d)
        return
    click.echo(f"{d['kind']} {name} (plugin {d['plugin']}), format version {d['version']}"
               + (f", reads {', '.join(map(str, d['readable_versions']))}" if len(d["readable_versions"]) > 1 else ""))
    if d["description"]:
        click.echo(f"  {d['description']}")
    if d.get("min_frames", 1) > 1:
        click.echo(f"  codes clips of at least {d['min_frames']} frames")
    if d["params"]:
        click.echo("parameters (-p KEY=VALUE):")
        width = max(len(p["name"]) for p in d["params"])
        for p in d["params"]:
            click.echo(f"  {p['name']:<{width}}  {p['type']}, default {p['default']}: {p['help']}")
