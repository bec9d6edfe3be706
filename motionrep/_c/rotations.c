/* Rotation conversions over arrays: feature columns to quaternions (motionrep.model.rotations' *_columns_*
 * functions: reading BVH, the plain conversion functions) and the continuity pass of rotation vectors. */
#include <math.h>

#include "ccore.h"
#include "mr_rotconv.h"

/* out[t, joints[r]] = the quaternion of features[t, columns[r]] for every row t of the (T, C) features (float32 or
 * float64, read as float64) and every entry r, by `kind`; out is (T, J, 4) float32 or float64 (float32: the
 * float64 result rounded).  Euler entries read up to three columns, -1 ending them early, each factor about
 * axes[r, k].  Returns 0, or 2 (a quaternion of zero or non-finite length), 3 (a degenerate 6D encoding): the
 * other results are written all the same. */
int mr_columns_to_quat(int kind, const void *features, int f32, int64_t T, int64_t C, const int64_t *columns,
                       const int64_t *axes, const int64_t *joints, int64_t R, void *out, int out32, int64_t J)
{
    int64_t zero = 0, degenerate = 0;
    const float *X32 = (const float *)features;
    const double *X64 = (const double *)features;
    int width = kind == MR_QUAT ? 4 : kind == MR_ORTHO6D ? 6 : 3;
    for (int64_t t = 0; t < T; t++) {
        for (int64_t r = 0; r < R; r++) {
            const int64_t *cols = columns + width * r;
            double v[6], q[4] = {0.0, 0.0, 0.0, 1.0};
            int n = width;
            if (kind == MR_EULER || kind == MR_EULER_DEGREES)
                for (n = 0; n < 3 && cols[n] >= 0; n++) {
                }
            for (int k = 0; k < n; k++)
                v[k] = f32 ? (double)X32[t * C + cols[k]] : X64[t * C + cols[k]];
            switch (kind) {
            case MR_QUAT:
                zero += !mr_normalized(v[0], v[1], v[2], v[3], q);
                break;
            case MR_AXIS_ANGLE:
                mr_axis_angle(v[0], v[1], v[2], q);
                break;
            case MR_ORTHO6D:
                degenerate += !mr_ortho6d(v[0], v[1], v[2], v[3], v[4], v[5], q);
                break;
            default: /* Euler angles, the first factor leftmost */
                for (int k = 0; k < n; k++)
                    mr_euler_factor(q, v[k], (int)axes[3 * r + k], kind == MR_EULER_DEGREES);
            }
            int64_t o = (t * J + joints[r]) * 4;
            if (out32)
                for (int c = 0; c < 4; c++)
                    ((float *)out)[o + c] = (float)q[c];
            else
                for (int c = 0; c < 4; c++)
                    ((double *)out)[o + c] = q[c];
        }
    }
    return zero ? 2 : degenerate ? 3 : 0;
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
