"""Issue 25, closed-loop quantisation along the skeleton (prototype): payload bytes of ``transform`` with the
features quantised open loop (today) or depth by depth, each depth's targets recomputed from the decoded parents.

``tune OUT.jsonl MODE [MODE ...] [--clips other|cmu31] [--bounds 2,0.588,0.0588]``
    in one process, every clip read once, then for each mode every clip encoded at every bound by
    ``compress_motion(motion, "transform", max_error=bound)`` (the core verifies every payload), one row per mode
    appended to OUT: bytes per clip and bound, their sums, the encode time.

Modes: ``open`` (the codec as it is), ``orient`` (orientation feedback: a joint's local rotation becomes
``inv(decoded parent global) * true global``, sensitivities measured over the joint's direct children only),
``orient-opensens`` (the same retargeting, the open-loop sensitivities), ``pos`` (position feedback: the global
rotation of orientation feedback turned by the smallest rotation that points the joint at the true centroid of its
children from its decoded position; orientation feedback where that lever is shorter than 1e-3 of the longest
offset).

The prototype patches ``motionrep_transform._codec`` for the run (``_Plan`` and ``_sensitivity``) and gives the
encode context the chain through the motion and the representation's layout (root-quat-axis-angle only).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from acl import DATA  # noqa: E402


def _clips(which: str) -> list[Path]:
    from motionrep.io import read

    if which == "cmu31":
        return [p for p in sorted((DATA / "cmu").rglob("*.bvh")) if read(p).num_joints == 31]
    return sorted((DATA / "other").rglob("*.bvh"))


# ----------------------------------------------------------------------------------------------------------------
# the chain: depth groups of feature columns and retargeting from decoded parents (root-quat-axis-angle)

def _qmul(a, b):
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


def _qapply(q, v):
    u = q[..., :3]
    w = q[..., 3:]
    t = 2.0 * np.cross(u, np.broadcast_to(v, u.shape))
    return np.broadcast_to(v, u.shape) + w * t + np.cross(u, t)


def _qconj(q):
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


class Chain:
    """Depth groups of a root-quat-axis-angle layout and orientation feedback."""

    def __init__(self, motion, representation, position=False, multi=True):
        from motionrep.model.rotations import quat_normalize

        sk = motion.skeleton
        lay = representation.layout(sk)
        self.sk, self.lay = sk, lay
        depth = np.asarray(sk.depths, np.int64)
        J = sk.num_joints
        self.cols_of = {j: c for j, c in zip(lay.rotation_joints.tolist(), lay.rotation_columns)}
        tcols = {j: c for j, c in zip(sk.translated_joints.tolist(), lay.translation_columns)}
        groups: dict[int, list[int]] = {}
        groups.setdefault(0, []).extend([0, 1, 2])
        for j in range(J):
            cols = list(self.cols_of.get(j, [])) + (list(tcols.get(j, [])) if j != 0 else [])
            if cols:
                groups.setdefault(int(depth[j]), []).extend(cols)
        self.depth_of_group = sorted(groups)
        self.groups = [np.array(sorted(groups[d]), np.int64) for d in self.depth_of_group]
        self.joints_at = {d: [j for j in range(J) if depth[j] == d] for d in range(int(depth.max()) + 1)}
        local = quat_normalize(motion.rotations)
        G = np.empty_like(local)
        for j in range(J):
            p = sk.parents[j]
            G[:, j] = local[:, j] if p < 0 else _qmul(G[:, p], local[:, j])
        self.true_global = G
        self.depth = depth
        self.position = position
        self.multi = multi
        from motionrep.model.kinematics import global_positions
        self.true_pos = global_positions(motion)[:, :J]
        self.local_t = np.broadcast_to(sk.offsets, (motion.num_frames, J, 3)).copy()
        if sk.translated_joints.size:  # the true local translations (the prototype does not decode them)
            self.local_t[:, sk.translated_joints] = motion.joint_translations
        # per joint: the true vector to the centroid of its children (joints and end sites) when that is long
        self.lever = [None] * J
        if position:
            allpos = global_positions(motion)
            for j in range(J):
                pts = [k for k in range(J) if sk.parents[k] == j] + [
                    J + e for e in range(sk.num_end_sites) if sk.end_site_parents[e] == j]
                if not pts or (len(pts) > 1 and not self.multi):
                    continue
                v = allpos[:, pts].mean(axis=1) - allpos[:, j]
                if np.min(np.sqrt(np.sum(v * v, axis=1))) > 1e-3 * max(1e-9, float(np.abs(sk.offsets).max())):
                    self.lever[j] = v

    def decoded_globals(self, decoded, upto_depth):
        """Global rotations of the joints of depth < upto_depth from decoded features."""
        from motionrep.model.rotations import axis_angle_to_quat

        F = decoded.shape[0]
        J = self.sk.num_joints
        G = np.zeros((F, J, 4))
        for j in range(J):
            if self.depth[j] >= upto_depth:
                continue
            cols = self.cols_of.get(j)
            if cols is None:
                loc = np.zeros((F, 4))
                loc[:, 3] = 1.0
            elif j == 0:
                q = decoded[:, cols]
                nq = np.sqrt(np.sum(q * q, axis=1, keepdims=True))
                loc = np.where(nq > 1e-12, q / np.where(nq > 1e-12, nq, 1.0), np.array([0.0, 0.0, 0.0, 1.0]))
            else:
                loc = axis_angle_to_quat(decoded[:, cols])
            p = self.sk.parents[j]
            G[:, j] = loc if p < 0 else _qmul(G[:, p], loc)
        return G

    def decoded_positions(self, decoded, G, upto_depth):
        """Positions of the joints of depth < upto_depth from decoded features and their globals ``G``."""
        sk = self.sk
        F = decoded.shape[0]
        P = np.zeros((F, sk.num_joints, 3))
        for j in range(sk.num_joints):
            if self.depth[j] >= upto_depth:
                continue
            p = sk.parents[j]
            if p < 0:
                P[:, j] = decoded[:, :3]
            else:
                P[:, j] = P[:, p] + _qapply(G[:, p], self.local_t[:, j])
        return P

    def retarget(self, g, decoded, original):
        """Targets of the columns of group ``g`` given ``decoded`` (columns of earlier groups set)."""
        from motionrep.model.rotations import quat_to_axis_angle

        d = self.depth_of_group[g]
        out = original[:, self.groups[g]].copy()
        if d == 0:
            return out
        G = self.decoded_globals(decoded, d)
        if self.position:
            Pd = self.decoded_positions(decoded, G, d + 1)
        where = {c: i for i, c in enumerate(self.groups[g].tolist())}
        for j in self.joints_at[d]:
            cols = self.cols_of.get(j)
            if cols is None:
                continue
            p = self.sk.parents[j]
            Gj = self.true_global[:, j]
            if self.position and self.lever[j] is not None:
                a = self.lever[j]  # (F, 3) true vector from j to its children's centroid
                b = a + self.true_pos[:, j] - Pd[:, j]
                na, nb = np.sqrt(np.sum(a * a, axis=1)), np.sqrt(np.sum(b * b, axis=1))
                r = np.concatenate([np.cross(a, b), (na * nb + np.sum(a * b, axis=1))[:, None]], axis=1)
                r = r / np.sqrt(np.sum(r * r, axis=1, keepdims=True))
                Gj = _qmul(r, Gj)
            q = _qmul(_qconj(G[:, p]), Gj)
            v = quat_to_axis_angle(q)
            o = original[:, cols]
            theta = np.sqrt(np.sum(v * v, axis=1))
            safe = theta > 1e-12
            n = np.where(safe[:, None], v / np.where(safe, theta, 1.0)[:, None], 0.0)
            t = np.sum(n * o, axis=1)
            k = np.rint((t - theta) / (2 * np.pi))
            v = n * (theta + 2 * np.pi * k)[:, None]
            v = np.where(safe[:, None], v, 0.0)
            out[:, [where[c] for c in cols.tolist()]] = v
        return out

    def direct_mask(self):
        """``(D, J + E)`` bool: the points a feature's change moves when the loop restores the children."""
        sk, lay = self.sk, self.lay
        J, E = sk.num_joints, sk.num_end_sites
        mask = np.zeros((lay.width, J + E), bool)
        mask[:3] = True
        reach = np.sqrt(np.sum(self.local_t ** 2, axis=2)).max(axis=0)  # (J,) longest local offset over frames
        top = float(reach.max()) if reach.size else 1.0

        def points(j):  # direct children and end sites; a child at the joint itself passes on to its own
            out = [J + e for e in range(E) if sk.end_site_parents[e] == j]
            for k in range(J):
                if sk.parents[k] == j:
                    if reach[k] <= 1e-6 * top:
                        out += points(k)
                    else:
                        out.append(k)
            return out

        for j, cols in self.cols_of.items():
            pts = points(j)
            for c in cols:
                mask[c, pts] = True
        for j, cols in zip(sk.translated_joints.tolist(), lay.translation_columns):
            for c in cols:
                mask[c] = True
        return mask


