/* chain.c's loops that vectorise, included twice by chain.c (mr_twice.h: the x86-64 baseline and AVX2).  The two
 * give the same bits (the same IEEE operations, no fused multiply-add: -ffp-contract=off, and FMA is not enabled by
 * target("avx2")); AVX2 only does four values at once.  Not a header to include elsewhere. */
#define MR_RC MR_FN /* this copy's conversions, compiled for its target (mr_rotconv.h) */
#include "mr_rotconv.h"
#undef MR_RC

#define MR_CHAIN_BLOCK 64 /* frames converted together: a joint's inputs and local rotations for them in L1 */

/* mr_chain_pose (ccore.h): per joint, per block of frames, the local rotations converted in one loop over the
 * block (mr_rotconv.h's conversions, selects and no calls: it vectorises), then the block's inputs gathered into
 * rows of their own, posed in one loop (it vectorises), and written to the state. */
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
            double G[7 * MR_CHAIN_BLOCK], T[3 * MR_CHAIN_BLOCK], R[7 * MR_CHAIN_BLOCK]; /* rotation, position */
            for (int64_t r = 0; r < mb; r++) { /* gather: the translation, the parent's pose */
                const int64_t f = fr ? fr[r] : r0 + r;
                const double *x = a->decoded + f * D;
                for (int k = 0; k < 3; k++)
                    T[k * MR_CHAIN_BLOCK + r] = tc[k] >= 0 ? x[tc[k]] : tv[k];
                if (p >= 0) {
                    const double *g = a->rot + (p * F + f) * 4, *gp = a->pos + (p * F + f) * 3;
                    for (int k = 0; k < 4; k++)
                        G[k * MR_CHAIN_BLOCK + r] = g[k];
                    for (int k = 0; k < 3; k++)
                        G[(4 + k) * MR_CHAIN_BLOCK + r] = gp[k];
                }
            }
            for (int64_t r = 0; r < mb; r++) { /* posed (a loop that vectorises) */
                const double local[4] = {QX[r], QY[r], QZ[r], QW[r]};
                double t[3], out[7];
                for (int k = 0; k < 3; k++)
                    t[k] = T[k * MR_CHAIN_BLOCK + r];
                if (p < 0) {
                    for (int k = 0; k < 4; k++)
                        out[k] = local[k];
                    for (int k = 0; k < 3; k++)
                        out[4 + k] = t[k];
                } else {
                    double g[4], gp[3];
                    for (int k = 0; k < 4; k++)
                        g[k] = G[k * MR_CHAIN_BLOCK + r];
                    for (int k = 0; k < 3; k++)
                        gp[k] = G[(4 + k) * MR_CHAIN_BLOCK + r];
                    qmul(g, local, out);
                    qapply_add(g, gp, t, out + 4);
                }
                for (int k = 0; k < 7; k++)
                    R[k * MR_CHAIN_BLOCK + r] = out[k];
            }
            for (int64_t r = 0; r < mb; r++) { /* scatter */
                const int64_t f = fr ? fr[r] : r0 + r;
                for (int k = 0; k < 4; k++)
                    rot[4 * f + k] = R[k * MR_CHAIN_BLOCK + r];
                for (int k = 0; k < 3; k++)
                    pos[3 * f + k] = R[(4 + k) * MR_CHAIN_BLOCK + r];
            }
        }
    }
    return bad;
}

/* mr_chain_targets (ccore.h): per joint, per block of frames, the inputs of the block's frames gathered into rows
 * of their own (a loop of loads), then the local rotations in one loop, then (a quaternion) the sign nearest the
 * true one, or (a rotation vector) mr_rotvec_unit in one loop, libm's atan2 in a scalar one, the scale
 * (mr_rotvec_scale_sine: angle / s for scipy's angle / sin(angle / 2)) and the branch nearest the true one in
 * others, and the results written to their columns: the loops without calls or gathers vectorise.  Every value is
 * the arithmetic of tests/test_chain_kernels.py's numpy reference, bit for bit. */
