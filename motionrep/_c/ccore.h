/* motionrep._ccore: the compiled core's kernels, in plain C (no Python in them); module.c is the Python glue.
 *
 * Every kernel is scalar IEEE float64 arithmetic, compiled with -ffp-contract=off and without -ffast-math
 * (setup.py), so a result has the same bits on every x86-64 CPU. */
#ifndef MR_CCORE_H
#define MR_CCORE_H

#include <stddef.h>
#include <stdint.h>

/* Loops that vectorise are compiled twice where the compiler can: for the x86-64 baseline and for AVX2, chosen
 * when the module is loaded (mr_simd: MR_SIMD_AVX2 on a CPU that has it, unless MOTIONREP_CCORE_BASELINE is set).
 * Both copies run the same IEEE operations (no fused multiply-add): the same bits, AVX2 does more at once. */
#if defined(__x86_64__) && defined(__GNUC__) && defined(__linux__)
#define MR_HAVE_AVX2 1
#else
#define MR_HAVE_AVX2 0
#endif
enum { MR_SIMD_BASELINE, MR_SIMD_AVX2 };
extern int mr_simd;

/* numbers.c: the whitespace-separated numbers of a byte block (the BVH MOTION block), see scan_block in
 * motionrep/io/_numbers.py.  info receives MR_SCAN_INFO counts. */
enum { MR_ROWS, MR_FIRST_WRONG, MR_WRONG_COUNT, MR_LAST_DATA, MR_EXTRA, MR_FIRST_DATA, MR_FALLBACKS, MR_TOKENS,
       MR_SCAN_INFO };
void mr_scan(const uint8_t *u, int64_t n, int64_t width, int64_t rows_max, int by_line, double *out,
             int64_t out_size, int64_t *fallback, int64_t capacity, int64_t *info);

/* shortest.c: float64 values as the shortest decimal text that reads back to them, MR_SHORTEST_WIDTH bytes of
 * room per value; returns the length written, *left the values left to Python's repr. */
#define MR_SHORTEST_WIDTH 26
int64_t mr_format_shortest(const double *flat, int64_t count, int64_t per_line, uint8_t *out, int64_t *fallback,
                           int64_t capacity, int64_t *left);

/* fk.c: forward kinematics, see motionrep/model/kinematics.py. */
typedef struct {
    int64_t F, J, E, P;
    const void *rot;   /* (F, J, 4) float32 or float64 */
    int rot_f32;
    const double *root, *offsets, *joint_t, *site_offsets; /* (F, 3), (J, 3), (F, P, 3), (E, 3) */
    const int64_t *parents, *translated, *site_parents;    /* (J,), (P,), (E,) */
    double *out_pos;                                       /* (F, J + E, 3) */
    double *out_rot;                                       /* (F, J + E, 4) or NULL */
} mr_fk_args;
int mr_fk(const mr_fk_args *a);
int mr_max_distances(const double *positions, const double *reference, int64_t N, int64_t M, int64_t P, double *out);

/* rotations.c: feature columns to quaternions; kinds as motionrep.model.poseplan's. */
enum { MR_QUAT, MR_AXIS_ANGLE, MR_EULER, MR_EULER_DEGREES, MR_ORTHO6D };
int mr_columns_to_quat(int kind, const void *features, int f32, int64_t T, int64_t C, const int64_t *columns,
                       const int64_t *axes, const int64_t *joints, int64_t R, void *out, int out32, int64_t J);
void mr_axis_angle_continuous(const double *theta, const double *axis, double *out, int64_t F, int64_t N);

/* euler.c: (n, 4) xyzw quaternions to (n, 3) Euler angles for seq (three of "xyz", lower case extrinsic, upper
 * case intrinsic, no axis twice in a row), radians or degrees, as scipy's Rotation.from_quat(q).as_euler(seq,
 * degrees); returns -1, or the index of the first quaternion of zero or NaN length (out is then
 * incomplete). */
int64_t mr_quat_to_euler(const double *quat, int64_t n, const char *seq, int degrees, double *out);

#endif
