"""Hook specifications: the public seam through which plugins add representations and codecs.

Every hook here is documented in ``specs/plugins.md`` with the same signature (a test checks that they agree).
Shipped plugins (``plugins/motionrep_*``) use exactly these hooks; a third-party package does the same and
declares itself in the ``motionrep`` entry-point group::

    [project.entry-points.motionrep]
    haar = "motionrep_haar"

pluggy passes each implementation only the arguments it names, so arguments may be added to a hook in a later
version without breaking plugins; they are never renamed or removed.
"""

from __future__ import annotations

from typing import Callable

import pluggy

__all__ = ["hookspec", "hookimpl", "register_representations", "register_codecs"]

#: Marks the hook specifications below (project name ``motionrep``).
hookspec = pluggy.HookspecMarker("motionrep")
#: Marks a plugin's hook implementations: ``@motionrep.hookimpl``.
hookimpl = pluggy.HookimplMarker("motionrep")


# -------------------------------------------------------------------------------------------------------------
# Registration hooks
# -------------------------------------------------------------------------------------------------------------
@hookspec
def register_representations(register: Callable[..., None]) -> None:
    """Register pose representations.

    :param register: call ``register(representation)`` once per representation, with an instance of a
        :class:`motionrep.plugin.representation.Representation` subclass.  The core checks it (a non-empty ``name``,
        an integer ``version`` >= 1, the required methods) as it is registered.  A representation may also
        offer a torch path (``Representation.torch_path``, optional; ``specs/torch.md``), imported only when
        asked for, so that registering never imports torch.

    Called once per process, when plugins are first loaded: the first time motionrep looks up any
    representation or codec (a command naming one, reading a features or ``.mrc`` file, ``motionrep plugins``);
    never at import time.  A name registered by two plugins raises
    :class:`motionrep.errors.DuplicateNameError` naming both.
    """


@hookspec
def register_codecs(register: Callable[..., None]) -> None:
    """Register motion codecs.

    :param register: call ``register(codec)`` once per codec, with an instance of a
        :class:`motionrep.plugin.codec.Codec` subclass.  The core checks it (a non-empty ``name``, an integer
        ``format_version`` >= 1, a ``Params`` dataclass, the required methods) as it is registered.

    Called once per process, when plugins are first loaded (right after every ``register_representations``):
    the first time motionrep looks up any representation or codec (``compress``, ``decompress``, reading a
    ``.mrc`` file, ``motionrep plugins``...); never at import time.  A name registered by two plugins raises
    :class:`motionrep.errors.DuplicateNameError` naming both.
    """
