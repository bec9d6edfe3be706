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
/* (n, 4) xyzw quaternions to (n, 3) rotation vectors as scipy's as_rotvec: -1, or the first of zero or NaN length */
int64_t mr_quat_to_axis_angle(const double *quat, int64_t n, double *out);
void mr_axis_angle_continuous(const double *theta, const double *axis, double *out, int64_t F, int64_t N);

/* edits.c: a candidate's features with their poses, FK and per-point distances, edited column by column (see
 * motionrep/pipeline/edits.py).  Arrays: the packed pose plan (plan_i, plan_f), the skeleton (parents, slot: each
 * joint's translation slot, 0 for the root and k + 1 for the k-th translated joint, else -1; site_parents; entry:
 * each joint's plan entry or -1; offsets, site_offsets), per feature column c the joints it moves
 * cjoints[cstart[c] .. cstart[c + 1]) (2 j + 1 where joint j's entry is decoded again, 2 j where only its FK is;
 * increasing j) and end sites csites[sstart[c] .. sstart[c + 1]), a bound on how far a change moves each of those
 * points (lip_kind[c] 0: none, 1: |change| l, 2 + r: l 2 x / sqrt(1 - x^2), x = |change| / |q| of the quaternion of
 * plan entry r, for x < 1/2; l the point's factor, lip[cstart[c] + k] for the joint cjoints[cstart[c] + k], then
 * lip[cstart[D] + sstart[c] + k] for the end site csites[sstart[c] + k]), and the state: X (D, F) feature-major, L (F, J, 4)
 * local rotations, GP (F, J, 4) the plan's world rotations (world plans), T (F, N, 3) translations, G (F, J, 4)
 * FK world rotations, W (F, J + E, 3) positions, ref (F, J + E, 3), dist (F, J + E). */
typedef struct {
    int64_t F, J, E, D, N;
    int world;
    const int64_t *plan_i;
    const double *plan_f;
    const int64_t *parents, *slot, *site_parents, *entry, *lip_kind, *cstart, *cjoints, *sstart, *csites;
    const double *offsets, *site_offsets, *lip, *ref;
    double *X, *L, *GP, *T, *G, *W, *dist;
} mr_edits;
/* The state from X, every frame: 0, 1 (a distance not finite), 2 (a quaternion of zero length), 3 (a degenerate
 * 6D encoding), -1 (no memory). */
int mr_edits_init(const mr_edits *s);
/* Edits (m, 3) int64 (column, first frame, count), deltas the counts' values one after the other: each in turn is
 * checked and, if every point it moves is within bound in every frame it touches, accepted[e] = 1 and (with
 * commit) applied; the state is exact again when it returns.  leads (m,) or NULL: the frame of each edit (from its
 * first) to check first, -1 for the frame of the largest change; set, for each edit that fails, to the frame
 * where it failed.  starts, scales (m,) or NULL: edit e's values are deltas[starts[e] + i] * scales[e] (deltas
 * then a pool of shapes the edits share) instead of the next counts[e] values of deltas.  Returns the number
 * accepted, or -1 (no memory). */
int64_t mr_edits_apply(const mr_edits *s, const int64_t *edits, int64_t m, const double *deltas, double bound,
                       int commit, uint8_t *accepted, int64_t *leads, const int64_t *starts, const double *scales);

/* out = base + the rotation of v by the unit xyzw quaternion g (fk.c's arithmetic, one point). */
static inline void mr_rotate_add(const double *g, const double *base, double vx, double vy, double vz, double *out)
{
    double qx = g[0], qy = g[1], qz = g[2], qw = g[3];
    double tx = 2.0 * (qy * vz - qz * vy);
    double ty = 2.0 * (qz * vx - qx * vz);
    double tz = 2.0 * (qx * vy - qy * vx);
    out[0] = base[0] + vx + qw * tx + (qy * tz - qz * ty);
    out[1] = base[1] + vy + qw * ty + (qz * tx - qx * tz);
    out[2] = base[2] + vz + qw * tz + (qx * ty - qy * tx);
}

/* chain.c: closed-loop targets along the skeleton (motionrep/pipeline/chain.py), joint-major state rot (J, F, 4)
 * and pos (J, F, 3).  mr_chain_pose: the n joints of one depth posed, joints[i] from its parent parents[i] (-1: the
 * root depth) with the local rotation of decoded (F, D)'s columns rcols[i] (kinds[i] 0: a quaternion, normalised;
 * 1: a rotation vector, its first 3; -1: none, the identity), mr_rotconv.h's conversions, and the translation
 * tcols[i] (3 columns of decoded, -1 taking tvals[i]).  With frames (m,) (NULL: every frame), only those frames:
 * the same arithmetic per frame.  Returns the number of quaternions of zero or non-finite length (their joints'
 * rows then hold inf or nan). */
typedef struct {
    int64_t F, D, n, m;
    const double *decoded, *tvals;
    const int64_t *kinds, *rcols, *joints, *parents, *tcols, *frames;
    double *rot, *pos;
} mr_chain_pose_args;
int64_t mr_chain_pose(const mr_chain_pose_args *a);
/* mr_chain_targets: for the n joints of one depth (parents[i]), the local rotation giving true_rot (n, F, 4) under
 * the decoded parent, turned first (lever[i] = m >= 0: position feedback) to point from the joint's decoded
 * position (the parent's plus local_offset (M, F, 3)) at true_pos + lever_vec ((M, F, 3), lever_len (M, F)); written
 * into out (F, C) at columns at[i] (4, or 3 and -1), a quaternion (kind 0) of the sign nearest truth (n, F, 4), a
 * rotation vector (kind 1) on the branch nearest truth's first 3.  Returns -1, or i F + f of a zero-length local
 * rotation of a rotation vector (out then incomplete).  With frames (m,) (NULL: every frame), only those frames of
 * out are written (the same arithmetic per frame). */
typedef struct {
    int64_t F, n, C, m;
    const double *rot, *pos, *true_rot, *local_offset, *true_pos, *lever_vec, *lever_len, *truth;
    const int64_t *parents, *lever, *kind, *at, *frames;
    double *out;
} mr_chain_targets_args;
int64_t mr_chain_targets(const mr_chain_targets_args *a);

/* euler.c: (n, 4) xyzw quaternions to (n, 3) Euler angles for seq (three of "xyz", lower case extrinsic, upper
 * case intrinsic, no axis twice in a row), radians or degrees, as scipy's Rotation.from_quat(q).as_euler(seq,
 * degrees); returns -1, or the index of the first quaternion of zero or NaN length (out is then
 * incomplete). */
int64_t mr_quat_to_euler(const double *quat, int64_t n, const char *seq, int degrees, double *out);

#endif
