/* Forward kinematics over a block of frames at a time, included twice by fk.c (mr_twice.h: the x86-64 baseline
 * and AVX2).  Per joint, every loop runs over the block's frames, the same
 * operations for each (so it vectorises); the operations of one frame are those of fk.c's description, in that
 * order, so every copy and every block size gives the same bits.  Not a header to include elsewhere.
 *
 * Scratch, per block: G[j][c][i] the world rotation of joint j (component c, frame i of the block), W[p][c][i] the
 * world position of point p (joints, then end sites). */
static void MR_FN(fk_frames)(const mr_fk_args *a, const int64_t *slot, double *restrict G, double *restrict W)
{
    const int64_t F = a->F, J = a->J, E = a->E, P = a->P, B = MR_FK_BLOCK;
    const double *restrict root = a->root, *restrict offsets = a->offsets, *restrict joint_t = a->joint_t;
    for (int64_t f0 = 0; f0 < F; f0 += B) {
        const int64_t m = F - f0 < B ? F - f0 : B;
        for (int64_t j = 0; j < J; j++) {
            double qx[MR_FK_BLOCK], qy[MR_FK_BLOCK], qz[MR_FK_BLOCK], qw[MR_FK_BLOCK];
            if (a->rot_f32) {
                const float *r = (const float *)a->rot + (f0 * J + j) * 4;
                for (int64_t i = 0; i < m; i++) {
                    qx[i] = (double)r[i * J * 4];
                    qy[i] = (double)r[i * J * 4 + 1];
                    qz[i] = (double)r[i * J * 4 + 2];
                    qw[i] = (double)r[i * J * 4 + 3];
                }
            } else {
                const double *r = (const double *)a->rot + (f0 * J + j) * 4;
                for (int64_t i = 0; i < m; i++) {
                    qx[i] = r[i * J * 4];
                    qy[i] = r[i * J * 4 + 1];
                    qz[i] = r[i * J * 4 + 2];
                    qw[i] = r[i * J * 4 + 3];
                }
            }
            for (int64_t i = 0; i < m; i++) { /* exactly unit: FK of the rotation each one stands for */
                double x = qx[i], y = qy[i], z = qz[i], w = qw[i];
                double n = sqrt(x * x + y * y + z * z + w * w);
                qx[i] = x / n;
                qy[i] = y / n;
                qz[i] = z / n;
                qw[i] = w / n;
            }
            double *restrict g = G + j * 4 * B, *restrict wj = W + j * 3 * B;
            const int64_t p = a->parents[j];
            if (p < 0) {
                for (int64_t i = 0; i < m; i++) {
                    g[i] = qx[i], g[B + i] = qy[i], g[2 * B + i] = qz[i], g[3 * B + i] = qw[i];
                    wj[i] = root[(f0 + i) * 3];
                    wj[B + i] = root[(f0 + i) * 3 + 1];
                    wj[2 * B + i] = root[(f0 + i) * 3 + 2];
                }
                continue;
            }
            double lx[MR_FK_BLOCK], ly[MR_FK_BLOCK], lz[MR_FK_BLOCK]; /* the joint's local translation */
            const int64_t k = slot[j];
            for (int64_t i = 0; i < m; i++) {
                const double *t = k >= 0 ? joint_t + ((f0 + i) * P + k) * 3 : offsets + 3 * j;
                lx[i] = t[0], ly[i] = t[1], lz[i] = t[2];
            }
            const double *restrict gp = G + p * 4 * B, *restrict wp = W + p * 3 * B;
            for (int64_t i = 0; i < m; i++) {
                rotate_add(gp, wp, i, B, lx[i], ly[i], lz[i], wj);
                double ax = gp[i], ay = gp[B + i], az = gp[2 * B + i], aw = gp[3 * B + i];
                double x = qx[i], y = qy[i], z = qz[i], w = qw[i];
                g[i] = aw * x + ax * w + ay * z - az * y;
                g[B + i] = aw * y - ax * z + ay * w + az * x;
                g[2 * B + i] = aw * z + ax * y - ay * x + az * w;
                g[3 * B + i] = aw * w - ax * x - ay * y - az * z;
            }
        }
        for (int64_t e = 0; e < E; e++) {
            const int64_t p = a->site_parents[e];
            const double *restrict gp = G + p * 4 * B, *restrict wp = W + p * 3 * B;
            double *restrict we = W + (J + e) * 3 * B;
            const double vx = a->site_offsets[3 * e], vy = a->site_offsets[3 * e + 1], vz = a->site_offsets[3 * e + 2];
            for (int64_t i = 0; i < m; i++)
                rotate_add(gp, wp, i, B, vx, vy, vz, we);
        }
        for (int64_t i = 0; i < m; i++) {
            double *pos = a->out_pos + (f0 + i) * (J + E) * 3;
            for (int64_t pt = 0; pt < J + E; pt++)
                for (int c = 0; c < 3; c++)
                    pos[3 * pt + c] = W[(pt * 3 + c) * B + i];
        }
        if (a->out_rot) {
            for (int64_t i = 0; i < m; i++) {
                double *rot = a->out_rot + (f0 + i) * (J + E) * 4;
                for (int64_t pt = 0; pt < J + E; pt++) {
                    int64_t j = pt < J ? pt : a->site_parents[pt - J];
                    double sign = G[(j * 4 + 3) * B + i] < 0 ? -1.0 : 1.0; /* w >= 0, as matrix_to_quat gives */
                    for (int c = 0; c < 4; c++)
                        rot[4 * pt + c] = sign * G[(j * 4 + c) * B + i];
                }
            }
        }
    }
}
