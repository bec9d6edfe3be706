/* Forward kinematics: world positions (F, J + E, 3) and, when asked, world rotations (F, J + E, 4) (xyzw,
 * w >= 0), frame by frame, joint by joint (parents come first), composing unit quaternions in float64.
 *
 * Each local rotation is normalised first (so the result is exactly the pose the rotations stand for); per joint
 * one quaternion product and one vector rotation, v + w t + q_vec x t with t = 2 q_vec x v. */
#include <math.h>

#include "ccore.h"

#include <stdlib.h>

/* out[c B + i] = base[c B + i] + rotate(g, v) for lane i of the unit xyzw quaternions g[c B + i]: v + w t + q_vec x t
 * with t = 2 q_vec x v (the world position of a point at local offset v from its joint). */
static inline void rotate_add(const double *restrict g, const double *restrict base, int64_t i, int64_t B, double vx,
                              double vy, double vz, double *restrict out)
{
    double qx = g[i], qy = g[B + i], qz = g[2 * B + i], qw = g[3 * B + i];
    double tx = 2.0 * (qy * vz - qz * vy);
    double ty = 2.0 * (qz * vx - qx * vz);
    double tz = 2.0 * (qx * vy - qy * vx);
    out[i] = base[i] + vx + qw * tx + (qy * tz - qz * ty);
    out[B + i] = base[B + i] + vy + qw * ty + (qz * tx - qx * tz);
    out[2 * B + i] = base[2 * B + i] + vz + qw * tz + (qx * ty - qy * tx);
}

#define MR_FK_BLOCK 4 /* frames computed together, joint by joint: each joint's loops vectorise over them */

#define MR_IMPL "fk_impl.h"
#include "mr_twice.h"

/* FK of a->F frames (see ccore.h for the arrays).  Returns 0, or -1 if the scratch cannot be allocated. */
int mr_fk(const mr_fk_args *a)
{
    const int64_t J = a->J, E = a->E, B = MR_FK_BLOCK;
    int64_t *slot = malloc(sizeof(int64_t) * (size_t)(J ? J : 1));
    double *scratch = malloc(sizeof(double) * (size_t)((4 * J + 3 * (J + E)) * B + 1));
    if (!slot || !scratch) {
        free(slot);
        free(scratch);
        return -1;
    }
    for (int64_t j = 0; j < J; j++) /* which of the translated joints each joint is, or -1 (its OFFSET) */
        slot[j] = -1;
    for (int64_t k = 0; k < a->P; k++)
        slot[a->translated[k]] = k;
#if MR_HAVE_AVX2
    if (mr_simd == MR_SIMD_AVX2)
        fk_frames_avx2(a, slot, scratch, scratch + 4 * J * B);
    else
#endif
        fk_frames_baseline(a, slot, scratch, scratch + 4 * J * B);
    free(slot);
    free(scratch);
    return 0;
}

/* out[k] = the largest distance over the P points between positions[k] and reference[k % M] (positions (N, P, 3),
 * reference (M, P, 3)): sqrt((dx dx + dy dy) + dz dz), dx = position - reference, as numpy's
 * sqrt(sum((a - b) ** 2, axis=-1)) sums.  Returns 0 if a distance is not finite (NaN or infinity), else 1. */
int mr_max_distances(const double *positions, const double *reference, int64_t N, int64_t M, int64_t P, double *out)
{
    int finite = 1;
    for (int64_t k = 0; k < N; k++) {
        const double *a = positions + k * P * 3, *b = reference + (k % M) * P * 3;
        double best = 0.0;
        for (int64_t p = 0; p < P; p++) {
            double dx = a[3 * p] - b[3 * p], dy = a[3 * p + 1] - b[3 * p + 1], dz = a[3 * p + 2] - b[3 * p + 2];
            double d = sqrt((dx * dx + dy * dy) + dz * dz);
            finite &= d <= 1.79769313486231570815e308; /* false for NaN and infinity */
            best = d > best ? d : best;
        }
        out[k] = best;
    }
    return finite;
}
