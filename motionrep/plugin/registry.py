"""Plugin loading and the registry of representations and codecs.

Plugins are loaded lazily, once per process, the first time a representation or codec is looked up:

1. third-party plugins from the ``motionrep`` entry-point group (all of them, or only those named in the
   comma-separated environment variable ``MOTIONREP_LOAD_PLUGINS``; empty means none);
2. the shipped plugins in :data:`DEFAULT_PLUGINS`, imported and registered the same way.

Then every ``register_representations`` and ``register_codecs`` implementation is called with a ``register``
callback that validates what it is given and remembers which plugin gave it.  A name registered twice raises
:class:`~motionrep.errors.DuplicateNameError` naming both plugins.
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any, Callable

import pluggy

from . import hookspecs
from .codec import Codec
from ..errors import DuplicateNameError, PluginError, PluginVersionError, UnknownPluginError
from .representation import Representation

__all__ = [
    "pm",
    "DEFAULT_PLUGINS",
    "ENV_VAR",
    "PluginInfo",
    "load_plugins",
    "reset_plugins",
    "get_representation",
    "get_codec",
    "representations",
    "codecs",
    "plugin_infos",
    "provider_of",
]

#: The shipped plugins, registered through the same hooks as third-party ones.
DEFAULT_PLUGINS: tuple[str, ...] = (
    "motionrep_rootquat",
    "motionrep_dualquat",
    "motionrep_ortho6d",
    "motionrep_euler",
    "motionrep_svd",
    "motionrep_fourier",
    "motionrep_transform",
)
#: Environment variable limiting which third-party plugins load (comma-separated names; empty = none).
ENV_VAR = "MOTIONREP_LOAD_PLUGINS"

pm = pluggy.PluginManager("motionrep")
pm.add_hookspecs(hookspecs)


@dataclass
class PluginInfo:
    """What ``motionrep plugins`` reports about one plugin."""

    name: str
    version: str | None
    shipped: bool
    distribution: str | None = None
    hooks: list[str] = field(default_factory=list)
    representations: list[str] = field(default_factory=list)
    codecs: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "version": self.version, "shipped": self.shipped,
                "distribution": self.distribution, "hooks": self.hooks,
                "representations": self.representations, "codecs": self.codecs}


class _State:
    loaded = False
    infos: dict[str, PluginInfo] = {}
    reps: dict[str, tuple[Representation, str]] = {}
    codecs: dict[str, tuple[Codec, str]] = {}


def _allowed_names() -> set[str] | None:
    value = os.environ.get(ENV_VAR)
    if value is None:
        return None
    return {n.strip() for n in value.split(",") if n.strip()}


def _load_entry_points() -> None:
    allowed = _allowed_names()
    found: set[str] = set()
    for ep in metadata.entry_points(group="motionrep"):
        dist = ep.dist.name if ep.dist is not None else None
        names = {ep.name} | ({dist} if dist else set())
        if allowed is not None and not names & allowed:
            continue
        found |= names
        if pm.has_plugin(ep.name):
            continue
        try:
            module = ep.load()
        except Exception as exc:  # a broken third-party plugin must name itself
            raise PluginError(f"plugin {ep.name!r} ({ep.value}) failed to load: {type(exc).__name__}: {exc}") from exc
        _register(module, ep.name)
        _State.infos[ep.name] = PluginInfo(ep.name, ep.dist.version if ep.dist is not None else None, False, dist)
    if allowed:
        missing = sorted(allowed - found)
        if missing:
            raise PluginError(f"{ENV_VAR} names {missing[0]!r}, but no installed plugin has that name")


def _load_shipped() -> None:
    from .._version import __version__

    for name in DEFAULT_PLUGINS:
        if pm.has_plugin(name):
            other = _State.infos.get(name)
            if other is not None and other.distribution:
                raise DuplicateNameError(f"plugin name {name!r} is used twice: by the shipped plugin and by "
                                         f"{other.distribution!r}")
            continue
        try:
            module = importlib.import_module(name)
        except ImportError as exc:
            raise PluginError(f"shipped plugin {name!r} failed to import: {exc}") from exc
        _register(module, name)
        _State.infos[name] = PluginInfo(name, getattr(module, "__version__", __version__), True, "motionrep")


def _register(module: Any, name: str) -> None:
    try:
        pm.register(module, name=name)
    except pluggy.PluginValidationError as exc:  # a hook implementation whose arguments the spec lacks
        raise PluginError(f"plugin {name!r} is invalid: " + " ".join(str(exc).split())) from exc


def _check_representation(obj: Any, plugin: str) -> None:
    from .representation import representation_problems

    problems = representation_problems(obj)
    if problems:
        raise PluginError(f"plugin {plugin!r} registered representation {getattr(obj, 'name', obj)!r}, which is "
                          f"invalid: {'; '.join(problems)}")


def _check_codec(obj: Any, plugin: str) -> None:
    from .codec import codec_problems

    problems = codec_problems(obj)
    if problems:
        raise PluginError(f"plugin {plugin!r} registered codec {getattr(obj, 'name', obj)!r}, which is invalid: "
                          f"{'; '.join(problems)}")


def _collect(hook_name: str, kind: str, check: Callable[[Any, str], None], into: dict) -> None:
    hook = getattr(pm.hook, hook_name)
    # get_hookimpls() is in registration order; walk it backwards, the order in which pluggy calls hooks.
    for impl in reversed(hook.get_hookimpls()):
        plugin = impl.plugin_name

        def register(obj: Any, _plugin: str = plugin) -> None:
            check(obj, _plugin)
            if obj.name in into:
                other = into[obj.name][1]
                raise DuplicateNameError(f"{kind} name {obj.name!r} is registered twice: by plugin {other!r} "
                                         f"and by plugin {_plugin!r}")
            into[obj.name] = (obj, _plugin)
            info = _State.infos.get(_plugin)
            if info is not None:
                (info.representations if kind == "representation" else info.codecs).append(obj.name)

        impl.function(**{arg: register for arg in impl.argnames})
        info = _State.infos.get(plugin)
        if info is not None and hook_name not in info.hooks:
            info.hooks.append(hook_name)


def load_plugins() -> None:
    """Load and register every plugin, once (later calls do nothing).

    Raises:
        PluginError: if a plugin fails to import, registers something invalid, or two register one name.
    """
    if _State.loaded:
        return
    try:
        _load_entry_points()
        _load_shipped()
        try:
            pm.check_pending()
        except pluggy.PluginValidationError as exc:  # a misspelt hook name
            known = ", ".join(n for n in hookspecs.__all__ if n not in ("hookspec", "hookimpl"))
            raise PluginError(" ".join(str(exc).split()) + f"; known hooks: {known}") from exc
        for name, plugin in pm.list_name_plugin():
            if name not in _State.infos:  # registered by hand (tests, embedding applications)
                _State.infos[name] = PluginInfo(name, getattr(plugin, "__version__", None), False, None)
            _State.infos[name].hooks = sorted(caller.name for caller in pm.get_hookcallers(plugin) or ())
        _collect("register_representations", "representation", _check_representation, _State.reps)
        _collect("register_codecs", "codec", _check_codec, _State.codecs)
    except BaseException:
        reset_plugins()
        raise
    _State.loaded = True


def reset_plugins() -> None:
    """Forget every plugin and registration, so the next lookup loads them again (for tests)."""
    for name, plugin in list(pm.list_name_plugin()):
        pm.unregister(plugin, name=name)
    _State.loaded = False
    _State.infos = {}
    _State.reps = {}
    _State.codecs = {}


def representations() -> dict[str, Representation]:
    """Every registered representation by name."""
    load_plugins()
    return {name: obj for name, (obj, _) in sorted(_State.reps.items())}


def codecs() -> dict[str, Codec]:
    """Every registered codec by name."""
    load_plugins()
    return {name: obj for name, (obj, _) in sorted(_State.codecs.items())}


def provider_of(name: str, kind: str = "codec") -> str | None:
    """Name of the plugin that registered the codec (or representation) ``name``; None if none did."""
    load_plugins()
    table = _State.codecs if kind == "codec" else _State.reps
    entry = table.get(name)
    if entry is None:
        return None
    info = _State.infos.get(entry[1])
    return info.distribution if info is not None and info.distribution and not info.shipped else entry[1]


def _where(path: Any, clip: str | None) -> str:
    return ("" if path is None else f"{path}: ") + ("" if clip is None else f"clip {clip!r}: ")


def _unknown(kind: str, name: str, table: dict, provided_by: str | None, path: Any, clip: str | None) -> Exception:
    hint = f" (provided by plugin {provided_by!r}, which is not installed or not loaded)" if provided_by else ""
    return UnknownPluginError(f"{_where(path, clip)}unknown {kind} {name!r}{hint}; available: "
                              + ", ".join(sorted(table)))


def get_representation(name: str, *, version: int | None = None, provided_by: str | None = None,
                       path: Any = None, clip: str | None = None) -> Representation:
    """The representation registered as ``name``; with ``version``, only if it is that version.

    Args:
        name: representation name.
        version: the version a file was written by (features, or a ``.mrc`` container); None: any.
        provided_by: the plugin the file says provides it, quoted when it is not installed.
        path, clip: the file (and clip of a database) the name comes from, quoted in errors.

    Raises:
        UnknownPluginError: naming the representation (and its plugin) and listing the available names.
        PluginVersionError: naming the file, when the installed representation is another version (features
            are only decoded by the version that wrote them).
    """
    load_plugins()
    entry = _State.reps.get(name)
    if entry is None:
        raise _unknown("representation", name, _State.reps, provided_by, path, clip)
    rep = entry[0]
    if version is not None and version != rep.version:
        raise PluginVersionError(f"{_where(None, clip)}written by representation {name!r} version {version}, but "
                                 f"the installed {name!r} (plugin {provider_of(name, 'representation')!r}) is "
                                 f"version {rep.version}, which cannot decode another version", path)
    return rep


def get_codec(name: str, *, version: int | None = None, provided_by: str | None = None, path: Any = None,
              clip: str | None = None) -> Codec:
    """The codec registered as ``name``; with ``version``, only if it reads that payload version.

    Args:
        name: codec name.
        version: the payload format version a file holds; None: any.
        provided_by: the plugin a file says provides it, quoted in the error when it is not installed.
        path, clip: the file (and clip of an archive) the name comes from, quoted in errors.

    Raises:
        UnknownPluginError: naming the codec (and its plugin when known) and listing the available codecs.
        PluginVersionError: naming the file, when the installed codec does not read that payload version.
    """
    load_plugins()
    entry = _State.codecs.get(name)
    if entry is None:
        raise _unknown("codec", name, _State.codecs, provided_by, path, clip)
    codec = entry[0]
    readable = tuple(codec.readable_versions) or (codec.format_version,)
    if version is not None and version not in readable:
        raise PluginVersionError(f"{_where(None, clip)}codec {name!r} payload version {version} is not readable by "
                                 f"the installed codec (plugin {provider_of(name, 'codec')!r}), which reads "
                                 f"versions {', '.join(map(str, readable))}", path)
    return codec


def plugin_infos() -> list[PluginInfo]:
    """One :class:`PluginInfo` per loaded plugin, third-party first, then shipped, each sorted by name."""
    load_plugins()
    return sorted(_State.infos.values(), key=lambda i: (i.shipped, i.name))
