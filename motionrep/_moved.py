"""The flat layout's module names (``motionrep.compress``, ``motionrep.codec``, ...), answered from the wings.

Until 0.2 every module sat directly in ``motionrep/``; they now live in wings (CONTRIBUTING.md, "Layout").  A
plugin or script written against the old names keeps working: importing ``motionrep.compress`` gives the module
``motionrep.pipeline.compress`` itself (one module object under two names, so state and ``isinstance`` checks
agree) and says once, as a :class:`DeprecationWarning`, where it lives now.  :data:`MOVED` is the one table of the
moves; nothing inside motionrep imports an old name (``tests/test_layout.py`` reads the imports).
"""

from __future__ import annotations

import importlib
import sys
import warnings
from importlib.machinery import ModuleSpec

__all__ = ["MOVED", "install"]

#: old module name -> where it lives now (a package's submodules follow it: ``motionrep.render.scene`` ->
#: ``motionrep.present.render.scene``)
MOVED = {
    "motionrep._model": "motionrep.model._pose", "motionrep.rotations": "motionrep.model.rotations",
    "motionrep.kinematics": "motionrep.model.kinematics", "motionrep.poseplan": "motionrep.model.poseplan",
    "motionrep.ops": "motionrep.model.ops", "motionrep.synthetic": "motionrep.model.synthetic",
    "motionrep.timefmt": "motionrep.model.timefmt", "motionrep.bound": "motionrep.model.bound",
    "motionrep.hookspecs": "motionrep.plugin.hookspecs", "motionrep.plugins": "motionrep.plugin.registry",
    "motionrep.codec": "motionrep.plugin.codec", "motionrep.representation": "motionrep.plugin.representation",
    "motionrep.coding": "motionrep.plugin.coding",
    "motionrep.container": "motionrep.io.container", "motionrep.archive": "motionrep.io.archive",
    "motionrep._demo": "motionrep.io._demo",
    "motionrep.evaluate": "motionrep.pipeline.evaluate", "motionrep.pairing": "motionrep.pipeline.pairing",
    "motionrep.compress": "motionrep.pipeline.compress", "motionrep.decode": "motionrep.pipeline.decode",
    "motionrep.runtime": "motionrep.pipeline.runtime", "motionrep.figures": "motionrep.pipeline.figures",
    "motionrep.sources": "motionrep.pipeline.sources", "motionrep.checksum": "motionrep.pipeline.checksum",
    "motionrep.executors": "motionrep.batch.executors", "motionrep.store": "motionrep.batch.store",
    "motionrep.totals": "motionrep.batch.totals",
    "motionrep.info": "motionrep.present.info", "motionrep.view": "motionrep.present.view",
    "motionrep.render": "motionrep.present.render", "motionrep.bench": "motionrep.present.bench",
}
# ``motionrep.batch`` was a module and is now the batch wing's package: its names live in ``motionrep.batch.engine``
# and cannot be answered under the old name (the package takes it); the CHANGELOG says so.


def _target(fullname: str) -> str | None:
    if fullname in MOVED:
        return MOVED[fullname]
    head, dot, tail = fullname.rpartition(".")
    while dot:
        if head in MOVED:
            return MOVED[head] + fullname[len(head):]
        head, dot, _ = head.rpartition(".")
    return None


class _OldNames:
    """A meta path finder and loader in one: an old name is loaded as the module at its new place."""

    def find_spec(self, fullname: str, path: object = None, target: object = None) -> ModuleSpec | None:
        new = _target(fullname) if fullname.startswith("motionrep.") else None
        return None if new is None else ModuleSpec(fullname, self, loader_state=new)

    def create_module(self, spec: ModuleSpec):
        new = spec.loader_state
        warnings.warn(f"{spec.name} is now {new} (motionrep's modules moved into wings; CONTRIBUTING.md, "
                      "'Layout'): import it from there", DeprecationWarning, stacklevel=4)
        module = importlib.import_module(new)
        spec.loader_state = module.__spec__  # the module's own spec, given back in exec_module
        return module

    def exec_module(self, module) -> None:
        # the import system stamped the old name's spec on the module: give it its own back
        module.__spec__ = module.__spec__.loader_state


_finder = _OldNames()


def install() -> None:
    """Answer the old names from now on (idempotent; ``import motionrep`` calls it)."""
    if _finder not in sys.meta_path:
        sys.meta_path.insert(0, _finder)