# ----------------------------------------------------------------------------------------------------------------
# patches of the codec

def _patch(mode: str):
    from motionrep.pipeline import evaluate as ev
    from motionrep_transform import _codec
    from motionrep_transform._decoder import synthesised
    from motionrep_transform._wavelet import forward
    from motionrep.plugin.coding import MAX_MAGNITUDE, step_scale

    orig_plan, orig_sens = _codec._Plan, _codec._sensitivity
    if mode == "open":
        return lambda: None

    class ClosedPlan(orig_plan):
        chain: Chain = None

        def quantise(self, region_exp, rounding):
            ch = self.chain
            exps = self.exponents(np.asarray(region_exp, np.int64))
            steps = [step_scale(e) for e in exps]
            out = [np.zeros(e.shape, np.int64) for e in exps]
            decoded = np.zeros((self.num_frames, self.num_features))
            for g, cols in enumerate(ch.groups):
                target = ch.retarget(g, decoded, self.original)
                coeffs = forward(target, self.levels) if self.levels else [target.copy()]
                deq = []
                for a, (c, s) in enumerate(zip(coeffs, steps)):
                    st = s[:, cols]
                    m = np.floor(np.abs(c) / st + rounding)
                    if m.size and not float(m.max()) <= MAX_MAGNITUDE:
                        raise _codec.naming(_codec.BoundNotMetError("transform: steps too small", None, None),
                                            "max_error")
                    q = m.astype(np.int64) * np.sign(c).astype(np.int64)
                    out[a][:, cols] = q
                    deq.append(q * st)
                decoded[:, cols] = synthesised(deq, self.levels) if self.levels else deq[0]
            return out

    def closed_sensitivity(context, features, weights):
        summary, per_frame = orig_sens(context, features, weights)
        if mode.endswith("-opensens"):
            return summary, per_frame
        ch = context._chain
        mask = ch.direct_mask()
        x_all = np.asarray(features, dtype=np.float64)
        F, D = x_all.shape
        count = min(F, ev.SENSITIVITY_FRAMES, max(8, ev.SENSITIVITY_BUDGET // max(D, 1)))
        rows = np.unique(np.linspace(0, F - 1, count).round().astype(np.int64))
        x = x_all[rows]
        n = x.shape[0]
        h = 1e-6 * (1.0 + np.abs(x).max(axis=0))
        moved = np.repeat(x[None], D, axis=0)
        moved[np.arange(D), :, np.arange(D)] += h[:, None]
        base = context._positions(x)
        pos = context._positions(moved.reshape(D * n, D)).reshape(D, n, -1, 3)
        dist = np.sqrt(np.sum((pos - base[None]) ** 2, axis=-1))  # (D, n, P)
        dist = np.where(mask[:, None, :], dist, 0.0).max(axis=2)
        pf = (dist / h[:, None]).T
        return np.percentile(pf, _codec._SENSITIVITY_PERCENTILE, axis=0), pf

    orig_encode = _codec.TransformCodec.encode

    def encode(self, features, weights, context):
        chain = Chain(context.motion, context.representation, position=mode.startswith("pos"), multi=not mode.startswith("pos1"))
        context._chain = chain

        class P(ClosedPlan):
            pass

        P.chain = chain
        P.original = np.asarray(features, dtype=np.float64)
        _codec._Plan = P
        try:
            return orig_encode(self, features, weights, context)
        finally:
            _codec._Plan = orig_plan

    _codec._sensitivity = closed_sensitivity
    _codec.TransformCodec.encode = encode

    def undo():
        _codec._sensitivity = orig_sens
        _codec.TransformCodec.encode = orig_encode
    return undo


def tune(out: str, modes: list[str], which: str, bounds: list[float]) -> None:
    from motionrep.io import read
    from motionrep.pipeline.compress import compress_motion

    clips = _clips(which)
    motions = [(str(p.relative_to(DATA)), read(p)) for p in clips]
    for mode in modes:
        undo = _patch(mode)
        row = {"mode": mode, "clips": which, "bytes": {}, "sums": {}, "seconds": {}}
        try:
            for bound in bounds:
                t0 = time.process_time()
                per = {}
                for name, m in motions:
                    r = compress_motion(m, "transform", max_error=f"{bound:g}%")
                    per[name] = int(sum(int(np.asarray(a).nbytes) for a in r.container.arrays.values()))
                row["bytes"][str(bound)] = per
                row["sums"][str(bound)] = sum(per.values())
                row["seconds"][str(bound)] = round(time.process_time() - t0, 2)
                print(mode, bound, row["sums"][str(bound)], row["seconds"][str(bound)], flush=True)
        finally:
            undo()
        with open(out, "a") as fh:
            fh.write(json.dumps(row) + "\n")


def table(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    base = rows[0]
    for r in rows:
        cells = []
        for b, s in r["sums"].items():
            ratios = [r["bytes"][b][c] / base["bytes"][b][c] for c in r["bytes"][b] if c in base["bytes"].get(b, {})]
            med = statistics.median(ratios) if ratios else float("nan")
            cells.append(f"{b}%: {s} ({s / base['sums'][b]:.3f}, median/clip {med:.3f}, {r['seconds'][b]} s)")
        print(r["mode"], r["clips"], " | ".join(cells))


def main() -> None:
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("tune")
    t.add_argument("out")
    t.add_argument("modes", nargs="+")
    t.add_argument("--clips", default="other")
    t.add_argument("--bounds", default="2,0.588,0.0588")
    tb = sub.add_parser("table")
    tb.add_argument("path")
    a = ap.parse_args()
    if a.cmd == "tune":
        tune(a.out, a.modes, a.clips, [float(b) for b in a.bounds.split(",")])
    else:
        table(a.path)


if __name__ == "__main__":
    main()
