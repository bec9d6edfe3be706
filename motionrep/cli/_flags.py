"""The command line's names for the library's parameters: a library error names a Python parameter
(``max_error``, ``clip=NAME``; :attr:`motionrep.errors.MotionrepError.parameters` lists the mentions), and the
command line shows the flag (``--max-error``, ``--clip NAME``) through :func:`flagged`, in its error funnel
(``motionrep.cli``) and wherever a command turns a library error into a message."""

from __future__ import annotations

from typing import Iterable

__all__ = ["FLAGS", "flagged", "flag_text"]

#: The one table from the library's parameter mentions (:attr:`motionrep.errors.MotionrepError.parameters`, as a
#: message writes them) to the command line's flags.  ``name=`` is a mention followed by its value (``fps=60`` reads
#: ``--fps 60``).
FLAGS: dict[str, str] = {
    "max_error=None": "--max-error none",
    "max_error=": "--max-error ",
    "max_error": "--max-error",
    "timeout=": "--timeout",
    "codec=": "--codec ",
    "fps=": "--fps ",
    "fps": "--fps",
    "max_frames=": "--max-frames ",
    "max_frames": "--max-frames",
    "frames=": "--frames",
    "codec=": "--codec ",
    "params window=": "-p window=",
    "units=": "--units",
    "scale=": "--scale",
    "on_clash=": "--on-clash ",
    "clip=NAME": "--clip NAME",
    "clip=": "--clip",
    "body_model=MODEL.npz": "--body-model MODEL.npz",
    "force=True": "--force",
    "resume=True": "--resume",
    "recompress_changed=True": "--recompress-changed",
    "common=True": "--common",
    "match='names'": "--match names",
    "strip_prefix": "--strip-prefix",
    "ignore_extra=True": "--ignore-extra",
    "ignore_extra": "--ignore-extra",
    "resample=True": "--resample",
}


def flagged(exc: BaseException) -> str:
    """``str(exc)`` with each parameter mention it records (``exc.parameters``) rewritten into its flag (:data:`FLAGS`):
    what the command line shows for a library error."""
    return flag_text(str(exc), getattr(exc, "parameters", ()))


def flag_text(text: str, mentions: Iterable[str]) -> str:
    """``text`` with each parameter mention in ``mentions`` rewritten into its flag (:data:`FLAGS`)."""
    for mention in mentions:
        text = text.replace(mention, FLAGS[mention])
    return text
