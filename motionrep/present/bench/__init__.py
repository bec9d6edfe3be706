"""Benchmarks of codecs on clips: the grid codec x representation x bound (or fixed-size sweep) x clip.

The package is split by concern:

* :mod:`~motionrep.present.bench.grid`: the runs to make (:func:`bench_tasks`, sweeps :func:`parse_sweep`);
* :mod:`~motionrep.present.bench.run`: making them (:func:`run_task`, :func:`run_bench` on the batch engine);
* :mod:`~motionrep.present.bench.report`: the rows, their medians, the full table, CSV and JSON;
* :mod:`~motionrep.present.bench.compact`: the default table, within 120 columns;
* :mod:`~motionrep.present.bench.plot`: the rate-distortion plot;
* :mod:`~motionrep.present.bench.anchors`: ACL 2.1's strict-bound sizes, overlaid on the plot where a clip has them.

Every run goes through :meth:`motionrep.pipeline.compress.Pipeline.compress`, so what is measured is what ``motionrep
compress`` would write: the codec encodes, the payload is packed into ``.mrc`` bytes, decoded again from those
bytes and measured with the shared evaluator (:mod:`motionrep.pipeline.evaluate`: FK-based L-infinity error over every
joint and end site).  A bound the codec cannot meet is an outcome (a row with status ``"failed"`` and the best
error reached), not an error.

Each run gives one :class:`BenchRow` (column reference: ``specs/bench.md``):

- the clip (name, source, frames, joints, frame rate, character height);
- the run (codec, representation, requested bound, fixed parameters of a sweep, seed);
- the outcome (status, the codec's own short description ``K=5`` / ``rank=9`` (``Codec.describe``) or
  ``failed: best L-inf ...``), the error in file units and in percent of the character height, the four
  compression figures of :func:`motionrep.pipeline.figures.compression_figures`: first the size vocabulary of
  :mod:`motionrep.pipeline.figures` (payload and file bits per bone per frame, the ratio against the source file), then
  the paper's ratio, the bytes ratio against float32 channels and bits per joint per frame;
- the cost: encode seconds (``CompressResult.seconds``: features, encoding, packing and the two checks, after
  the codec's ``warm_up``), and decode speed: poses per second when decoding :data:`DEFAULT_DECODE_POSES` poses
  at random times in batches (through :func:`motionrep.pipeline.compress.decode_at`: codec decode, then the
  representation to local joint rotations), feature vectors per second (the codec alone), and the median time
  to decode one pose at an arbitrary time.

:func:`summarize` gives the medians per codec, representation, bound and sweep value over the runs that
succeeded, with the failure count.  :func:`format_table`, :func:`write_csv`, :func:`write_json` and
:func:`plot_rate_distortion` all take the same rows, so the table, the CSV, the JSON and the plot agree.
Clips are gathered by :func:`motionrep.pipeline.sources.collect_clips`, as for every many-clip command.
"""

from .grid import DEFAULT_DECODE_POSES, BenchTask, bench_tasks, codec_parameter_names, is_sweep, parse_sweep
from .plot import plain_log_ticks, plot_rate_distortion, plot_series, require_matplotlib
from .compact import TABLE_WIDTH, format_compact
from .report import (BENCH_FORMAT, BENCH_VERSION, COLUMNS, SUMMARY_COLUMNS, BenchRow, BenchSummary, bench_json,
                     csv_text, format_table, machine_info, read_csv, summarize, write_csv, write_json)
from .run import DECODE_BATCH, SINGLE_POSE_REPEATS, decode_speed, run_bench, run_task

__all__ = [
    "BENCH_FORMAT",
    "BENCH_VERSION",
    "DEFAULT_DECODE_POSES",
    "DECODE_BATCH",
    "SINGLE_POSE_REPEATS",
    "BenchTask",
    "BenchRow",
    "BenchSummary",
    "COLUMNS",
    "SUMMARY_COLUMNS",
    "codec_parameter_names",
    "parse_sweep",
    "is_sweep",
    "bench_tasks",
    "run_task",
    "decode_speed",
    "run_bench",
    "summarize",
    "format_table",
    "format_compact",
    "TABLE_WIDTH",
    "plain_log_ticks",
    "csv_text",
    "write_csv",
    "read_csv",
    "write_json",
    "bench_json",
    "plot_rate_distortion",
    "plot_series",
    "require_matplotlib",
    "machine_info",
]
