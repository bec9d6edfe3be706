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
figures of :class:`CompressionFigures` (the paper's parameter ratio, the float32-channel ratio) are shown only with
``--verbose`` and in JSON.

Compression figures (:func:`compression_figures`), always reported together:

(a) ``paper_ratio``: ``frames x feature width`` of the representation divided by the number of stored
    parameters (every stored number, frequencies and normalisation included) -- the ratio of Tojo et al. 2022.
(b) ``float32_ratio``: bytes of the source's channel data stored as float32 (``frames x channels x 4``) divided
    by the bytes of the compressed file.
(c) ``bits_per_joint_frame``: compressed file bits divided by ``frames x joints`` (end sites excluded).
(d) ``file_ratio``: source file bytes divided by compressed file bytes (None when the motion did not come from
    a file).
(e) ``bits_per_bone_frame``: the codec's payload bits (``payload_bytes``: its arrays, without the skeleton and
    metadata every ``.mrc`` file has) divided by ``frames x (joints + end sites)``, ACL's count, so that sizes
    compare with ACL's and between codecs whatever the container adds (None when the payload size is not
    given).  The same figure as (f); kept under this name for older readers.
(f) ``payload_bits_per_bone_frame``, ``file_bits_per_bone_frame`` and ``ratio_vs_source``: the size vocabulary of
    above, the figures every report shows first (the others behind ``--verbose`` and in JSON).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from ..errors import ValidationError

__all__ = ["CompressionFigures", "compression_figures", "PAYLOAD_BPBF", "FILE_BPBF", "RATIO_VS_SOURCE", "LABELS", "bones", "payload_bits_per_bone_frame",
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


@dataclass(frozen=True)
class CompressionFigures:
    """The four compression figures, reported together (see the module docstring).

    Attributes:
        paper_ratio: (a) ``num_frames * feature_width / num_parameters``.
        float32_ratio: (b) ``num_frames * num_channels * 4 / compressed_bytes``.
        bits_per_joint_frame: (c) ``8 * compressed_bytes / (num_frames * num_joints)``.
        file_ratio: (d) ``source_bytes / compressed_bytes``, or None without a source file.
        bits_per_bone_frame: (e) ``8 * payload_bytes / (num_frames * (num_joints + num_end_sites))``, or None
            without ``payload_bytes``.
        num_frames, feature_width, num_parameters, num_channels, num_joints, compressed_bytes, source_bytes,
        num_end_sites, payload_bytes: the inputs.
    """

    paper_ratio: float
    float32_ratio: float
    bits_per_joint_frame: float
    file_ratio: float | None
    num_frames: int
    feature_width: int
    num_parameters: int
    num_channels: int
    num_joints: int
    compressed_bytes: int
    source_bytes: int | None
    bits_per_bone_frame: float | None = None
    num_end_sites: int = 0
    payload_bytes: int | None = None
    payload_bits_per_bone_frame: float | None = None
    file_bits_per_bone_frame: float | None = None
    ratio_vs_source: float | None = None

    def as_dict(self) -> dict[str, Any]:
        """A JSON-serialisable dict of every field."""
        return asdict(self)

    def summary(self) -> str:
        """The short line: file bytes, the payload's and the file's bits per bone per frame, the ratio against
        the source (:func:`size_line`)."""
        return size_line(self.compressed_bytes, self.payload_bits_per_bone_frame, self.file_bits_per_bone_frame,
                         self.ratio_vs_source)

    def details(self) -> str:
        """The other figures, for ``--verbose``: the paper's parameter ratio, the float32-channel ratio, bits per
        joint per frame of the file, the payload's bytes."""
        payload = "" if self.payload_bytes is None else f", payload {self.payload_bytes} bytes"
        return (f"paper ratio {self.paper_ratio:.1f}x ({self.num_parameters} stored numbers), "
                f"vs float32 channels {self.float32_ratio:.1f}x, {self.bits_per_joint_frame:.2f} file "
                f"bits/joint/frame{payload}")


def compression_figures(*, num_frames: int, feature_width: int, num_parameters: int, num_channels: int,
                        num_joints: int, compressed_bytes: int, source_bytes: int | None = None,
                        num_end_sites: int = 0, payload_bytes: int | None = None) -> CompressionFigures:
    """Compute the compression figures.

    Args:
        num_frames: frames of the clip ``F``.
        feature_width: columns ``D`` of the representation the codec compressed.
        num_parameters: every number the codec stored (all payload array elements).
        num_channels: BVH channel values per frame of the source skeleton.
        num_joints: joints ``J`` (end sites excluded).
        compressed_bytes: size of the compressed file.
        source_bytes: size of the source file, or None.
        num_end_sites: end sites of the skeleton (bones = joints + end sites, for ``bits_per_bone_frame``).
        payload_bytes: bytes of the codec's payload arrays (``Container.payload_bytes``), or None.

    Raises:
        ValidationError: for non-positive sizes.
    """
    if num_frames < 1 or num_joints < 1 or compressed_bytes < 1:
        raise ValidationError("compression figures need at least one frame, one joint and one compressed byte")
    params = max(int(num_parameters), 1)
    bone_frames = num_frames * bones(num_joints, num_end_sites)
    payload_bpbf = None if payload_bytes is None else payload_bits_per_bone_frame(payload_bytes, bone_frames)
    return CompressionFigures(
        paper_ratio=num_frames * feature_width / params,
        float32_ratio=num_frames * num_channels * 4 / compressed_bytes,
        bits_per_joint_frame=8.0 * compressed_bytes / (num_frames * num_joints),
        file_ratio=None if source_bytes is None else source_bytes / compressed_bytes,
        num_frames=int(num_frames),
        feature_width=int(feature_width),
        num_parameters=int(num_parameters),
        num_channels=int(num_channels),
        num_joints=int(num_joints),
        compressed_bytes=int(compressed_bytes),
        source_bytes=None if source_bytes is None else int(source_bytes),
        bits_per_bone_frame=payload_bpbf,
        num_end_sites=int(num_end_sites),
        payload_bytes=None if payload_bytes is None else int(payload_bytes),
        payload_bits_per_bone_frame=payload_bpbf,
        file_bits_per_bone_frame=file_bits_per_bone_frame(compressed_bytes, bone_frames),
        ratio_vs_source=ratio_vs_source(source_bytes, compressed_bytes),
    )
