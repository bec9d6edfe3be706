/* Conversions to xyzw quaternions, one value at a time: plain C, no Python, every function static inline.
 *
 * The arithmetic of every conversion motionrep makes to quaternions (Euler angles in radians or degrees, a
 * rotation vector, a quaternion to normalise, a 6D encoding) and the sine and cosine they use.  Each expression is
 * written in the order of evaluation it must have (C evaluates a + b + c as (a + b) + c, as Python does): compiled
 * with -ffp-contract=off and without -ffast-math, every operation is one IEEE operation, so a value gives the same
 * bits on every x86-64 CPU, in any batch, vectorised or not.  These are the operations of the numba kernels they
 * replace (motionrep/model/poseplan.py, motionrep/jit.py), operation for operation: the same bits, checked on every
 * real clip (benchmarks/results/ccore_equivalence.md).
 *
 * Anything that converts feature columns to quaternions includes this header, so that there is one implementation
 * of each conversion.
 */
/* Included once as is (the functions under their own names), and once more by each loop file compiled twice
 * (mr_twice.h) with MR_RC defined as that copy's MR_FN, so that every copy has its own functions, compiled for its
 * target: the AVX2 copy's floor is then one instruction (the same value; SSE4.1's roundpd).  The names below are
 * written MR_RC(name) for that reason. */
#if defined(MR_RC) || !defined(MR_ROTCONV_H)
#ifndef MR_RC
#define MR_ROTCONV_H
#define MR_RC(name) name
#define MR_RC_PLAIN
#endif

#include <math.h>
#include <stdint.h>

/* floor(x) exactly, for any double (inf and nan are returned as they are, -0.0 stays -0.0).  With SSE4.1 (the AVX2
 * copies) floor() is one instruction; without it (the x86-64 baseline) the nearest integer by adding and removing
 * 2**52 (exact below 2**52 in magnitude), one less where that rounded up: selects that vectorise, no libm call.
 * An includer whose kernels are gcc target_clones (motionrep/_c/include/motionrep/mrkernels.h: the clones'
 * targets are not known to the preprocessor) defines MR_ROTCONV_FLOOR_BUILTIN: floor() itself, which gcc makes
 * one instruction in the AVX2 / AVX-512 clones and an inline sequence in the baseline one (-fno-trapping-math):
 * floor exactly, either way. */
static inline double MR_RC(mr_floor)(double x)
{
#if defined(__SSE4_1__) || defined(MR_ROTCONV_FLOOR_BUILTIN)
    return floor(x);
#else
    const double two52 = 4503599627370496.0;
    double big = copysign(two52, x), zero = copysign(0.0, x);
    double r = (x + big) - big; /* x rounded to a whole number (|x| < 2**52) */
    double below = r - 1.0;     /* computed whether needed or not: the selects below are then plain moves */
    r = r > x ? below : r;
    r = r == 0.0 ? zero : r;        /* floor(-0.0) is -0.0; floor(x in (-1, 0)) is -1, not zero */
    return fabs(x) < two52 ? r : x; /* else already a whole number, or inf, or nan */
#endif
}

/* rint(x) for x >= 0 (round half to even), exactly: for 0 <= x < 2**52, x + 2**52 has ulp 1, and 2**52 is even. */
static inline double MR_RC(mr_rint_nonneg)(double x)
{
    const double two52 = 4503599627370496.0;
    return x < two52 ? (x + two52) - two52 : x;
}

