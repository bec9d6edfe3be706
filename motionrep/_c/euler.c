/* euler.c: quaternions to Euler angles, the values scipy's Rotation.from_quat(q).as_euler(seq, degrees) gives
 * (scipy's compiled backend: the quaternion normalised, then the direct method of Bernardes and Viollet, "Quaternion
 * to Euler angles conversion: a direct, general and computationally efficient method", PLoS ONE 17(11), 2022),
 * operation for operation with the same libm atan2 and hypot, so the same bits, without importing scipy.spatial
 * (about a quarter of a second of every process that writes BVH).  Checked against scipy on every order, random and
 * edge-case quaternions (tests/test_ccore.py). */
#include <math.h>

#include "ccore.h"

/* Euler angles (radians) of the unit quaternion (x, y, z, w) for the extrinsic axes i, j, k (i == k for a proper
 * order): the middle angle from the two half-norms, the outer ones from their half sum and half difference; a
 * middle angle within 1e-7 of 0 or pi (gimbal lock) sets the third angle to zero. */
static void angles_of(const double *q, int i, int j, int k, int symmetric, int sign, int extrinsic, double *ang)
{
    const double pi = 3.141592653589793;
    double a, b, c, d;
    if (symmetric) {
        a = q[3];
        b = q[i];
        c = q[j];
        d = q[k] * sign;
    } else {
        a = q[3] - q[j];
        b = q[i] + q[k] * sign;
        c = q[j] + q[3];
        d = q[k] * sign - q[i];
    }
    int first = extrinsic ? 0 : 2, third = extrinsic ? 2 : 0;
    ang[1] = 2.0 * atan2(hypot(c, d), hypot(a, b));
    int locked = fabs(ang[1]) <= 1e-7 ? 1 : fabs(ang[1] - pi) <= 1e-7 ? 2 : 0;
    double half_sum = atan2(b, a), half_diff = atan2(d, c);
    if (!locked) {
        ang[first] = half_sum - half_diff;
        ang[third] = half_sum + half_diff;
    } else {
        ang[2] = 0.0;
        ang[0] = locked == 1 ? 2.0 * half_sum : 2.0 * half_diff * (extrinsic ? -1.0 : 1.0);
    }
    if (!symmetric) {
        ang[third] *= sign;
        ang[1] -= pi / 2.0;
    }
    for (int e = 0; e < 3; e++) {
        if (ang[e] < -pi)
            ang[e] += 2.0 * pi;
        else if (ang[e] > pi)
            ang[e] -= 2.0 * pi;
    }
}

int64_t mr_quat_to_euler(const double *quat, int64_t n, const char *seq, int degrees, double *out)
{
    /* the axes as scipy takes them: lower case, reversed for an intrinsic (upper-case) order */
    int extrinsic = seq[0] >= 'x';
    int axis[3];
    for (int e = 0; e < 3; e++) {
        char c = seq[extrinsic ? e : 2 - e];
        axis[e] = (c | 0x20) - 'x';
    }
    int i = axis[0], j = axis[1], k = axis[2];
    int symmetric = i == k;
    if (symmetric)
        k = 3 - i - j;
    int sign = (i - j) * (j - k) * (k - i) / 2;  /* +1 for an even permutation of the axes, -1 for an odd one */
    for (int64_t r = 0; r < n; r++) {
        const double *p = quat + 4 * r;
        double norm = sqrt(((p[0] * p[0] + p[1] * p[1]) + p[2] * p[2]) + p[3] * p[3]);
        if (norm == 0.0 || isnan(norm))  /* as scipy: no rotation */
            return r;
        double q[4] = {p[0] / norm, p[1] / norm, p[2] / norm, p[3] / norm};
        double *ang = out + 3 * r;
        angles_of(q, i, j, k, symmetric, sign, extrinsic, ang);
        if (degrees)
            for (int e = 0; e < 3; e++)
                ang[e] = ang[e] * (180.0 / 3.141592653589793);
    }
    return -1;
}
