/* The column conversions' loops, included twice by rotations.c (mr_twice.h: the x86-64
 * baseline and AVX2).  The two give the same bits (the same IEEE operations, no fused
 * multiply-add: -ffp-contract=off, and FMA is not enabled by target("avx2")); AVX2 only does four values at once.
 * Not a header to include elsewhere. */
#define MR_RC MR_FN /* this copy's conversions, compiled for its target (mr_rotconv.h) */
#include "mr_rotconv.h"
#undef MR_RC

/* The quaternions of m rows (m <= MR_BLOCK) of one entry, from its inputs V[k * MR_BLOCK + i] (input k of row i),
 * into Q[c * MR_BLOCK + i]; every loop over the rows runs the same operations on each (selects, no branches), so it
 * vectorises.  Returns the number of rows whose quaternion has zero length (QUAT) or is degenerate (ORTHO6D). */
static int64_t MR_FN(convert_block)(int kind, const double *restrict V, int factors, const int64_t *axes, int64_t m,
                             double *restrict Q)
{
    double *QX = Q, *QY = Q + MR_BLOCK, *QZ = Q + 2 * MR_BLOCK, *QW = Q + 3 * MR_BLOCK;
    const double *V0 = V, *V1 = V + MR_BLOCK, *V2 = V + 2 * MR_BLOCK, *V3 = V + 3 * MR_BLOCK;
    const double *V4 = V + 4 * MR_BLOCK, *V5 = V + 5 * MR_BLOCK;
    int64_t bad = 0;
    double q[4];
    switch (kind) {
    case MR_QUAT:
        for (int64_t i = 0; i < m; i++) {
            bad += !MR_FN(mr_normalized)(V0[i], V1[i], V2[i], V3[i], q);
            QX[i] = q[0], QY[i] = q[1], QZ[i] = q[2], QW[i] = q[3];
        }
        break;
    case MR_AXIS_ANGLE:
        for (int64_t i = 0; i < m; i++) {
            MR_FN(mr_axis_angle)(V0[i], V1[i], V2[i], q);
            QX[i] = q[0], QY[i] = q[1], QZ[i] = q[2], QW[i] = q[3];
        }
        break;
    case MR_ORTHO6D:
        for (int64_t i = 0; i < m; i++) {
            bad += !MR_FN(mr_ortho6d)(V0[i], V1[i], V2[i], V3[i], V4[i], V5[i], q);
            QX[i] = q[0], QY[i] = q[1], QZ[i] = q[2], QW[i] = q[3];
        }
        break;
    default: /* Euler angles, the first factor leftmost */
        for (int64_t i = 0; i < m; i++)
            QX[i] = 0.0, QY[i] = 0.0, QZ[i] = 0.0, QW[i] = 1.0;
        for (int k = 0; k < factors; k++) {
            const double *A = V + k * MR_BLOCK;
            int axis = (int)axes[k];
            double ex = axis == 0 ? 1.0 : 0.0, ey = axis == 1 ? 1.0 : 0.0, ez = axis == 2 ? 1.0 : 0.0;
            if (kind == MR_EULER_DEGREES)
                for (int64_t i = 0; i < m; i++) {
                    double sn, cs;
                    MR_FN(mr_sincos)(MR_FN(mr_half_degrees)(A[i]), &sn, &cs);
                    MR_FN(mr_product)(QX[i], QY[i], QZ[i], QW[i], sn * ex, sn * ey, sn * ez, cs, q);
                    QX[i] = q[0], QY[i] = q[1], QZ[i] = q[2], QW[i] = q[3];
                }
            else
                for (int64_t i = 0; i < m; i++) {
                    double sn, cs;
                    MR_FN(mr_sincos)(0.5 * A[i], &sn, &cs);
                    MR_FN(mr_product)(QX[i], QY[i], QZ[i], QW[i], sn * ex, sn * ey, sn * ez, cs, q);
                    QX[i] = q[0], QY[i] = q[1], QZ[i] = q[2], QW[i] = q[3];
                }
        }
    }
    return bad;
}

/* mr_columns_to_quat (rotations.c) */
static int MR_FN(columns_to_quat)(int kind, const void *features, int f32, int64_t T, int64_t C, const int64_t *columns,
                       const int64_t *axes, const int64_t *joints, int64_t R, void *out, int out32, int64_t J)
{
    int64_t bad = 0;
    const float *X32 = (const float *)features;
    const double *X64 = (const double *)features;
    int width = kind == MR_QUAT ? 4 : kind == MR_ORTHO6D ? 6 : 3;
    double V[6 * MR_BLOCK], Q[4 * MR_BLOCK];
    for (int64_t t0 = 0; t0 < T; t0 += MR_BLOCK) {
        int64_t m = T - t0 < MR_BLOCK ? T - t0 : MR_BLOCK;
        for (int64_t r = 0; r < R; r++) {
            const int64_t *cols = columns + width * r;
            int n = width;
            if (kind == MR_EULER || kind == MR_EULER_DEGREES)
                for (n = 0; n < 3 && cols[n] >= 0; n++) {
                }
            for (int k = 0; k < n; k++) {
                double *Vk = V + k * MR_BLOCK;
                if (f32)
                    for (int64_t i = 0; i < m; i++)
                        Vk[i] = (double)X32[(t0 + i) * C + cols[k]];
                else
                    for (int64_t i = 0; i < m; i++)
                        Vk[i] = X64[(t0 + i) * C + cols[k]];
            }
            bad += MR_FN(convert_block)(kind, V, n, axes ? axes + 3 * r : NULL, m, Q);
            int64_t o = (t0 * J + joints[r]) * 4;
            if (out32) {
                float *O = (float *)out + o;
                for (int64_t i = 0; i < m; i++)
                    for (int c = 0; c < 4; c++)
                        O[i * J * 4 + c] = (float)Q[c * MR_BLOCK + i];
            } else {
                double *O = (double *)out + o;
                for (int64_t i = 0; i < m; i++)
                    for (int c = 0; c < 4; c++)
                        O[i * J * 4 + c] = Q[c * MR_BLOCK + i];
            }
        }
    }
    return !bad ? 0 : kind == MR_QUAT ? 2 : 3;
}