static int64_t MR_FN(chain_targets)(const mr_chain_targets_args *a)
{
    enum { CG0, CW0 = 4, CT0 = 8, CP0 = 12, CO0 = 15, CA0 = 18, CTP0 = 21, CNA = 24, CIN }; /* rows of in */
    const int64_t F = a->F, frames = a->frames ? a->m : F;
    const double two_pi = 2.0 * 3.141592653589793;
    enum { B = MR_CHAIN_BLOCK };
    double in[CIN * B]; /* per input, its B values: parent rotation, true rotation, truth, parent position, local
                         * offset, lever vector, true point, lever length */
    double L[4 * B], U[4 * B], S[B], O[4 * B];
    double *L0 = L, *L1 = L + B, *L2 = L + 2 * B, *L3 = L + 3 * B;
    double *U0 = U, *U1 = U + B, *U2 = U + 2 * B, *U3 = U + 3 * B;
    int ok[B];
    for (int64_t i = 0; i < a->n; i++) {
        const int64_t p = a->parents[i], m = a->lever[i], kind = a->kind[i];
        const int64_t *at = a->at + 4 * i;
        for (int64_t r0 = 0; r0 < frames; r0 += B) {
            const int64_t nb = frames - r0 < B ? frames - r0 : B;
            const int64_t *fr = a->frames ? a->frames + r0 : NULL;
            for (int64_t r = 0; r < nb; r++) { /* gather */
                const int64_t f = fr ? fr[r] : r0 + r;
                const double *g = a->rot + (p * F + f) * 4, *w = a->true_rot + (i * F + f) * 4;
                const double *t = a->truth + (i * F + f) * 4;
                for (int k = 0; k < 4; k++)
                    in[(CG0 + k) * B + r] = g[k], in[(CW0 + k) * B + r] = w[k], in[(CT0 + k) * B + r] = t[k];
                if (m >= 0) {
                    const int64_t l = m * F + f; /* the lever point's row */
                    const double *pp = a->pos + (p * F + f) * 3, *lo = a->local_offset + 3 * l;
                    const double *av = a->lever_vec + 3 * l, *tp = a->true_pos + 3 * l;
                    for (int k = 0; k < 3; k++)
                        in[(CP0 + k) * B + r] = pp[k], in[(CO0 + k) * B + r] = lo[k], in[(CA0 + k) * B + r] = av[k],
                        in[(CTP0 + k) * B + r] = tp[k];
                    in[CNA * B + r] = a->lever_len[l];
                }
            }
            for (int64_t r = 0; r < nb; r++) { /* the local rotation giving the (turned) true one */
                double g[4], want[4], local[4];
                for (int k = 0; k < 4; k++)
                    g[k] = in[(CG0 + k) * B + r], want[k] = in[(CW0 + k) * B + r];
                double cg[4] = {-g[0], -g[1], -g[2], g[3]};
                if (m >= 0) { /* position feedback: turn the true rotation to point, from here, at the true point */
                    double pp[3], lo[3], av[3], b[3], here[3], turn[4], turned[4];
                    for (int k = 0; k < 3; k++)
                        pp[k] = in[(CP0 + k) * B + r], lo[k] = in[(CO0 + k) * B + r], av[k] = in[(CA0 + k) * B + r];
                    const double na = in[CNA * B + r];
                    qapply_add(g, pp, lo, here);
                    for (int k = 0; k < 3; k++)
                        b[k] = (av[k] + in[(CTP0 + k) * B + r]) - here[k];
                    double nb_ = sqrt((b[0] * b[0] + b[1] * b[1]) + b[2] * b[2]);
                    cross(av, b, turn);
                    turn[3] = na * nb_ + ((av[0] * b[0] + av[1] * b[1]) + av[2] * b[2]);
                    double size = sqrt(((turn[0] * turn[0] + turn[1] * turn[1]) + turn[2] * turn[2])
                                       + turn[3] * turn[3]);
                    double floor_ = na * nb_;
                    floor_ = floor_ < 1e-300 ? 1e-300 : floor_; /* numpy's maximum: a NaN stays NaN */
                    int turns = size > 1e-12 * floor_; /* else no turn (selects: the division's value unused) */
                    for (int k = 0; k < 4; k++)
                        turn[k] = turns ? turn[k] / size : (k == 3 ? 1.0 : 0.0);
                    qmul(turn, want, turned);
                    for (int k = 0; k < 4; k++)
                        want[k] = turned[k];
                }
                qmul(cg, want, local);
                L0[r] = local[0], L1[r] = local[1], L2[r] = local[2], L3[r] = local[3];
            }
            int width = 4;
            if (kind == 0) { /* a quaternion: the sign nearest the true one */
                const double *T0 = in + CT0 * B, *T1 = T0 + B, *T2 = T0 + 2 * B, *T3 = T0 + 3 * B;
                for (int64_t r = 0; r < nb; r++) {
                    double dot = ((L0[r] * T0[r] + L1[r] * T1[r]) + L2[r] * T2[r]) + L3[r] * T3[r];
                    int flip = dot < 0;
                    O[r] = flip ? -L0[r] : L0[r];
                    O[B + r] = flip ? -L1[r] : L1[r];
                    O[2 * B + r] = flip ? -L2[r] : L2[r];
                    O[3 * B + r] = flip ? -L3[r] : L3[r];
                }
            } else { /* a rotation vector (mr_quat_to_axis_angle's steps), on the branch (theta + 2 pi k) n nearest
                      * the true one */
                width = 3;
                int all = 1;
                for (int64_t r = 0; r < nb; r++) {
                    double u[4];
                    ok[r] = MR_FN(mr_rotvec_unit)(L0[r], L1[r], L2[r], L3[r], u);
                    all &= ok[r];
                    U0[r] = u[0], U1[r] = u[1], U2[r] = u[2], U3[r] = u[3];
                    S[r] = sqrt((u[0] * u[0] + u[1] * u[1]) + u[2] * u[2]);
                }
                if (!all)
                    for (int64_t r = 0; r < nb; r++)
                        if (!ok[r])
                            return i * F + (fr ? fr[r] : r0 + r);
                double angle[B];
                for (int64_t r = 0; r < nb; r++) /* libm: one at a time */
                    angle[r] = 2.0 * atan2(S[r], U3[r]);
                for (int64_t r = 0; r < nb; r++) /* sin(angle / 2) is S (the unit quaternion's): no libm sin */
                    S[r] = MR_FN(mr_rotvec_scale_sine)(angle[r], S[r]);
                const double *T0 = in + CT0 * B, *T1 = T0 + B, *T2 = T0 + 2 * B;
                for (int64_t r = 0; r < nb; r++) {
                    double v0 = S[r] * U0[r], v1 = S[r] * U1[r], v2 = S[r] * U2[r];
                    double theta = sqrt((v0 * v0 + v1 * v1) + v2 * v2);
                    int some = theta > 1e-12;
                    double d = some ? theta : 1.0, n0 = v0 / d, n1 = v1 / d, n2 = v2 / d;
                    double turns = rint((((n0 * T0[r] + n1 * T1[r]) + n2 * T2[r]) - theta) / two_pi);
                    double scale = theta + two_pi * turns;
                    O[r] = some ? n0 * scale : 0.0;
                    O[B + r] = some ? n1 * scale : 0.0;
                    O[2 * B + r] = some ? n2 * scale : 0.0;
                }
            }
            for (int64_t r = 0; r < nb; r++) { /* scatter */
                double *o = a->out + (fr ? fr[r] : r0 + r) * a->C;
                for (int k = 0; k < width; k++)
                    o[at[k]] = O[k * B + r];
            }
        }
    }
    return -1;
}
