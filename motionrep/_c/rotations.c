/* Rotation conversions over arrays: feature columns to quaternions (motionrep.model.rotations' *_columns_*
 * functions: reading BVH, the plain conversion functions), quaternions to rotation vectors and the continuity pass
 * of rotation vectors. */
#include <math.h>

#include "ccore.h"
#include "mr_rotconv.h"

#define MR_BLOCK 64 /* rows converted together: each entry's inputs and results for them stay in the L1 cache */

#define MR_IMPL "rotations_impl.h"
#include "mr_twice.h"

/* out[t, joints[r]] = the quaternion of features[t, columns[r]] for every row t of the (T, C) features (float32 or
 * float64, read as float64) and every entry r, by `kind`; out is (T, J, 4) float32 or float64 (float32: the
 * float64 result rounded).  Euler entries read up to three columns, -1 ending them early, each factor about
 * axes[r, k].  Returns 0, or 2 (a quaternion of zero or non-finite length), 3 (a degenerate 6D encoding): the
 * other results are written all the same.  The AVX2 copy where mr_simd says so (the same bits, faster). */
int mr_columns_to_quat(int kind, const void *features, int f32, int64_t T, int64_t C, const int64_t *columns,
                       const int64_t *axes, const int64_t *joints, int64_t R, void *out, int out32, int64_t J)
{
#if MR_HAVE_AVX2
    if (mr_simd == MR_SIMD_AVX2)
        return columns_to_quat_avx2(kind, features, f32, T, C, columns, axes, joints, R, out, out32, J);
#endif
    return columns_to_quat_baseline(kind, features, f32, T, C, columns, axes, joints, R, out, out32, J);
}

/* out[f, n] = (theta[f, n] + 2 pi k) axis[f, n] for f >= 1, k = rint((axis . out[f - 1, n] - theta) / 2 pi); a
 * rotation of theta <= 1e-12 takes the direction of out[f - 1, n] (or 0) as its axis.  The sums and products in
 * numpy's order ((a0 b0 + a1 b1) + a2 b2): the result the frame-by-frame numpy loop this replaces gave. */
void mr_axis_angle_continuous(const double *theta, const double *axis, double *out, int64_t F, int64_t N)
{
    const double two_pi = 2 * 3.141592653589793;
    for (int64_t f = 1; f < F; f++) {
        for (int64_t n = 0; n < N; n++) {
            const double *p = out + ((f - 1) * N + n) * 3;
            const double *ax = axis + (f * N + n) * 3;
            double p0 = p[0], p1 = p[1], p2 = p[2];
            double a0 = ax[0], a1 = ax[1], a2 = ax[2];
            double t = theta[f * N + n];
            if (t <= 1e-12) { /* no rotation: any axis will do, so keep the previous frame's */
                double size = sqrt((p0 * p0 + p1 * p1) + p2 * p2);
                if (size > 1e-12) {
                    a0 = p0 / size;
                    a1 = p1 / size;
                    a2 = p2 / size;
                } else {
                    a0 = a1 = a2 = 0.0;
                }
            }
            double k = rint(((a0 * p0 + a1 * p1) + a2 * p2 - t) / two_pi);
            double scale = t + two_pi * k;
            double *o = out + (f * N + n) * 3;
            o[0] = scale * a0;
            o[1] = scale * a1;
            o[2] = scale * a2;
        }
    }
}

/* out[r] = the rotation vector of quat[r] (xyzw): the values scipy's Rotation.from_quat(q).as_rotvec() gives,
 * operation for operation (the quaternion normalised by its length, made canonical (w > 0, or w = 0 and the first
 * non-zero of x, y, z positive), angle 2 atan2(|v|, w), v scaled by angle / sin(angle / 2), or by its series
 * 2 + a^2 / 12 + 7 a^4 / 2880 at angles <= 1e-3) with the same libm atan2 and sin: the same bits, without importing
 * scipy.spatial (about 0.15 s of a process) or scipy's per-call overhead (about a quarter of a millisecond per
 * thousand quaternions).  Returns -1, or the index of the first quaternion of zero or NaN length (scipy's error;
 * out is then incomplete). */
int64_t mr_quat_to_axis_angle(const double *quat, int64_t n, double *out)
{
    for (int64_t r = 0; r < n; r++) {
        const double *p = quat + 4 * r;
        double u[4];
        if (!mr_rotvec_unit(p[0], p[1], p[2], p[3], u))
            return r;
        double scale = mr_rotvec_scale(2.0 * atan2(sqrt((u[0] * u[0] + u[1] * u[1]) + u[2] * u[2]), u[3]));
        double *o = out + 3 * r;
        o[0] = scale * u[0], o[1] = scale * u[1], o[2] = scale * u[2];
    }
    return -1;
}
