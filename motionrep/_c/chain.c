/* Closed-loop targets along the skeleton (motionrep/pipeline/chain.py's FeatureChain): one depth's joints posed
 * from the decoded features, and one depth's targets, over whole blocks (joint-major arrays, no Python per joint).
 * Every value is numpy's of chain.py's former elementwise code, operation for operation in the order numpy evaluated
 * it (left to right; sums over the last axis ((x0 + x1) + x2) + x3), with the same libm calls (sqrt, rint, and
 * the quaternion to rotation vector of mr_rotconv.h, rotations.c's, but for its sin(angle / 2), taken as the
 * normalised quaternion's vector length: IEEE operations, no libm sin): scalar IEEE arithmetic compiled without
 * FMA contraction or fast-math (setup.py), so the targets, and the payloads quantised from them, are the same bits
 * on every CPU.  The loops are chain_impl.h's, compiled for the x86-64 baseline and for AVX2 (the same bits). */
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

/* The AVX2 copies where mr_simd says so (the same bits: chain_impl.h). */
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
#if MR_HAVE_AVX2
    if (mr_simd == MR_SIMD_AVX2)
        return chain_targets_avx2(a);
#endif
    return chain_targets_baseline(a);
}