/* fdlibm's kernels: (sin r, cos r) for r in [-pi/4, pi/4] (the reduced argument of mr_sincos) */
static inline void MR_RC(mr_sincos_kernel)(double r, double *sin_out, double *cos_out)
{
    double z = r * r;
    double s = r + r * z * (-1.66666666666666324348e-01 + z * (8.33333333332248946124e-03 + z * (
        -1.98412698298579493134e-04 + z * (2.75573137070700676789e-06 + z * (
            -2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
    double tail = z * z * (4.16666666666666019037e-02 + z * (-1.38888888888741095749e-03 + z * (
        2.48015872894767294178e-05 + z * (-2.75573143513906633035e-07 + z * (
            2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
    double hz = 0.5 * z;
    double w = 1.0 - hz;
    *sin_out = s;
    *cos_out = w + (((1.0 - w) - hz) + tail);
}

/* (sin x, cos x) of a float64 x to within an ulp: Cody-Waite reduction by pi / 2 (three parts, exact products for
 * |x| < 2**20 pi / 2; beyond, the reduction loses accuracy gracefully but stays bounded), then fdlibm's kernels on
 * [-pi/4, pi/4].  motionrep.jit.sincos, operation for operation. */
static inline void MR_RC(mr_sincos)(double x, double *sin_out, double *cos_out)
{
    double n = MR_RC(mr_floor)(x * 0.6366197723675814 + 0.5);
    double r = ((x - n * 1.57079632673412561417e+00) - n * 6.07710050630396597660e-11) - n * 2.02226624871116645580e-21;
    double s, c;
    MR_RC(mr_sincos_kernel)(r, &s, &c);
    double quadrant = n - 4.0 * MR_RC(mr_floor)(n * 0.25);
    int odd = (quadrant == 1.0) | (quadrant == 3.0);
    double s1 = odd ? c : s;
    double c1 = odd ? -s : c;
    int upper = quadrant >= 2.0;
    *sin_out = upper ? -s1 : s1; /* selects, no branch: loops over it vectorise */
    *cos_out = upper ? -c1 : c1;
}

/* Whether mr_sincos(x) is mr_sincos_kernel(x) exactly: x whose quadrant n = floor(x 2 / pi + 1/2) is 0 (x within
 * about pi / 4 of 0; not NaN).  Then n is +0.0, each n * c of the reduction is +0.0 and x - +0.0 is x (-0.0 too),
 * the quadrant is +0.0 - 4 floor(+0.0) = +0.0, and no select changes a value. */
static inline int MR_RC(mr_sincos_first)(double x)
{
    double v = x * 0.6366197723675814 + 0.5;
    return (v >= 0.0) & (v < 1.0);
}

/* q = a b, the Hamilton product of two xyzw quaternions (q may be a). */
static inline void MR_RC(mr_product)(double ax, double ay, double az, double aw, double bx, double by, double bz, double bw,
                              double *q)
{
    q[0] = aw * bx + ax * bw + ay * bz - az * by;
    q[1] = aw * by - ax * bz + ay * bw + az * bx;
    q[2] = aw * bz + ax * by - ay * bx + az * bw;
    q[3] = aw * bw - ax * bx - ay * by - az * bz;
}

/* Half of `degrees` in radians, the angle reduced exactly to about [-360, 360] first (Sterbenz). */
static inline double MR_RC(mr_half_degrees)(double degrees)
{
    return (degrees - 720.0 * MR_RC(mr_floor)(degrees * (1.0 / 720.0) + 0.5)) * (3.141592653589793 / 360.0);
}

/* q = q b, b the rotation by `angle` (radians; degrees when `degrees`: reduced exactly to about [-360, 360] first)
 * about axis 0 (X), 1 (Y) or 2 (Z): one factor of an Euler conversion. */
static inline void MR_RC(mr_euler_factor)(double *q, double angle, int axis, int degrees)
{
    double s, cs;
    double half = degrees ? MR_RC(mr_half_degrees)(angle) : 0.5 * angle;
    MR_RC(mr_sincos)(half, &s, &cs);
    double ex = axis == 0 ? 1.0 : 0.0, ey = axis == 1 ? 1.0 : 0.0, ez = axis == 2 ? 1.0 : 0.0;
    MR_RC(mr_product)(q[0], q[1], q[2], q[3], s * ex, s * ey, s * ez, cs, q);
}

/* theta2 = |(x, y, z)|^2 of a rotation vector, in mr_axis_angle's order */
static inline double MR_RC(mr_axis_angle_theta2)(double x, double y, double z)
{
    return (x * x + y * y) + z * z;
}

/* sin(theta / 2) / theta from s = sin(theta / 2), theta and theta2 = theta^2: s / theta, or below 1e-3 its series
 * (no 0 / 0).  Where theta > 1e-3 is known (say theta2 > 2e-6: sqrt is correctly rounded and monotonic), it is
 * s / theta, and a loop may compute that alone (the series' two divisions are then never needed). */
static inline double MR_RC(mr_axis_angle_scale)(double s, double theta, double theta2)
{
    return theta > 1e-3 ? s / theta : 0.5 - theta2 / 48.0 + theta2 * theta2 / 3840.0;
}

/* q = the quaternion of rotation vector (x, y, z): [sin(theta / 2) v / theta, cos(theta / 2)], theta = |v|, with
 * sin(theta / 2) / theta by its series below 1e-3 (no 0 / 0), as scipy's Rotation.from_rotvec. */
static inline void MR_RC(mr_axis_angle)(double x, double y, double z, double *q)
{
    double theta2 = MR_RC(mr_axis_angle_theta2)(x, y, z);
    double theta = sqrt(theta2);
    double s, c;
    MR_RC(mr_sincos)(0.5 * theta, &s, &c);
    double k = MR_RC(mr_axis_angle_scale)(s, theta, theta2);
    q[0] = k * x;
    q[1] = k * y;
    q[2] = k * z;
    q[3] = c;
}

/* q = (x, y, z, w) / |(x, y, z, w)|; 0 if the length is zero or not finite (q then holds inf or nan), else 1. */
static inline int MR_RC(mr_normalized)(double x, double y, double z, double w, double *q)
{
    double n = sqrt(((x * x + y * y) + z * z) + w * w);
    q[0] = x / n;
    q[1] = y / n;
    q[2] = z / n;
    q[3] = w / n;
    return (n != 0.0) & (n < INFINITY);
}

/* q = the quaternion (w >= 0) of the 6D encoding [a1, a2] (the first two columns of a rotation matrix):
 * Gram-Schmidt, the cross product third, then the matrix's quaternion as scipy's Rotation.from_matrix (the largest
 * of the trace and the diagonal picks the formula; where w is zero, the first non-zero component is made
 * positive).  0 if the encoding is degenerate (a column zero or the two parallel), else 1. */
static inline int MR_RC(mr_ortho6d)(double a1x, double a1y, double a1z, double a2x, double a2y, double a2z, double *q)
{
    double n1 = sqrt((a1x * a1x + a1y * a1y) + a1z * a1z);
    double d = n1 > 0.0 ? n1 : 1.0;
    double b1x = a1x / d, b1y = a1y / d, b1z = a1z / d;
    double dot = (b1x * a2x + b1y * a2y) + b1z * a2z;
    double u2x = a2x - dot * b1x, u2y = a2y - dot * b1y, u2z = a2z - dot * b1z;
    double n2 = sqrt((u2x * u2x + u2y * u2y) + u2z * u2z);
    double b2x = u2x / n2, b2y = u2y / n2, b2z = u2z / n2;
    double b3x = b1y * b2z - b1z * b2y, b3y = b1z * b2x - b1x * b2z, b3z = b1x * b2y - b1y * b2x;
    double m00 = b1x, m10 = b1y, m20 = b1z;
    double m01 = b2x, m11 = b2y, m21 = b2z;
    double m02 = b3x, m12 = b3y, m22 = b3z;
    double trace = (m00 + m11) + m22;
    int use_t = (trace >= m00) & (trace >= m11) & (trace >= m22);
    int use_0 = !use_t & (m00 >= m11) & (m00 >= m22);
    int use_1 = !use_t & !use_0 & (m11 >= m22);
    double s21 = m21 + m12, d21 = m21 - m12;
    double s02 = m02 + m20, d02 = m02 - m20;
    double s10 = m10 + m01, d10 = m10 - m01;
    double e0 = 1.0 - trace + 2.0 * m00, e1 = 1.0 - trace + 2.0 * m11, e2 = 1.0 - trace + 2.0 * m22;
    double et = 1.0 + trace;
    double x = use_t ? d21 : (use_0 ? e0 : (use_1 ? s10 : s02));
    double y = use_t ? d02 : (use_0 ? s10 : (use_1 ? e1 : s21));
    double z = use_t ? d10 : (use_0 ? s02 : (use_1 ? s21 : e2));
    double w = use_t ? et : (use_0 ? d21 : (use_1 ? d02 : d10));
    double n = sqrt(((x * x + y * y) + z * z) + w * w);
    n = w < 0.0 ? -n : n;
    q[0] = x / n;
    q[1] = y / n;
    q[2] = z / n;
    q[3] = w / n;
    if (q[3] == 0.0) { /* q / -n is -(q / n) exactly: this is the sign the rule would have chosen */
        double qx = q[0], qy = q[1], qz = q[2];
        if (qx < 0.0 || (qx == 0.0 && (qy < 0.0 || (qy == 0.0 && qz < 0.0)))) {
            q[0] = -qx;
            q[1] = -qy;
            q[2] = -qz;
            q[3] = -q[3];
        }
    }
    return (n1 >= 1e-12) & (n2 >= 1e-12) & (n2 < INFINITY);
}

/* The rotation vector of quaternion (qx, qy, qz, qw), as scipy's Rotation.from_quat(q).as_rotvec() (rotations.c's
 * mr_quat_to_axis_angle, and the closed loop's targets), in two steps around libm's atan2 and sin:
 * mr_rotvec_unit: u = the quaternion normalised by its length and made canonical (w > 0, or w = 0 and the first
 * non-zero of x, y, z positive; selects, no branch); 0 if the length is zero or NaN (u then inf or nan), else 1.
 * mr_rotvec_scale: with angle = 2 atan2(|u's x, y, z|, u's w), the factor that takes u's x, y, z to the rotation
 * vector, angle / sin(angle / 2), or its series 2 + a^2 / 12 + 7 a^4 / 2880 (mr_rotvec_series) at angles <= 1e-3. */
static inline int MR_RC(mr_rotvec_unit)(double qx, double qy, double qz, double qw, double *u)
{
    double norm = sqrt(((qx * qx + qy * qy) + qz * qz) + qw * qw);
    double x = qx / norm, y = qy / norm, z = qz / norm, w = qw / norm;
    int flip = (w < 0.0) | ((w == 0.0) & ((x < 0.0) | ((x == 0.0) & ((y < 0.0) | ((y == 0.0) & (z < 0.0))))));
    u[0] = flip ? -x : x;
    u[1] = flip ? -y : y;
    u[2] = flip ? -z : z;
    u[3] = flip ? -w : w;
    return (norm != 0.0) & (norm == norm);
}

static inline double MR_RC(mr_rotvec_series)(double angle)
{
    double a2 = angle * angle;
    return (2.0 + a2 / 12.0) + 7.0 * a2 * a2 / 2880.0;
}

static inline double MR_RC(mr_rotvec_scale)(double angle)
{
    return angle <= 1e-3 ? MR_RC(mr_rotvec_series)(angle) : angle / sin(angle / 2.0);
}

/* mr_rotvec_scale with sin(angle / 2) taken as `sine`, the length of mr_rotvec_unit's x, y, z (their exact value
 * for the unit quaternion; within a few ulps of libm's sin(angle / 2) here): IEEE operations only, no libm call
 * (the closed loop's targets; not scipy's bits). */
static inline double MR_RC(mr_rotvec_scale_sine)(double angle, double sine)
{
    return angle <= 1e-3 ? MR_RC(mr_rotvec_series)(angle) : angle / sine;
}

#ifdef MR_RC_PLAIN
#undef MR_RC
#undef MR_RC_PLAIN
#endif
#endif
