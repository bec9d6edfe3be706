"""The size vocabulary: one definition, one name and one label for each size figure, in every report.

Every command that states a size (``compress`` and its totals, ``info``, ``bench``, the viewer) and every JSON
object uses these names, so that two figures with different denominators never share a name:

``payload_bits_per_bone_frame``
    ``8 x payload bytes / (frames x bones)``: the codec's own arrays only (``Container.payload_bytes``, without
    the skeleton and metadata every ``.mrc`` file carries). ACL's figure: it compares codecs with each other and
    with ACL whatever the container adds.
``file_bits_per_bone_frame``
    ``8 x file bytes / (frames x bones)``: the whole ``.mrc`` file (or archive entry), what a disk holds.
``ratio_vs_source``
    ``source file bytes / file bytes``: how many times smaller than the file it was made from (None when the
    source's size is not known, e.g. a clip of a database).

Bones are joints plus end sites (every point the error is measured on; ACL counts the same way).  The other
figures of :class:`motionrep.pipeline.evaluate.CompressionFigures` (the paper's parameter ratio, the float32-channel
ratio) are shown only with ``--verbose`` and in JSON.
"""

from __future__ import annotations

__all__ = ["PAYLOAD_BPBF", "FILE_BPBF", "RATIO_VS_SOURCE", "LABELS", "bones", "payload_bits_per_bone_frame",
           "file_bits_per_bone_frame", "ratio_vs_source", "size_line"]

#: JSON key of the payload's bits per bone per frame.
PAYLOAD_BPBF = "payload_bits_per_bone_frame"
#: JSON key of the whole file's bits per bone per frame.
FILE_BPBF = "file_bits_per_bone_frame"
#: JSON key of the compression ratio against the source file.
RATIO_VS_SOURCE = "ratio_vs_source"
#: How reports and table headers name each figure.
LABELS = {PAYLOAD_BPBF: "payload bits/bone/frame", FILE_BPBF: "file bits/bone/frame",
          RATIO_VS_SOURCE: "x smaller than source"}


def bones(num_joints: int, num_end_sites: int) -> int:
    """Bones of a skeleton as every size figure counts them: joints plus end sites."""
    return int(num_joints) + int(num_end_sites)


def _per_bone_frame(nbytes: int, bone_frames: int) -> float:
    from ..errors import ValidationError

    if bone_frames < 1:
        raise ValidationError("bits per bone per frame need at least one frame and one bone")
    return 8.0 * int(nbytes) / int(bone_frames)


def payload_bits_per_bone_frame(payload_bytes: int, bone_frames: int) -> float:
    """``8 x payload_bytes / bone_frames``, ``bone_frames = frames x (joints + end sites)`` (summed over clips
    for totals)."""
    return _per_bone_frame(payload_bytes, bone_frames)


def file_bits_per_bone_frame(file_bytes: int, bone_frames: int) -> float:
    """``8 x file_bytes / bone_frames``: the whole ``.mrc`` container, skeleton and metadata included."""
    return _per_bone_frame(file_bytes, bone_frames)


def ratio_vs_source(source_bytes: int | None, file_bytes: int) -> float | None:
    """``source_bytes / file_bytes``, or None when the source's size is unknown (or either is zero)."""
    if not source_bytes or not file_bytes:
        return None
    return int(source_bytes) / int(file_bytes)


def size_line(file_bytes: int, payload_bpbf: float | None, file_bpbf: float | None,
              ratio: float | None) -> str:
    """The short size line every report starts its sizes with, e.g. ``1234 bytes, 0.853 payload
    bits/bone/frame, 1.096 file bits/bone/frame, 52.1x smaller than source``."""
    parts = [f"{int(file_bytes)} bytes"]
    if payload_bpbf is not None:
        parts.append(f"{payload_bpbf:.3f} {LABELS[PAYLOAD_BPBF]}")
    if file_bpbf is not None:
        parts.append(f"{file_bpbf:.3f} {LABELS[FILE_BPBF]}")
    if ratio is not None:
        parts.append(f"{ratio:.1f}{LABELS[RATIO_VS_SOURCE]}")
    return ", ".join(parts)
