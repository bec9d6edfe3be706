/* chain.c's loops that vectorise, included twice by chain.c (mr_twice.h: the x86-64 baseline and AVX2).  The two
 * give the same bits (the same IEEE operations, no fused multiply-add: -ffp-contract=off, and FMA is not enabled by
 * target("avx2")); AVX2 only does four values at once.  Not a header to include elsewhere. */
#define MR_RC MR_FN /* this copy's conversions, compiled for its target (mr_rotconv.h) */
#include "mr_rotconv.h"
#undef MR_RC

#define MR_CHAIN_BLOCK 64 /* frames converted together: a joint's inputs and local rotations for them in L1 */

/* mr_chain_pose (ccore.h): per joint, per block of frames, the local rotations converted in one loop over the
 * block (mr_rotconv.h's conversions, selects and no calls: it vectorises), then the block posed. */
static int64_t MR_FN(chain_pose)(const mr_chain_pose_args *a)
{
    const int64_t F = a->F, D = a->D, m = a->frames ? a->m : F;
    int64_t bad = 0;
    double V[3 * MR_CHAIN_BLOCK], W[MR_CHAIN_BLOCK], Q[4 * MR_CHAIN_BLOCK];
    double *V0 = V, *V1 = V + MR_CHAIN_BLOCK, *V2 = V + 2 * MR_CHAIN_BLOCK;
    double *QX = Q, *QY = Q + MR_CHAIN_BLOCK, *QZ = Q + 2 * MR_CHAIN_BLOCK, *QW = Q + 3 * MR_CHAIN_BLOCK;
    for (int64_t i = 0; i < a->n; i++) {
        const int64_t j = a->joints[i], p = a->parents[i], kind = a->kinds[i];
        const int64_t *tc = a->tcols + 3 * i, *rc = a->rcols + 4 * i;
        const double *tv = a->tvals + 3 * i;
        double *rot = a->rot + j * F * 4, *pos = a->pos + j * F * 3;
        for (int64_t r0 = 0; r0 < m; r0 += MR_CHAIN_BLOCK) {
            const int64_t mb = m - r0 < MR_CHAIN_BLOCK ? m - r0 : MR_CHAIN_BLOCK;
            const int64_t *fr = a->frames ? a->frames + r0 : NULL;
            /* the decoder's conversions of the block's rows (as motionrep.model.rotations' *_columns_*) */
            if (kind == 0 || kind == 1) {
                for (int64_t r = 0; r < mb; r++) {
                    const double *x = a->decoded + (fr ? fr[r] : r0 + r) * D;
                    V0[r] = x[rc[0]], V1[r] = x[rc[1]], V2[r] = x[rc[2]];
                    if (kind == 0)
                        W[r] = x[rc[3]];
                }
            }
            double q[4];
            if (kind == 0) {
                int64_t zero = 0;
                for (int64_t r = 0; r < mb; r++) {
                    zero += !MR_FN(mr_normalized)(V0[r], V1[r], V2[r], W[r], q);
                    QX[r] = q[0], QY[r] = q[1], QZ[r] = q[2], QW[r] = q[3];
                }
                bad += zero;
            } else if (kind == 1) {
                for (int64_t r = 0; r < mb; r++) {
                    MR_FN(mr_axis_angle)(V0[r], V1[r], V2[r], q);
                    QX[r] = q[0], QY[r] = q[1], QZ[r] = q[2], QW[r] = q[3];
                }
            } else {
                for (int64_t r = 0; r < mb; r++)
                    QX[r] = 0.0, QY[r] = 0.0, QZ[r] = 0.0, QW[r] = 1.0;
            }
            for (int64_t r = 0; r < mb; r++) {
                const int64_t f = fr ? fr[r] : r0 + r;
                const double *x = a->decoded + f * D;
                const double local[4] = {QX[r], QY[r], QZ[r], QW[r]};
                double t[3];
                for (int k = 0; k < 3; k++)
                    t[k] = tc[k] >= 0 ? x[tc[k]] : tv[k];
                if (p < 0) {
                    for (int k = 0; k < 4; k++)
                        rot[4 * f + k] = local[k];
                    for (int k = 0; k < 3; k++)
                        pos[3 * f + k] = t[k];
                } else {
                    const double *g = a->rot + (p * F + f) * 4;
                    qmul(g, local, rot + 4 * f);
                    qapply_add(g, a->pos + (p * F + f) * 3, t, pos + 3 * f);
                }
            }
        }
    }
    return bad;
}
