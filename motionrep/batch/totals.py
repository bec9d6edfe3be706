"""The totals at the end of a batch of compressed clips, as ACL's tools end a run: clips, failures (every one
named, with its reason), raw and compressed sizes, the overall ratio, bits per bone per frame, the worst error and
its clip, wall and CPU time.

Sizes: *raw* is every BVH channel of every frame as float32 (``frames * channels * 4`` bytes, ACL's "raw size"
counts its float32 tracks the same way); *source* is the size of the files read, when known; *compressed* the
``.mrc`` containers; *payload* the codecs' arrays inside them.  The size figures are those of
:mod:`motionrep.pipeline.figures`, with the same names and definitions as in every other report, summed over the clips:
``payload_bits_per_bone_frame = 8 * payload bytes / sum(frames * (joints + end sites))``,
``file_bits_per_bone_frame`` the same with the containers' bytes, ``ratio_vs_source`` source over compressed
bytes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping

__all__ = ["BatchTotals", "StoredClip", "container_summary", "MB"]

#: Bytes in the megabytes reported (10^6, as file sizes are shown).
MB = 1_000_000


@dataclass(frozen=True)
class StoredClip:
    """A clip the output already held and a run kept (``--resume``): its stored container and sizes.

    Attributes:
        container: the stored container.
        bytes: its size in the output.
        source: where its source is.
        source_bytes: the size of its source, when known.
    """

    container: Any
    bytes: int
    source: str | None = None
    source_bytes: int | None = None


def container_summary(container: Any, nbytes: int, source: str | None = None,
                      source_bytes: int | None = None) -> StoredClip:
    """What the totals need of a stored container (a clip kept by ``--resume``)."""
    return StoredClip(container, int(nbytes), source, source_bytes)


@dataclass
class BatchTotals:
    """Totals over the clips of a run (compressed now, or kept from an earlier run by ``--resume``).

    Attributes:
        clips: clips in the run.
        compressed: clips compressed by this run.
        kept: clips kept from an earlier run (``--resume``).
        failures: ``[{"clip", "source", "reason", "type"}]``, every failed clip.
        raw_bytes, source_bytes, compressed_bytes, payload_bytes: sums (``source_bytes`` over the clips whose
            size is known).
        bone_frames: ``sum(frames * (joints + end sites))``.
        worst: ``{"clip", "max_error", "max_error_percent", "frame", "joint", "units"}`` or None.
        wall_seconds, cpu_seconds: the run's elapsed time, and the processor time of its workers and client.
    """

    clips: int = 0
    compressed: int = 0
    kept: int = 0
    failures: list[dict[str, Any]] = field(default_factory=list)
    raw_bytes: int = 0
    source_bytes: int = 0
    compressed_bytes: int = 0
    payload_bytes: int = 0
    bone_frames: int = 0
    worst: dict[str, Any] | None = None
    wall_seconds: float = 0.0
    cpu_seconds: float = 0.0

    @classmethod
    def of(cls, outcomes: Iterable[Any], kept: Mapping[str, StoredClip] | None = None, *,
           wall_seconds: float = 0.0, client_cpu_seconds: float = 0.0,
           reason: Callable[[Any], str] | None = None) -> "BatchTotals":
        """Totals of :class:`motionrep.batch.engine.ClipOutcome` s; ``kept`` gives the :class:`StoredClip` of every
        skipped clip; ``reason(failure)`` words a failure (default: its message; the command line shows flags)."""
        kept = kept or {}
        t = cls(wall_seconds=float(wall_seconds), cpu_seconds=float(client_cpu_seconds))
        for o in outcomes:
            t.clips += 1
            t.cpu_seconds += float(o.cpu_seconds or 0.0)
            if o.failed:
                f = o.failure
                t.failures.append({"clip": o.name, "source": o.source,
                                   "reason": reason(f) if reason is not None else f.message, "type": f.type})
                continue
            if o.skipped:
                t.kept += 1
                stored = kept.get(o.name)
                if stored is None:
                    continue
                t._add(o.name, stored.container, stored.bytes, stored.source_bytes)
            else:
                t.compressed += 1
                r = o.result
                t._add(o.name, r.container, len(r.data), r.figures.source_bytes)
        return t

    def _add(self, name: str, c: Any, nbytes: int, source_bytes: int | None) -> None:
        frames, sk = int(c.num_frames), c.skeleton
        self.raw_bytes += frames * int(sk.num_channels) * 4
        self.compressed_bytes += int(nbytes)
        self.payload_bytes += int(c.payload_bytes)
        self.bone_frames += frames * (int(sk.num_joints) + int(sk.num_end_sites))
        self.source_bytes += int(source_bytes or 0)
        ev = c.evaluation
        if ev and (self.worst is None or ev["max_error_percent"] > self.worst["max_error_percent"]):
            self.worst = {"clip": name, "max_error": ev["max_error"], "max_error_percent": ev["max_error_percent"],
                          "frame": ev.get("frame"), "joint": ev.get("joint"), "units": ev.get("units")}

    @property
    def ratio(self) -> float | None:
        """Raw (float32 channels) over compressed bytes."""
        return self.raw_bytes / self.compressed_bytes if self.compressed_bytes else None

    @property
    def payload_bits_per_bone_frame(self) -> float | None:
        """:func:`motionrep.pipeline.figures.payload_bits_per_bone_frame` over every clip."""
        from ..pipeline.figures import payload_bits_per_bone_frame

        return payload_bits_per_bone_frame(self.payload_bytes, self.bone_frames) if self.bone_frames else None

    @property
    def file_bits_per_bone_frame(self) -> float | None:
        """:func:`motionrep.pipeline.figures.file_bits_per_bone_frame` over every clip."""
        from ..pipeline.figures import file_bits_per_bone_frame

        return file_bits_per_bone_frame(self.compressed_bytes, self.bone_frames) if self.bone_frames else None

    @property
    def ratio_vs_source(self) -> float | None:
        from ..pipeline.figures import ratio_vs_source

        return ratio_vs_source(self.source_bytes, self.compressed_bytes)

    def as_dict(self) -> dict[str, Any]:
        """Plain data (the ``totals`` of ``motionrep compress --json``)."""
        return {"clips": self.clips, "compressed": self.compressed, "kept": self.kept,
                "failed": len(self.failures), "failures": self.failures,
                "raw_mb": self.raw_bytes / MB, "source_mb": self.source_bytes / MB if self.source_bytes else None,
                "compressed_mb": self.compressed_bytes / MB, "payload_mb": self.payload_bytes / MB,
                "ratio": self.ratio, "source_ratio": self.ratio_vs_source, "ratio_vs_source": self.ratio_vs_source,
                "payload_bits_per_bone_frame": self.payload_bits_per_bone_frame,
                "file_bits_per_bone_frame": self.file_bits_per_bone_frame, "worst": self.worst,
                "wall_seconds": self.wall_seconds, "cpu_seconds": self.cpu_seconds}

    def lines(self, verbose: bool = False) -> list[str]:
        """The report, one fact a line (``verbose``: also the raw float32 size and ratio)."""
        kept = f", {self.kept} kept from an earlier run" if self.kept else ""
        out = [f"clips:        {self.clips} ({self.compressed} compressed{kept}, {len(self.failures)} failed)"]
        for f in self.failures:
            out.append(f"  FAILED {f['clip']}: {f['reason']}")
        if self.compressed_bytes:
            from ..pipeline.figures import size_line

            src = f"source files {self.source_bytes / MB:.3f} MB, " if self.source_bytes else ""
            out.append(f"compressed:   {src}.mrc {self.compressed_bytes / MB:.3f} MB, payload "
                       f"{self.payload_bytes / MB:.3f} MB")
            out.append("size:         " + size_line(self.compressed_bytes, self.payload_bits_per_bone_frame,
                                                     self.file_bits_per_bone_frame, self.ratio_vs_source)
                       + " (bones = joints + end sites)")
            if verbose:
                out.append(f"raw size:     {self.raw_bytes / MB:.3f} MB (float32 channels), ratio {self.ratio:.2f}x")
        if self.worst is not None:
            w = self.worst
            units = f" {w['units']}" if w.get("units") else ""
            out.append(f"worst error:  {w['max_error']:.4g}{units} ({w['max_error_percent']:.3g}% of height) in "
                       f"{w['clip']}, frame {w['frame']}, {w['joint']}")
        out.append(f"time:         {self.wall_seconds:.1f} s wall, {self.cpu_seconds:.1f} s CPU")
        return out
