/* The pose plan in C: a skeleton's feature columns to poses (motionrep.model.poseplan, which packs the plan).
 * No Python here: motionrep/_c/plan/module.c is the binding (motionrep._cplan). */
#ifndef MOTIONREP_PLAN_H
#define MOTIONREP_PLAN_H

#include <stddef.h>
#include <stdint.h>

/* the conversion kinds (motionrep.model.poseplan) */
enum { MR_QUAT, MR_AXIS_ANGLE, MR_EULER, MR_EULER_DEGREES, MR_ORTHO6D, MR_WORLD_QUAT, MR_WORLD_IDENTITY };

/* status of mr_plan_run: the numbers poseplan._raise_for turns into messages */
enum { MR_PLAN_OK = 0, MR_PLAN_NOT_FINITE = 1, MR_PLAN_ZERO_QUAT = 2, MR_PLAN_DEGENERATE_6D = 3 };

/* poses converted together: each joint's inputs and results for them stay in the L1 cache */
#define MR_PLAN_SUB 64

typedef struct {
    int64_t R, J, N, M;            /* entries, joints, translation rows (root + P), joints without an entry */
    int world;                     /* world-rotation plan */
    const int64_t *kinds, *cols, *axes, *joints, *parents, *ident, *tcols;   /* (R), (R, 6), (R, 3), ... */
    const double *tvals;           /* (N, 3) */
    int64_t rows;                  /* the feature rows the plan reads: max column + 1 */
    /* NULL (mr_plan_parse), or set by a caller that knows which features are constant over a clip: the entries
     * (R) whose columns all are (isconst[r]), and their quaternions (constq, (R, 4)), which mr_plan_run then
     * writes for every pose instead of converting the same values again (the values it would compute) */
    const unsigned char *isconst;
    const double *constq;
    /* NULL (mr_plan_parse), or the columns check_finite must look at, each once (nchecked of them): those the plan
     * reads, less any of constant entries (known finite) */
    const int64_t *checked;
    int64_t nchecked;
} mr_plan;

/* The plan in the packed arrays of PosePlan.packed(), checked so that running it reads and writes in bounds.
 * Returns 0, or -1 for a plan that does not hold together. */
int mr_plan_parse(const int64_t *plan_i, size_t n_i, const double *plan_f, size_t n_f, mr_plan *out);

/* Doubles of scratch mr_plan_run needs (world plans: the world rotations of a sub-block). */
size_t mr_plan_scratch(const mr_plan *plan);

/* A batch's float64 rotations streamed to memory past the cache (a batch larger than the cache: no cache line of it
 * is read before it is written).  Each sub-block's rotations are gathered in one half of `stage` (2 x MR_PLAN_SUB x
 * J x 4 doubles, 16-byte aligned), then written out with non-temporal stores a piece after each entry of the next
 * sub-block's conversion, in this call or the next, so that the memory writes overlap the arithmetic instead of
 * stalling it.  Set `stage` (and zero the rest) before the first call; mr_plan_flush writes what is left. */
typedef struct {
    double *stage;
    int half;            /* the half the next sub-block is gathered in */
    const double *src;   /* the rows waiting: src[done, len) go to dst[done, len) */
    double *dst;
    size_t len, done;
} mr_stream;

/* Writes the rows mr_plan_run left waiting in `s` (if any) and orders the non-temporal stores before what follows. */
void mr_plan_flush(mr_stream *s);

/* Decode `count` poses from feature-major X (feature d of pose i at X[d * ldx + i], p->rows rows) into rot
 * (count, J, 4) float64 (or float32 when rot_f32), root (count, 3) and moved (count, N - 1, 3) (unused when N is 0).
 * `scratch` holds mr_plan_scratch(plan) doubles (NULL when that is 0).  check_finite: refuse features the plan
 * reads that are NaN or infinite.  `stream` (or NULL): float64 rotations go through it (see mr_stream; the same
 * values; rows of this call may still be waiting in it when the call returns: mr_plan_flush after the last call).
 * Returns an MR_PLAN_* status (everything is written whatever it is). */
int mr_plan_run(const mr_plan *p, const double *X, ptrdiff_t ldx, ptrdiff_t count, int check_finite, void *rot,
                int rot_f32, double *root, double *moved, double *scratch, mr_stream *stream);

/* poses from which a batch's float64 rotations are streamed past the cache */
#define MR_PLAN_STREAM 8192

#endif
