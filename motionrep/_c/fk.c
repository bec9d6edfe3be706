/* Forward kinematics: world positions (F, J + E, 3) and, when asked, world rotations (F, J + E, 4) (xyzw,
 * w >= 0), frame by frame, joint by joint (parents come first), composing unit quaternions in float64.
 *
 * Each local rotation is normalised first (so the result is exactly the pose the rotations stand for); per joint
 * one quaternion product and one vector rotation, v + w t + q_vec x t with t = 2 q_vec x v. */
#include <math.h>

#include "ccore.h"

/* out = base + rotate(g, v) for a unit xyzw quaternion g. */
static inline void rotate_add(const double *g, double vx, double vy, double vz, const double *base, double *out)
{
    double qx = g[0], qy = g[1], qz = g[2], qw = g[3];
    double tx = 2.0 * (qy * vz - qz * vy);
    double ty = 2.0 * (qz * vx - qx * vz);
    double tz = 2.0 * (qx * vy - qy * vx);
    out[0] = base[0] + vx + qw * tx + (qy * tz - qz * ty);
    out[1] = base[1] + vy + qw * ty + (qz * tx - qx * tz);
    out[2] = base[2] + vz + qw * tz + (qx * ty - qy * tx);
}

/* One frame; ROT(k) reads component k of the frame's local rotations (float32 or float64). */
#define MR_FK_FRAME(ROT)                                                                                              \
    do {                                                                                                              \
        for (int64_t k = 0; k < P; k++)                                                                               \
            for (int c = 0; c < 3; c++)                                                                               \
                local[3 * a->translated[k] + c] = a->joint_t[(f * P + k) * 3 + c];                                   \
        for (int64_t j = 0; j < J; j++) {                                                                             \
            double x = (double)ROT(4 * j), y = (double)ROT(4 * j + 1), z = (double)ROT(4 * j + 2);                    \
            double w = (double)ROT(4 * j + 3);                                                                        \
            double n = sqrt(x * x + y * y + z * z + w * w);                                                           \
            x /= n;                                                                                                   \
            y /= n;                                                                                                   \
            z /= n;                                                                                                   \
            w /= n;                                                                                                   \
            int64_t p = a->parents[j];                                                                                \
            double *gj = g + 4 * j;                                                                                   \
            if (p < 0) {                                                                                              \
                gj[0] = x;                                                                                            \
                gj[1] = y;                                                                                            \
                gj[2] = z;                                                                                            \
                gj[3] = w;                                                                                            \
                for (int c = 0; c < 3; c++)                                                                           \
                    pos[3 * j + c] = a->root[3 * f + c];                                                              \
                continue;                                                                                             \
            }                                                                                                         \
            const double *gp = g + 4 * p;                                                                             \
            rotate_add(gp, local[3 * j], local[3 * j + 1], local[3 * j + 2], pos + 3 * p, pos + 3 * j);               \
            double ax = gp[0], ay = gp[1], az = gp[2], aw = gp[3];                                                    \
            gj[0] = aw * x + ax * w + ay * z - az * y;                                                                \
            gj[1] = aw * y - ax * z + ay * w + az * x;                                                                \
            gj[2] = aw * z + ax * y - ay * x + az * w;                                                                \
            gj[3] = aw * w - ax * x - ay * y - az * z;                                                                \
        }                                                                                                             \
    } while (0)

void mr_fk(const mr_fk_args *a)
{
    const int64_t F = a->F, J = a->J, E = a->E, P = a->P;
    double *g = a->scratch, *local = a->scratch + 4 * J; /* world rotations so far; local translations */
    for (int64_t j = 0; j < J; j++)
        for (int c = 0; c < 3; c++)
            local[3 * j + c] = a->offsets[3 * j + c];
    for (int64_t f = 0; f < F; f++) {
        double *pos = a->out_pos + f * (J + E) * 3;
        if (a->rot_f32) {
            const float *r = (const float *)a->rot + f * J * 4;
#define MR_ROT32(k) r[k]
            MR_FK_FRAME(MR_ROT32);
#undef MR_ROT32
        } else {
            const double *r = (const double *)a->rot + f * J * 4;
#define MR_ROT64(k) r[k]
            MR_FK_FRAME(MR_ROT64);
#undef MR_ROT64
        }
        for (int64_t e = 0; e < E; e++) {
            int64_t p = a->site_parents[e];
            const double *so = a->site_offsets + 3 * e;
            rotate_add(g + 4 * p, so[0], so[1], so[2], pos + 3 * p, pos + 3 * (J + e));
        }
        if (a->out_rot) {
            double *rot = a->out_rot + f * (J + E) * 4;
            for (int64_t i = 0; i < J + E; i++) {
                int64_t j = i < J ? i : a->site_parents[i - J];
                double sign = g[4 * j + 3] < 0 ? -1.0 : 1.0; /* w >= 0, as matrix_to_quat gives */
                for (int c = 0; c < 4; c++)
                    rot[4 * i + c] = sign * g[4 * j + c];
            }
        }
    }
}
