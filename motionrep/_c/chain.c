/* Closed-loop targets along the skeleton (motionrep/pipeline/chain.py's FeatureChain): one depth's joints posed
 * from the decoded features, and one depth's targets, over whole blocks (joint-major arrays, no Python per joint).
 * Every value is numpy's of chain.py's former elementwise code, operation for operation in the order numpy evaluated
 * it (left to right; sums over the last axis ((x0 + x1) + x2) + x3), with the same libm calls (sqrt, rint, and
 * rotations.c's quaternion to rotation vector): scalar IEEE arithmetic compiled without FMA contraction or
 * fast-math (setup.py), so the targets, and the payloads quantised from them, are the same bits on every CPU. */
#include <math.h>

#include "ccore.h"
#include "mr_rotconv.h"

/* o = a b: the core's Hamilton product (mr_rotconv.h's mr_product, numpy's quat_multiply's order) */
static inline void qmul(const double *a, const double *b, double *o)
{
    mr_product(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], o);
}

static inline void cross(const double *a, const double *b, double *o)
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* o = base + the rotation of v by q: base + ((v + w t) + u x t), t = 2.0 (u x v) */
static inline void qapply_add(const double *q, const double *base, const double *v, double *o)
{
    double t[3], c[3], s[3];
    cross(q, v, c);
    t[0] = 2.0 * c[0], t[1] = 2.0 * c[1], t[2] = 2.0 * c[2];
    cross(q, t, s);
    for (int k = 0; k < 3; k++)
        o[k] = base[k] + ((v[k] + q[3] * t[k]) + s[k]);
}

#define MR_IMPL "chain_impl.h"
#include "mr_twice.h"

/* The AVX2 copy where mr_simd says so (the same bits: chain_impl.h). */
int64_t mr_chain_pose(const mr_chain_pose_args *a)
{
#if MR_HAVE_AVX2
    if (mr_simd == MR_SIMD_AVX2)
        return chain_pose_avx2(a);
#endif
    return chain_pose_baseline(a);
}

int64_t mr_chain_targets(const mr_chain_targets_args *a)
{
    const int64_t F = a->F, frames = a->frames ? a->m : F;
    const double two_pi = 2.0 * 3.141592653589793;
    for (int64_t i = 0; i < a->n; i++) {
        const int64_t p = a->parents[i], m = a->lever[i];
        const int64_t *at = a->at + 4 * i;
        for (int64_t r = 0; r < frames; r++) {
            const int64_t f = a->frames ? a->frames[r] : r;
            const double *g = a->rot + (p * F + f) * 4;
            double want[4], local[4], cg[4] = {-g[0], -g[1], -g[2], g[3]};
            for (int k = 0; k < 4; k++)
                want[k] = a->true_rot[(i * F + f) * 4 + k];
            if (m >= 0) { /* position feedback: turn the true rotation to point, from here, at the true point */
                const int64_t l = m * F + f; /* the lever point's row */
                const double *av = a->lever_vec + 3 * l, *tp = a->true_pos + 3 * l, na = a->lever_len[l];
                double here[3], b[3], turn[4], turned[4];
                qapply_add(g, a->pos + (p * F + f) * 3, a->local_offset + 3 * l, here);
                for (int k = 0; k < 3; k++)
                    b[k] = (av[k] + tp[k]) - here[k];
                double nb = sqrt((b[0] * b[0] + b[1] * b[1]) + b[2] * b[2]);
                cross(av, b, turn);
                turn[3] = na * nb + ((av[0] * b[0] + av[1] * b[1]) + av[2] * b[2]);
                double size = sqrt(((turn[0] * turn[0] + turn[1] * turn[1]) + turn[2] * turn[2]) + turn[3] * turn[3]);
                double floor_ = na * nb;
                if (floor_ < 1e-300) /* numpy's maximum: a NaN stays NaN */
                    floor_ = 1e-300;
                if (size > 1e-12 * floor_) {
                    for (int k = 0; k < 4; k++)
                        turn[k] = turn[k] / size;
                } else {
                    turn[0] = turn[1] = turn[2] = 0.0, turn[3] = 1.0;
                }
                qmul(turn, want, turned);
                for (int k = 0; k < 4; k++)
                    want[k] = turned[k];
            }
            qmul(cg, want, local);
            const double *near = a->truth + (i * F + f) * 4;
            double *o = a->out + f * a->C;
            if (a->kind[i] == 0) { /* a quaternion: the sign nearest the true one */
                double dot = ((local[0] * near[0] + local[1] * near[1]) + local[2] * near[2]) + local[3] * near[3];
                for (int k = 0; k < 4; k++)
                    o[at[k]] = dot < 0 ? -local[k] : local[k];
            } else { /* a rotation vector: the branch (theta + 2 pi k) n nearest the true one */
                double v[3];
                if (mr_quat_to_axis_angle(local, 1, v) >= 0)
                    return i * F + f;
                double theta = sqrt((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]);
                int ok = theta > 1e-12;
                double d = ok ? theta : 1.0, n[3] = {v[0] / d, v[1] / d, v[2] / d};
                double turns = rint((((n[0] * near[0] + n[1] * near[1]) + n[2] * near[2]) - theta) / two_pi);
                double scale = theta + two_pi * turns;
                for (int k = 0; k < 3; k++)
                    o[at[k]] = ok ? n[k] * scale : 0.0;
            }
        }
    }
    return -1;
}
