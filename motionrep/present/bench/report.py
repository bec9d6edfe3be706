"""Benchmark results: one :class:`BenchRow` per run, the medians per group (:func:`summarize`), and the same rows
as an aligned or Markdown table, CSV and JSON (column reference: ``specs/bench.md``), with the machine they ran
on (:func:`machine_info`).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import os
import platform
import statistics
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from ...errors import FormatError

__all__ = ["BENCH_FORMAT", "BENCH_VERSION", "BenchRow", "COLUMNS", "BenchSummary", "SUMMARY_COLUMNS", "summarize",
           "totals_line", "format_table", "csv_text", "write_csv", "read_csv",
           "machine_info", "bench_json", "write_json"]

#: ``format`` written into the JSON file.
BENCH_FORMAT = "motionrep-bench"
#: Version of the CSV/JSON layout (``specs/bench.md``); bumped when a column changes meaning or is removed.
BENCH_VERSION = 1


# ---------------------------------------------------------------------------------------------------------------
# rows
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BenchRow:
    """The result of one run (one row of the table, CSV and JSON; column reference in ``specs/bench.md``).

    Error columns are in file units and in percent of the character height.  For a ``"failed"`` run (bound not
    met) ``error`` and ``error_percent`` hold the best error the codec reached, ``encode_seconds`` the time until
    it gave up, and the size and decode columns are None; for an ``"error"`` run (invalid parameters for this
    clip, unreadable input...) only ``message`` says what happened.
    """

    clip: str
    source: str
    frames: int
    joints: int
    fps: float
    height: float
    units: str | None
    codec: str
    representation: str
    max_error: str | None
    bound: float | None
    params: str
    seed: int
    status: str
    outcome: str
    error: float | None = None
    error_percent: float | None = None
    mean_error: float | None = None
    mean_error_percent: float | None = None
    worst_frame: int | None = None
    worst_joint: str | None = None
    paper_ratio: float | None = None
    bytes_ratio: float | None = None
    file_ratio: float | None = None
    bits_per_joint_frame: float | None = None
    bytes: int | None = None
    parameters: int | None = None
    feature_width: int | None = None
    encode_seconds: float | None = None
    evaluations: int | None = None
    decode_poses: int | None = None
    decode_poses_per_second: float | None = None
    decode_features_per_second: float | None = None
    decode_pose_seconds: float | None = None
    load_average: float | None = None
    info: dict[str, Any] = field(default_factory=dict)
    message: str = ""
    xz_bytes: int | None = None
    xz_ratio: float | None = None
    payload_bytes: int | None = None
    bits_per_bone_frame: float | None = None
    payload_bits_per_bone_frame: float | None = None
    file_bits_per_bone_frame: float | None = None
    ratio_vs_source: float | None = None
    #: The parameter mentions ``message`` holds (:attr:`motionrep.errors.MotionrepError.parameters`), which the
    #: command line rewrites into flags; not a column.
    mentions: tuple[str, ...] = field(default=(), repr=False, compare=False, metadata={"column": False})

    def as_dict(self) -> dict[str, Any]:
        """Every column, JSON-serialisable."""
        return {c: v for c, v in dataclasses.asdict(self).items() if c in COLUMNS}


#: Column names of :class:`BenchRow`, in CSV order.
COLUMNS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(BenchRow) if f.metadata.get("column", True))



# ---------------------------------------------------------------------------------------------------------------
# medians
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BenchSummary:
    """Medians of one group of runs (one codec, representation, bound and parameter combination) over the runs
    that succeeded; None when none did.

    Attributes:
        runs, ok, failed, errors: how many runs the group has, and how many succeeded, missed the bound, or
            raised an error.
    """

    codec: str
    representation: str
    max_error: str | None
    params: str
    runs: int
    ok: int
    failed: int
    errors: int
    median_error_percent: float | None
    median_paper_ratio: float | None
    median_bytes_ratio: float | None
    median_bits_per_joint_frame: float | None
    median_encode_seconds: float | None
    median_decode_poses_per_second: float | None
    total_bytes: int | None = None
    total_xz_bytes: int | None = None
    median_bits_per_bone_frame: float | None = None
    median_payload_bits_per_bone_frame: float | None = None
    median_file_bits_per_bone_frame: float | None = None
    median_ratio_vs_source: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


#: Column names of :class:`BenchSummary`.
SUMMARY_COLUMNS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(BenchSummary))


def _median(values: Iterable[float | None]) -> float | None:
    vals = [float(v) for v in values if v is not None]
    return statistics.median(vals) if vals else None


def summarize(rows: Sequence[BenchRow]) -> list[BenchSummary]:
    """Medians per (codec, representation, bound, parameters), groups in order of first appearance."""
    groups: dict[tuple, list[BenchRow]] = {}
    for r in rows:
        groups.setdefault((r.codec, r.representation, r.max_error, r.params), []).append(r)
    out = []
    for (codec, rep, bound, params), members in groups.items():
        ok = [r for r in members if r.status == "ok"]
        out.append(BenchSummary(
            codec=codec, representation=rep, max_error=bound, params=params, runs=len(members), ok=len(ok),
            failed=sum(r.status == "failed" for r in members), errors=sum(r.status == "error" for r in members),
            median_error_percent=_median(r.error_percent for r in ok),
            median_paper_ratio=_median(r.paper_ratio for r in ok),
            median_bytes_ratio=_median(r.bytes_ratio for r in ok),
            median_bits_per_joint_frame=_median(r.bits_per_joint_frame for r in ok),
            median_bits_per_bone_frame=_median(r.bits_per_bone_frame for r in ok),
            median_payload_bits_per_bone_frame=_median(r.payload_bits_per_bone_frame for r in ok),
            median_file_bits_per_bone_frame=_median(r.file_bits_per_bone_frame for r in ok),
            median_ratio_vs_source=_median(r.ratio_vs_source for r in ok),
            median_encode_seconds=_median(r.encode_seconds for r in ok),
            median_decode_poses_per_second=_median(r.decode_poses_per_second for r in ok),
            total_bytes=sum(r.bytes for r in ok) if ok and all(r.bytes is not None for r in ok) else None,
            total_xz_bytes=sum(r.xz_bytes for r in ok) if ok and all(r.xz_bytes is not None for r in ok) else None))
    return out


def totals_line(rows: Sequence[BenchRow]) -> str:
    """One line of totals over every run: clips, runs by status, encode time, source and ``xz -9`` bytes."""
    clips: dict[str, BenchRow] = {}
    for r in rows:
        clips.setdefault(r.clip, r)
    ok = sum(r.status == "ok" for r in rows)
    failed = sum(r.status == "failed" for r in rows)
    errors = sum(r.status == "error" for r in rows)
    seconds = sum(r.encode_seconds or 0.0 for r in rows)
    xz = [r.xz_bytes for r in clips.values()]
    xz_text = f"; xz -9 of the sources {sum(xz):,} bytes" if xz and all(x is not None for x in xz) else ""
    return (f"totals: {len(rows)} runs on {len(clips)} clips: {ok} ok, {failed} failed (bound not met), "
            f"{errors} errors; encode {seconds:.1f} s{xz_text}")


# ---------------------------------------------------------------------------------------------------------------
# the table
# ---------------------------------------------------------------------------------------------------------------
def _f(v: float | None, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def _bound_text(v: str | None) -> str:
    return "none" if v is None else v


def _row_cells(r: BenchRow, reps: bool, params: bool) -> list[str]:
    units = f" {r.units}" if r.units and r.error is not None else ""
    cells = [r.clip, str(r.frames), str(r.joints), r.codec]
    if reps:
        cells.append(r.representation)
    cells.append(_bound_text(r.max_error))
    if params:
        cells.append(r.params or "-")
    cells += [r.outcome, _f(r.error, ".4g") + units, _f(r.error_percent, ".3f"), _f(r.paper_ratio, ".2f"),
              _f(r.bytes_ratio, ".2f"), _f(r.bits_per_joint_frame, ".3f"), _f(r.bits_per_bone_frame, ".3f"),
              _f(r.bytes, ",d"), _f(r.xz_bytes, ",d"), _f(r.xz_ratio, ".2f"), _f(r.encode_seconds, ".2f"),
              _f(r.decode_poses_per_second, ",.0f")]
    return cells


def _summary_cells(s: BenchSummary, reps: bool, params: bool) -> list[str]:
    cells = [s.codec]
    if reps:
        cells.append(s.representation)
    cells.append(_bound_text(s.max_error))
    if params:
        cells.append(s.params or "-")
    cells += [f"{s.ok}/{s.runs}", str(s.failed + s.errors), _f(s.median_error_percent, ".3f"),
              _f(s.median_paper_ratio, ".2f"), _f(s.median_bytes_ratio, ".2f"),
              _f(s.median_bits_per_joint_frame, ".3f"), _f(s.median_bits_per_bone_frame, ".3f"),
              _f(s.total_bytes, ",d"), _f(s.total_xz_bytes, ",d"),
              _f(None if not (s.total_bytes and s.total_xz_bytes) else s.total_xz_bytes / s.total_bytes, ".2f"),
              _f(s.median_encode_seconds, ".2f"), _f(s.median_decode_poses_per_second, ",.0f")]
    return cells


def _layout(header: list[str], body: list[list[str]], markdown: bool, right: set[int]) -> list[str]:
    if markdown:
        esc = [[c.replace("|", "\\|") for c in row] for row in [header] + body]
        lines = ["| " + " | ".join(esc[0]) + " |",
                 "|" + "|".join("---:" if i in right else "---" for i in range(len(header))) + "|"]
        return lines + ["| " + " | ".join(row) + " |" for row in esc[1:]]
    widths = [max(len(row[i]) for row in [header] + body) for i in range(len(header))]

    def line(row: list[str]) -> str:
        return "  ".join(c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(row, widths))).rstrip()

    return [line(header), "  ".join("-" * w for w in widths)] + [line(row) for row in body]


def format_table(rows: Sequence[BenchRow], summaries: Sequence[BenchSummary] | None = None, *,
                 markdown: bool = False) -> str:
    """The runs and, below them, the medians per group, as aligned text (or Markdown tables): every column
    (``bench --wide``, and ``bench.md``).

    Columns: clip, frames, joints, codec, (representation when several), bound, (parameters for a sweep),
    outcome, L-inf (file units), L-inf % of height, the paper's ratio, bytes ratio (float32 channels / file
    bytes), bits per joint per frame (the file), payload bits per bone per frame (the codec's bytes; bones =
    joints + end sites, ACL's count), bytes, the ``xz -9`` bytes of the source and how many times smaller than it
    the result is, encode seconds, decode poses per second; then the totals line and the medians (with total
    bytes against total ``xz -9`` bytes).
    """
    summaries = summarize(rows) if summaries is None else summaries
    reps = len({r.representation for r in rows}) > 1
    params = any(r.params for r in rows)
    head = ["clip", "frames", "joints", "codec"] + (["representation"] if reps else []) + ["bound"] + \
        (["params"] if params else []) + ["outcome", "L-inf", "L-inf %", "paper ratio", "bytes ratio",
                                          "bits/joint/frame", "payload bits/bone/frame", "bytes", "xz -9 bytes",
                                          "vs xz -9", "encode s", "decode poses/s"]
    n = len(head)
    right = {1, 2} | set(range(n - 11, n))
    out = _layout(head, [_row_cells(r, reps, params) for r in rows], markdown, right)
    out += ["", totals_line(rows)]
    shead = ["codec"] + (["representation"] if reps else []) + ["bound"] + (["params"] if params else []) + \
        ["ok/runs", "failed", "median L-inf %", "paper ratio", "bytes ratio", "bits/joint/frame",
         "payload bits/bone/frame", "total bytes", "total xz -9", "vs xz -9", "encode s", "decode poses/s"]
    m = len(shead)
    out += ["", "Medians over the runs that succeeded (failed: bound not met or error); totals over them:", ""]
    out += _layout(shead, [_summary_cells(s, reps, params) for s in summaries], markdown, set(range(m - 12, m)))
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------------------------------------------------------
# CSV and JSON
# ---------------------------------------------------------------------------------------------------------------
def _csv_cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, dict):
        return json.dumps(v, sort_keys=True)
    return str(v)


def csv_text(rows: Sequence[BenchRow]) -> str:
    """The rows as CSV text (header :data:`COLUMNS`; floats written exactly, ``repr``; None as an empty cell;
    ``info`` as JSON)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    for r in rows:
        d = r.as_dict()
        writer.writerow([_csv_cell(d[c]) for c in COLUMNS])
    return buf.getvalue()


def write_csv(rows: Sequence[BenchRow], path: str | os.PathLike[str]) -> None:
    """Write the rows as CSV, atomically."""
    from ...io import atomic_path

    with atomic_path(path) as tmp:
        Path(tmp).write_text(csv_text(rows), encoding="utf-8")


_FIELD_TYPES = {f.name: f.type for f in dataclasses.fields(BenchRow)}


def _from_cell(name: str, text: str) -> Any:
    kind = str(_FIELD_TYPES[name])
    if name == "info":
        return json.loads(text) if text else {}
    if text == "" and "None" in kind:
        return None
    if kind.startswith("int"):
        return int(text)
    if kind.startswith("float"):
        return float(text)
    return text


def read_csv(path: str | os.PathLike[str]) -> list[BenchRow]:
    """Read rows written by :func:`write_csv`.

    Raises:
        FormatError: if the header is not :data:`COLUMNS` (or, from an older writer, a prefix of them) or a cell
            does not convert.
    """
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        # columns are appended within a layout version: an older file has a prefix of them
        if header is None or not header or tuple(header) != COLUMNS[:len(header)]:
            raise FormatError("not a motionrep bench CSV (unexpected header)", path)
        names = COLUMNS[:len(header)]
        rows = []
        for line, cells in enumerate(reader, start=2):
            try:
                rows.append(BenchRow(**{c: _from_cell(c, v) for c, v in zip(names, cells, strict=True)}))
            except (ValueError, TypeError) as exc:
                raise FormatError(f"bad row: {exc}", path, line) from None
    return rows


def machine_info() -> dict[str, Any]:
    """The machine and software a benchmark ran on: CPU model and count, load average, Python and library
    versions, the date (UTC)."""
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions: dict[str, str | None] = {}
    from importlib import metadata

    for dist in ("motionrep", "numpy", "scipy", "torch", "h5py", "matplotlib"):
        try:
            versions[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[dist] = None
    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        load = None
    return {"date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"), "cpu": cpu,
            "cpus": os.cpu_count(), "load_average": load, "python": platform.python_version(),
            "platform": platform.platform(), "versions": versions}


def bench_json(rows: Sequence[BenchRow], summaries: Sequence[BenchSummary] | None = None,
               settings: Mapping[str, Any] | None = None, machine: Mapping[str, Any] | None = None) -> dict:
    """The JSON document of a benchmark (layout in ``specs/bench.md``)."""
    summaries = summarize(rows) if summaries is None else summaries
    return {"format": BENCH_FORMAT, "format_version": BENCH_VERSION,
            "machine": dict(machine) if machine is not None else machine_info(),
            "settings": dict(settings or {}), "columns": list(COLUMNS), "rows": [r.as_dict() for r in rows],
            "medians": [s.as_dict() for s in summaries]}


def write_json(rows: Sequence[BenchRow], path: str | os.PathLike[str], **kwargs: Any) -> None:
    """Write :func:`bench_json` to ``path``, atomically (non-finite floats as null)."""
    from ...io import atomic_path

    doc = _finite(bench_json(rows, **kwargs))
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")


def _finite(obj: Any) -> Any:
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj
