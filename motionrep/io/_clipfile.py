"""The interface of a file of named clips read once (glTF's :class:`GLTFFile`, FBX's :class:`FBXFile`): ``names``
and ``read_clip`` given by the format, ``read``, ``close`` and ``summaries`` from them."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

from ..model._pose import Motion

__all__ = ["ClipFile"]


class ClipFile(ABC):
    """A file of named motion clips, loaded when opened; subclasses give ``names`` (the clips' names, in the
    file's order) and ``read_clip``."""

    names: list[str]

    @abstractmethod
    def read_clip(self, clip: str | None = None) -> tuple[str, Motion]:
        """``(name, motion)`` of clip ``clip`` (may be omitted when the file holds exactly one)."""

    def read(self, clip: str | None = None) -> Motion:
        """Clip ``clip`` as a :class:`~motionrep.Motion` (see :meth:`read_clip`)."""
        return self.read_clip(clip)[1]

    def close(self) -> None:
        """Nothing to release: the file was read whole when opened."""

    def summaries(self) -> list[dict[str, Any]]:
        """Per clip: ``name``, ``kind`` (``"motion"``), ``frames``, ``fps``, ``duration``, ``joints``."""
        out = []
        for name in self.names:
            m = self.read(name)
            out.append({"name": name, "kind": "motion", "frames": m.num_frames, "fps": m.fps,
                        "duration": m.duration, "joints": m.num_joints})
        return out
