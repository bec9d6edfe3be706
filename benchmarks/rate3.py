"""Issue 25, the encoder's decisions: ``transform`` before and after, from two runs of ``benchmarks/acl.py``.

One run of ``python benchmarks/acl.py run --codecs transform:slack=0,transform --clips cmu --runs FILE`` (every
CMU clip of ``../shared/data`` at 2 %, 0.588 % and 0.0588 %; each file compressed, decompressed to BVH and
checked with ``motionrep evaluate``): ``slack=0`` makes the integer choices of the search before this change,
the default spends the slack; the same coder, the same process, the same load. This script reads the JSONL file
and prints the tables of ``results/rate3.md``: per bound, the median and worst payload / ACL 2.1 strict-bound
size over the eight CMU-31 clips, the salsa clips' ratio of medians (ACL gives only its median), how many files
were verified within their bound, and the median encode and decode times of each setting (in that run, under
its load: not a timing benchmark; encode times beside main are measured on their own).

Usage::

    python benchmarks/rate3.py RUNS.jsonl [BEFORE_CODEC] [AFTER_CODEC]   # default: transform:slack=0 transform
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from acl import BOUNDS, acl_figures  # noqa: E402


def _rows(path: str, codec: str) -> dict[tuple[str, float], dict]:
    out = {}
    for line in Path(path).read_text().splitlines():
        r = json.loads(line)
        if r["codec"] == codec:
            out[(r["clip"], r["bound_percent"])] = r
    return out


def _ratio(r: dict, acl: float) -> float:
    return r["payload_bpbf"] / acl


def main(path: str, before: str = "transform:slack=0", after: str = "transform") -> None:
    acl = acl_figures()
    runs = {"before": _rows(path, before), "after": _rows(path, after)}
    print("| bound | run | CMU-31 median | CMU-31 worst | salsa ratio of medians | files verified | median encode s "
          "| median decode ms |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for bound in BOUNDS:
        for name, rows in runs.items():
            cmu31 = [_ratio(r, acl[(c, b)]) for (c, b), r in rows.items() if b == bound and (c, b) in acl
                     and r["status"] == "ok"]
            salsa = [r["payload_bpbf"] for (c, b), r in rows.items() if b == bound and "salsa" in c
                     and r["status"] == "ok"]
            at = [r for (c, b), r in rows.items() if b == bound]
            ok = sum(1 for r in at if r["status"] == "ok" and r.get("verified"))
            sal = f"{statistics.median(salsa) / acl[('salsa-median', bound)]:.3f}" if salsa else "–"
            print(f"| {bound:g} % | {name} | {statistics.median(cmu31):.3f} | {max(cmu31):.3f} | "
                  f"{sal} | {ok} / {len(at)} | "
                  f"{statistics.median(r['seconds'] for r in at if r['status'] == 'ok'):.2f} | "
                  f"{1e3 * statistics.median(r['decode_seconds'] for r in at if r['status'] == 'ok'):.1f} |")
    print()
    print("| clip | bound | before b/b/f | after b/b/f | after / before | after / ACL |")
    print("|---|---|---:|---:|---:|---:|")
    for (clip, bound), a in sorted(runs["after"].items(), key=lambda kv: (kv[0][1] * -1, kv[0][0])):
        b = runs["before"].get((clip, bound))
        if a["status"] != "ok" or b is None or b["status"] != "ok":
            print(f"| {clip} | {bound:g} % | {b and b['status']} | {a['status']} | | |")
            continue
        ref = acl.get((clip, bound))
        print(f"| {clip} | {bound:g} % | {b['payload_bpbf']:.3f} | {a['payload_bpbf']:.3f} | "
              f"{a['payload_bytes'] / b['payload_bytes']:.3f} | {'' if ref is None else f'{_ratio(a, ref):.3f}'} |")


if __name__ == "__main__":
    main(*sys.argv[1:4])
