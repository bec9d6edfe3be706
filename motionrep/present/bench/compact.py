"""The default ``motionrep bench`` table: within :data:`TABLE_WIDTH` columns, the size vocabulary of
:mod:`motionrep.pipeline.figures` first (every column: :func:`motionrep.present.bench.report.format_table`, ``--wide``)."""

from __future__ import annotations

from typing import Sequence

from .report import BenchRow, BenchSummary, _bound_text, _f, summarize, totals_line

__all__ = ["TABLE_WIDTH", "format_compact"]

#: The width the default (compact) table fits in.
TABLE_WIDTH = 120


def _clip_cell(text: str, width: int) -> str:
    return text if len(text) <= width else text[:max(width - 1, 1)] + "~"


def _compact_layout(header: list[tuple[str, str]], body: list[list[str]], right: set[int], shrink: list[int],
                    width: int) -> list[str]:
    """Aligned text with two-line headers, within ``width`` columns: the ``shrink`` columns (text) are cut
    (ending ``~``) until the table fits, down to 6 characters each."""
    widths = [max([len(h[0]), len(h[1])] + [len(row[i]) for row in body]) for i, h in enumerate(header)]
    total = sum(widths) + 2 * (len(widths) - 1)
    while total > width:
        i = max(shrink, key=lambda k: widths[k])
        if widths[i] <= 6:
            break
        widths[i] -= 1
        total -= 1

    def line(row: Sequence[str]) -> str:
        cells = [_clip_cell(c, w) for c, w in zip(row, widths)]
        return "  ".join(c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(cells, widths))
                         ).rstrip()

    return [line([h[0] for h in header]), line([h[1] for h in header]), "  ".join("-" * w for w in widths)] + \
        [line(row) for row in body]


def format_compact(rows: Sequence[BenchRow], summaries: Sequence[BenchSummary] | None = None, *,
                   width: int = TABLE_WIDTH, every_column: str = "format_table") -> str:
    """The default table, within ``width`` columns: clip, codec, (representation, parameters when they vary),
    bound, outcome, L-inf % of height, the size vocabulary of :mod:`motionrep.pipeline.figures` (payload and file bits
    per bone per frame, x smaller than the source) and encode seconds; then the totals line and the medians.
    Clip names and outcomes are cut (``~``) when the table would be wider; :func:`format_table` has every
    column (``bench --wide``), which the medians' heading names as ``every_column``."""
    summaries = summarize(rows) if summaries is None else summaries
    reps = len({r.representation for r in rows}) > 1
    params = any(r.params for r in rows)
    head = [("", "clip"), ("", "codec")] + ([("", "representation")] if reps else []) + [("", "bound")] + \
        ([("", "params")] if params else []) + [("", "outcome"), ("L-inf", "% height"), ("payload", "bits/bone/frame"),
                                               ("file", "bits/bone/frame"), ("x smaller", "vs source"),
                                               ("encode", "s")]
    n = len(head)
    body = []
    for r in rows:
        cells = [r.clip, r.codec] + ([r.representation] if reps else []) + [_bound_text(r.max_error)] + \
            ([r.params or "-"] if params else [])
        outcome = "failed" if r.status == "failed" else r.outcome  # its best error: the L-inf column
        cells += [outcome, _f(r.error_percent, ".3f"), _f(r.payload_bits_per_bone_frame, ".3f"),
                  _f(r.file_bits_per_bone_frame, ".3f"), _f(r.ratio_vs_source, ".1f") + ("x" if r.ratio_vs_source
                                                                                         else ""),
                  _f(r.encode_seconds, ".2f")]
        body.append(cells)
    shrink = [0, n - 6] + [head.index(h) for h in (("", "params"), ("", "representation")) if h in head]
    out = _compact_layout(head, body, set(range(n - 5, n)), shrink, width)
    out += ["", totals_line(rows)]
    shead = [("", "codec")] + ([("", "representation")] if reps else []) + [("", "bound")] + \
        ([("", "params")] if params else []) + [("", "ok/runs"), ("", "failed"), ("L-inf", "% height"),
                                               ("payload", "bits/bone/frame"), ("file", "bits/bone/frame"),
                                               ("x smaller", "vs source"), ("encode", "s")]
    m = len(shead)
    sbody = []
    for s in summaries:
        cells = [s.codec] + ([s.representation] if reps else []) + [_bound_text(s.max_error)] + \
            ([s.params or "-"] if params else [])
        cells += [f"{s.ok}/{s.runs}", str(s.failed + s.errors), _f(s.median_error_percent, ".3f"),
                  _f(s.median_payload_bits_per_bone_frame, ".3f"), _f(s.median_file_bits_per_bone_frame, ".3f"),
                  _f(s.median_ratio_vs_source, ".1f") + ("x" if s.median_ratio_vs_source else ""),
                  _f(s.median_encode_seconds, ".2f")]
        sbody.append(cells)
    out += ["", "Medians over the runs that succeeded (failed: bound not met or error); every column: "
                f"{every_column}.", ""]
    out += _compact_layout(shead, sbody, set(range(m - 7, m)),
                           [shead.index(h) for h in (("", "params"), ("", "representation")) if h in shead], width)
    return "\n".join(out) + "\n"
