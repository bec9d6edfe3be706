/* The pose plan's kernel (see plan.h and motionrep/model/poseplan.py for what each conversion computes).
 *
 * Each conversion runs joint by joint over a sub-block of MR_PLAN_SUB poses, its arithmetic written as four
 * arrays (x, y, z, w) so that gcc vectorises the loops over poses; selects instead of branches.  The operations
 * and their order are those of the numba kernel this replaced (the conversions are the compiled core's,
 * motionrep/_c/mr_rotconv.h), so the results are the same bits. */
#include "plan.h"

#include <math.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "motionrep/mrkernels.h"

/* the packed header (poseplan._H_*) */
enum { H_R, H_J, H_P, H_M, H_KINDS, H_COLS, H_AXES, H_JOINTS, H_PARENTS, H_IDENT, H_TCOLS, H_WORLD, HEADER };

static int part(const int64_t *plan_i, size_t n_i, int64_t offset, int64_t count, const int64_t **out)
{
    if (offset < HEADER || count < 0 || (uint64_t)offset > n_i || (uint64_t)count > n_i - (uint64_t)offset)
        return -1;
    *out = plan_i + offset;
    return 0;
}

int mr_plan_parse(const int64_t *plan_i, size_t n_i, const double *plan_f, size_t n_f, mr_plan *p)
{
    static const int width[7] = {4, 3, 3, 3, 6, 4, 0};
    memset(p, 0, sizeof *p);
    if (n_i < HEADER)
        return -1;
    p->R = plan_i[H_R];
    p->J = plan_i[H_J];
    p->N = plan_i[H_P];
    p->M = plan_i[H_M];
    p->world = plan_i[H_WORLD] != 0;
    if (p->R < 0 || p->J < 0 || p->N < 0 || p->M < 0 || p->R > p->J || p->M > p->J || p->J > ((int64_t)1 << 40)
        || p->R > ((int64_t)1 << 40) || p->N > ((int64_t)1 << 40))
        return -1;
    if (part(plan_i, n_i, plan_i[H_KINDS], p->R, &p->kinds) || part(plan_i, n_i, plan_i[H_COLS], 6 * p->R, &p->cols)
        || part(plan_i, n_i, plan_i[H_AXES], 3 * p->R, &p->axes)
        || part(plan_i, n_i, plan_i[H_JOINTS], p->R, &p->joints)
        || part(plan_i, n_i, plan_i[H_PARENTS], p->J, &p->parents)
        || part(plan_i, n_i, plan_i[H_IDENT], p->M, &p->ident) || part(plan_i, n_i, plan_i[H_TCOLS], 3 * p->N, &p->tcols))
        return -1;
    if ((uint64_t)n_f < 3 * (uint64_t)p->N)
        return -1;
    p->tvals = plan_f;
    int64_t rows = 0;
    for (int64_t r = 0; r < p->R; r++) {
        int64_t kind = p->kinds[r], j = p->joints[r];
        if (kind < 0 || kind > 6 || j < 0 || j >= p->J)
            return -1;
        const int64_t *c = p->cols + 6 * r;
        int n = width[kind];
        if (kind == MR_EULER || kind == MR_EULER_DEGREES) {
            for (int k = 0; k < 3; k++) {
                if (c[k] < 0)
                    break;
                if (p->axes[3 * r + k] < 0 || p->axes[3 * r + k] > 2)
                    return -1;
                rows = c[k] + 1 > rows ? c[k] + 1 : rows;
            }
            continue;
        }
        if ((kind == MR_WORLD_QUAT || kind == MR_WORLD_IDENTITY) && (!p->world || j != r))
            return -1;
        for (int k = 0; k < n; k++) {
            if (c[k] < 0)
                return -1;
            rows = c[k] + 1 > rows ? c[k] + 1 : rows;
        }
    }
    if (p->world && p->R != p->J)
        return -1;
    for (int64_t j = 0; j < p->J; j++)
        if (p->parents[j] >= j || p->parents[j] < -1)
            return -1;
    for (int64_t e = 0; e < p->M; e++)
        if (p->ident[e] < 0 || p->ident[e] >= p->J)
            return -1;
    for (int64_t k = 0; k < 3 * p->N; k++) {
        if (p->tcols[k] < -1)
            return -1;
        rows = p->tcols[k] + 1 > rows ? p->tcols[k] + 1 : rows;
    }
    p->rows = rows;
    return 0;
}

size_t mr_plan_scratch(const mr_plan *p)
{
    return p->world ? (size_t)p->J * 4 * MR_PLAN_SUB : 0;
}

/* ---- the conversions: Q[i] for i < n from the feature rows ------------------------------------------------- */
/* Each is a loop over poses of the compiled core's conversion of one value (motionrep/_c/mr_rotconv.h, through
 * mrkernels.h): one implementation of every conversion, inlined here and vectorised over the poses. */

/* mr_axis_angle's arithmetic (its parts, in its order) in three loops over the n values, so that the CPU has many
 * of them in flight at once (the sum of squares and sqrt; the sine and cosine; the quotient and the products: each
 * a short chain, where the whole conversion is one long chain of dependent operations); and where every angle of
 * a run is well above 1e-3, the quotient alone (mr_axis_angle_scale: the series' two divisions never needed); and
 * where every half angle also lies in mr_sincos's first quadrant (mr_sincos_first), its kernels alone (the same
 * values), with the quotient and the products in their loop (the divisions overlap the next values' kernels).
 * `first`: look for that (the one-pose path does not: a pose's few values, one of them turned, and it costs) */
MR_INLINE void axis_angle(const double *MR_RESTRICT x0, const double *MR_RESTRICT x1, const double *MR_RESTRICT x2,
                          double *MR_RESTRICT QX, double *MR_RESTRICT QY, double *MR_RESTRICT QZ,
                          double *MR_RESTRICT QW, ptrdiff_t n, int first)
{
    double T2[MR_PLAN_SUB], T[MR_PLAN_SUB], S[MR_PLAN_SUB], C[MR_PLAN_SUB];
    for (ptrdiff_t a = 0; a < n; a += MR_PLAN_SUB) {
        ptrdiff_t m = n - a < MR_PLAN_SUB ? n - a : MR_PLAN_SUB;
        const double *MR_RESTRICT y0 = x0 + a, *MR_RESTRICT y1 = x1 + a, *MR_RESTRICT y2 = x2 + a;
        ptrdiff_t near = 0;  /* theta2 not above 2e-6 (or NaN): theta may be 1e-3 or less */
        ptrdiff_t turned = !first;  /* theta / 2 beyond the first quadrant of mr_sincos (or NaN); or not looked at */
        for (ptrdiff_t i = 0; i < m; i++) {
            double t2 = mr_axis_angle_theta2(y0[i], y1[i], y2[i]);
            T2[i] = t2;
            T[i] = sqrt(t2);
            near += t2 > 2e-6 ? 0 : 1;
            if (first)
                turned += mr_sincos_first(0.5 * T[i]) ? 0 : 1;
        }
        if (!turned && !near) {  /* the usual case: the kernels, the quotient and the products in one loop */
            for (ptrdiff_t i = 0; i < m; i++) {
                double sn, cs;
                mr_sincos_kernel(0.5 * T[i], &sn, &cs);
                double k = sn / T[i];
                QX[a + i] = k * y0[i]; QY[a + i] = k * y1[i]; QZ[a + i] = k * y2[i]; QW[a + i] = cs;
            }
            continue;
        }
        for (ptrdiff_t i = 0; turned && i < m; i++)
            mr_sincos(0.5 * T[i], &S[i], &C[i]);
        for (ptrdiff_t i = 0; !turned && i < m; i++)  /* (the same values: mr_sincos_first) */
            mr_sincos_kernel(0.5 * T[i], &S[i], &C[i]);
        for (ptrdiff_t i = 0; near && i < m; i++) {
            double k = mr_axis_angle_scale(S[i], T[i], T2[i]);
            QX[a + i] = k * y0[i]; QY[a + i] = k * y1[i]; QZ[a + i] = k * y2[i]; QW[a + i] = C[i];
        }
        for (ptrdiff_t i = 0; !near && i < m; i++) {
            double k = S[i] / T[i];
            QX[a + i] = k * y0[i]; QY[a + i] = k * y1[i]; QZ[a + i] = k * y2[i]; QW[a + i] = C[i];
        }
    }
}

/* the count of quaternions of zero or non-finite length */
MR_INLINE ptrdiff_t normalized(const double *MR_RESTRICT x0, const double *MR_RESTRICT x1,
                               const double *MR_RESTRICT x2, const double *MR_RESTRICT x3, double *MR_RESTRICT QX,
                               double *MR_RESTRICT QY, double *MR_RESTRICT QZ, double *MR_RESTRICT QW, ptrdiff_t n)
{
    ptrdiff_t zero = 0;
    for (ptrdiff_t i = 0; i < n; i++) {
        double q[4];
        zero += mr_normalized(x0[i], x1[i], x2[i], x3[i], q) ? 0 : 1;
        QX[i] = q[0]; QY[i] = q[1]; QZ[i] = q[2]; QW[i] = q[3];
    }
    return zero;
}

/* one factor of an Euler entry: Q = Q b, b the rotation by v[i] (radians, or degrees) about `axis`
 * (mr_euler_factor's arithmetic, its parts inlined so that the loop vectorises) */
MR_INLINE void euler_factor(const double *MR_RESTRICT v, int degrees, int axis, double *MR_RESTRICT QX,
                            double *MR_RESTRICT QY, double *MR_RESTRICT QZ, double *MR_RESTRICT QW, ptrdiff_t n)
{
    double ex = axis == 0 ? 1.0 : 0.0, ey = axis == 1 ? 1.0 : 0.0, ez = axis == 2 ? 1.0 : 0.0;
    for (ptrdiff_t i = 0; degrees && i < n; i++) {
        double s, cs, q[4];
        mr_sincos(mr_half_degrees(v[i]), &s, &cs);
        mr_product(QX[i], QY[i], QZ[i], QW[i], s * ex, s * ey, s * ez, cs, q);
        QX[i] = q[0]; QY[i] = q[1]; QZ[i] = q[2]; QW[i] = q[3];
    }
    for (ptrdiff_t i = 0; !degrees && i < n; i++) {
        double s, cs, q[4];
        mr_sincos(0.5 * v[i], &s, &cs);
        mr_product(QX[i], QY[i], QZ[i], QW[i], s * ex, s * ey, s * ez, cs, q);
        QX[i] = q[0]; QY[i] = q[1]; QZ[i] = q[2]; QW[i] = q[3];
    }
}

/* the same with an axis per element (the joints of one pose, side by side) */
MR_INLINE void euler_factor_each(const double *MR_RESTRICT v, int degrees, const int *MR_RESTRICT axis,
                                 double *MR_RESTRICT QX, double *MR_RESTRICT QY, double *MR_RESTRICT QZ,
                                 double *MR_RESTRICT QW, ptrdiff_t n)
{
    for (ptrdiff_t i = 0; i < n; i++) {
        double q[4] = {QX[i], QY[i], QZ[i], QW[i]};
        mr_euler_factor(q, v[i], axis[i], degrees);
        QX[i] = q[0]; QY[i] = q[1]; QZ[i] = q[2]; QW[i] = q[3];
    }
}

/* the count of degenerate encodings */
MR_INLINE ptrdiff_t ortho6d(const double *const *c, ptrdiff_t a, double *MR_RESTRICT QX, double *MR_RESTRICT QY,
                            double *MR_RESTRICT QZ, double *MR_RESTRICT QW, ptrdiff_t n)
{
    const double *MR_RESTRICT p0 = c[0] + a, *MR_RESTRICT p1 = c[1] + a, *MR_RESTRICT p2 = c[2] + a;
    const double *MR_RESTRICT p3 = c[3] + a, *MR_RESTRICT p4 = c[4] + a, *MR_RESTRICT p5 = c[5] + a;
    ptrdiff_t degenerate = 0;
    for (ptrdiff_t i = 0; i < n; i++) {
        double q[4];
        degenerate += mr_ortho6d(p0[i], p1[i], p2[i], p3[i], p4[i], p5[i], q) ? 0 : 1;
        QX[i] = q[0]; QY[i] = q[1]; QZ[i] = q[2]; QW[i] = q[3];
    }
    return degenerate;
}

/* ---- the kernel ---------------------------------------------------------------------------------------------- */

/* Most entries the one-pose path takes (its arrays are on the stack). */
#define ACROSS 256

/* One pose's rotations (pose i of X) with each kind's joints side by side, so that their arithmetic vectorises
 * across joints instead of poses (the one-pose path of the runtime decoder): the same conversions, element for
 * element, so the same bits.  Plans of world rotations (which go down the skeleton) do not take it. */
MR_CLONES
static void across_joints(const mr_plan *p, const double *X, ptrdiff_t ldx, ptrdiff_t i, double *o64, float *o32,
                          ptrdiff_t *zero, ptrdiff_t *degenerate)
{
    double in[6][ACROSS], Q[4][ACROSS], T[5][ACROSS];
    int64_t which[ACROSS], at[ACROSS];
    int axes[ACROSS];
    for (int kind = MR_QUAT; kind <= MR_ORTHO6D; kind++) {
        ptrdiff_t n = 0;
        for (ptrdiff_t r = 0; r < p->R; r++)
            if (p->kinds[r] == kind)
                which[n++] = r;
        if (!n)
            continue;
        int width = kind == MR_QUAT ? 4 : kind == MR_ORTHO6D ? 6 : 3;
        for (ptrdiff_t e = 0; e < n; e++)
            for (int k = 0; k < width; k++) {
                int64_t c = p->cols[6 * which[e] + k];
                in[k][e] = c >= 0 ? X[c * ldx + i] : 0.0;
            }
        if (kind == MR_AXIS_ANGLE) {
            axis_angle(in[0], in[1], in[2], Q[0], Q[1], Q[2], Q[3], n, 0);
        } else if (kind == MR_QUAT) {
            *zero += normalized(in[0], in[1], in[2], in[3], Q[0], Q[1], Q[2], Q[3], n);
        } else if (kind == MR_ORTHO6D) {
            const double *c[6] = {in[0], in[1], in[2], in[3], in[4], in[5]};
            *degenerate += ortho6d(c, 0, Q[0], Q[1], Q[2], Q[3], n);
        } else {  /* EULER, EULER_DEGREES: factor k of the entries that have one */
            for (ptrdiff_t e = 0; e < n; e++) {
                Q[0][e] = 0.0; Q[1][e] = 0.0; Q[2][e] = 0.0; Q[3][e] = 1.0;
            }
            for (int k = 0; k < 3; k++) {
                ptrdiff_t m = 0;
                for (ptrdiff_t e = 0; e < n; e++) {
                    if (p->cols[6 * which[e] + k] < 0)
                        continue;
                    at[m] = e;
                    T[0][m] = in[k][e];
                    axes[m] = (int)p->axes[3 * which[e] + k];
                    for (int q = 0; q < 4; q++)
                        T[1 + q][m] = Q[q][e];
                    m++;
                }
                if (!m)
                    break;
                euler_factor_each(T[0], kind == MR_EULER_DEGREES, axes, T[1], T[2], T[3], T[4], m);
                for (ptrdiff_t f = 0; f < m; f++)
                    for (int q = 0; q < 4; q++)
                        Q[q][at[f]] = T[1 + q][f];
            }
        }
        for (ptrdiff_t e = 0; e < n; e++) {
            int64_t j = p->joints[which[e]];
            if (o32) {
                for (int q = 0; q < 4; q++)
                    o32[4 * j + q] = (float)Q[q][e];
            } else {
                for (int q = 0; q < 4; q++)
                    o64[4 * j + q] = Q[q][e];
            }
        }
    }
}

/* whether a column of the plan's holds NaN or infinity in its first `count` values (each column once, from
 * p->checked when the caller made that list).  x * 0 is NaN exactly where x is NaN or infinite (a signed zero
 * elsewhere), and a sum of signed zeros is a zero: eight lanes of such sums over every column, looked at once at
 * the end (with the vector extension; a compare per value otherwise, and for a few poses) */
MR_INLINE int check_finite_columns(const mr_plan *p, const double *X, ptrdiff_t ldx, ptrdiff_t count)
{
    const int64_t *cols[2] = {p->cols, p->tcols};
    ptrdiff_t n[2] = {6 * p->R, 3 * p->N};
    if (p->checked) {
        cols[0] = p->checked;
        n[0] = p->nchecked;
        n[1] = 0;
    }
    int bad = 0;
#if defined(__GNUC__)
    typedef double v8d __attribute__((vector_size(64)));
    v8d zeros = {0.0};
#endif
    for (int part = 0; part < 2; part++)
        for (ptrdiff_t k = 0; k < n[part]; k++) {
            int64_t c = cols[part][k];
            if (c < 0)
                continue;
            const double *x = X + c * ldx;
            ptrdiff_t i = 0;
            if (count < 8) {  /* a few poses (the one-pose path): plain loops, no vector set-up per column */
                for (; i < count; i++)
                    bad |= !(fabs(x[i]) < INFINITY);
                continue;
            }
#if defined(__GNUC__)
            for (; i + 8 <= count; i += 8) {
                v8d v;
                memcpy(&v, x + i, sizeof v);
                zeros = zeros + v * 0.0;
            }
#endif
            for (; i < count; i++)
                bad |= !(fabs(x[i]) < INFINITY);
        }
#if defined(__GNUC__)
    for (int l = 0; l < 8; l++)
        bad |= zeros[l] != zeros[l];
#endif
    return bad;
}

/* dst[e] = src[e] for e < len (even) with non-temporal stores, dst 16-byte aligned: 64-byte stores (a whole cache
 * line each: 1.6 times the bandwidth of 16-byte ones on an AMD EPYC) where the CPU has AVX-512, 16-byte ones around
 * them and elsewhere */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(MR_NO_CLONES)
#include <immintrin.h>
__attribute__((target("avx512f"))) static void stream_rows_avx512(double *dst, const double *src, size_t len)
{
    size_t e = 0;
    for (; e < len && ((uintptr_t)(dst + e) & 63); e += 2)
        _mm_stream_pd(dst + e, _mm_loadu_pd(src + e));
    for (; e + 8 <= len; e += 8)
        _mm512_stream_pd(dst + e, _mm512_loadu_pd(src + e));
    for (; e < len; e += 2)
        _mm_stream_pd(dst + e, _mm_loadu_pd(src + e));
}
#define MR_STREAM_WIDE 1
#endif

static void stream_rows(double *dst, const double *src, size_t len)
{
#if defined(MR_STREAM_WIDE)
    static int wide = -1;
    if (wide < 0)
        wide = __builtin_cpu_supports("avx512f") ? 1 : 0;
    if (wide) {
        stream_rows_avx512(dst, src, len);
        return;
    }
#endif
#if defined(__SSE2__)
    for (size_t e = 0; e < len; e += 2)
        _mm_stream_pd(dst + e, _mm_loadu_pd(src + e));
#else
    memcpy(dst, src, len * sizeof(double));
#endif
}

/* the next `piece` doubles (or fewer) of the rows waiting in s */
static void stream_some(mr_stream *s, size_t piece)
{
    size_t end = s->len - s->done < piece ? s->len : s->done + piece;
    while (end < s->len && ((uintptr_t)(s->dst + end) & 63))  /* whole cache lines of dst in each piece */
        end += 2;
    stream_rows(s->dst + s->done, s->src + s->done, end - s->done);
    s->done = end;
}

void mr_plan_flush(mr_stream *s)
{
    if (s->len > s->done)
        stream_some(s, s->len - s->done);
    s->len = s->done = 0;
#if defined(__SSE2__)
    _mm_sfence();
#endif
}

MR_CLONES
int mr_plan_run(const mr_plan *p, const double *X, ptrdiff_t ldx, ptrdiff_t count, int check_finite, void *rot,
                int rot_f32, double *root, double *moved, double *G, mr_stream *sm)
{
    const ptrdiff_t R = p->R, J = p->J, N = p->N, M = p->M;
    double QX[MR_PLAN_SUB], QY[MR_PLAN_SUB], QZ[MR_PLAN_SUB], QW[MR_PLAN_SUB];
    double *final64 = rot_f32 ? NULL : (double *)rot;
    float *out32 = rot_f32 ? (float *)rot : NULL;
    /* through the stream (mr_stream): only when the plan writes every joint (no cache line read before it is
     * written) and rot is aligned for the stores */
    int stream = !rot_f32 && sm && ((uintptr_t)rot & 15) == 0 && p->R + p->M == p->J;
    /* the waiting rows, a piece after each entry: all of them by the end of the sub-block's entries */
    size_t piece = stream ? (size_t)MR_PLAN_SUB * J * 4 / (size_t)(R + 1) : 0;
    double *out64 = final64;
    if (check_finite && check_finite_columns(p, X, ldx, count))  /* every column the plan reads must be finite */
        return MR_PLAN_NOT_FINITE;
    ptrdiff_t zero = 0, degenerate = 0;
    int across = count <= 2 && !p->world && p->R <= ACROSS;  /* one pose or two: its joints side by side */
    for (ptrdiff_t a = 0; a < count; a += MR_PLAN_SUB) {
        ptrdiff_t n = count - a < MR_PLAN_SUB ? count - a : MR_PLAN_SUB;
        if (stream)  /* the sub-block's rows gathered in a half of the stage */
            out64 = sm->stage + (size_t)sm->half * MR_PLAN_SUB * J * 4 - (size_t)a * J * 4;
        /* (then the only sub-block; into the stage when streaming, as every entry of the sub-block) */
        for (ptrdiff_t e = 0; across && e < n; e++)
            across_joints(p, X, ldx, a + e, out64 ? out64 + (size_t)(a + e) * J * 4 : NULL,
                          out32 ? out32 + (size_t)(a + e) * J * 4 : NULL, &zero, &degenerate);
        for (ptrdiff_t r = 0; r < (across ? 0 : R); r++) {
            int64_t kind = p->kinds[r], j = p->joints[r];
            const int64_t *cc = p->cols + 6 * r;
            const double *c[6];
            for (int k = 0; k < 6; k++)
                c[k] = cc[k] >= 0 ? X + cc[k] * ldx : NULL;
            if (p->isconst && p->isconst[r]) {  /* columns constant over the clip: the quaternion known */
                const double *q = p->constq + 4 * r;
                for (ptrdiff_t i = 0; i < n; i++) {
                    QX[i] = q[0]; QY[i] = q[1]; QZ[i] = q[2]; QW[i] = q[3];
                }
            } else if (kind == MR_AXIS_ANGLE) {
                axis_angle(c[0] + a, c[1] + a, c[2] + a, QX, QY, QZ, QW, n, 1);
            } else if (kind == MR_QUAT) {
                zero += normalized(c[0] + a, c[1] + a, c[2] + a, c[3] + a, QX, QY, QZ, QW, n);
            } else if (kind == MR_EULER || kind == MR_EULER_DEGREES) {
                for (ptrdiff_t i = 0; i < n; i++) {
                    QX[i] = 0.0; QY[i] = 0.0; QZ[i] = 0.0; QW[i] = 1.0;
                }
                for (int k = 0; k < 3; k++) {
                    if (cc[k] < 0)
                        break;
                    euler_factor(c[k] + a, kind == MR_EULER_DEGREES, (int)p->axes[3 * r + k], QX, QY, QZ, QW, n);
                }
            } else if (kind == MR_ORTHO6D) {
                degenerate += ortho6d(c, a, QX, QY, QZ, QW, n);
            } else {  /* WORLD_QUAT, WORLD_IDENTITY: G_j = r / |r|, or G_parent; local = conj(G_parent) r */
                int64_t par = p->parents[j];
                double *gj = G + (size_t)j * 4 * MR_PLAN_SUB;
                if (kind == MR_WORLD_QUAT) {
                    zero += normalized(c[0] + a, c[1] + a, c[2] + a, c[3] + a, QX, QY, QZ, QW, n);
                    for (ptrdiff_t i = 0; i < n; i++) {
                        gj[i] = QX[i];
                        gj[MR_PLAN_SUB + i] = QY[i];
                        gj[2 * MR_PLAN_SUB + i] = QZ[i];
                        gj[3 * MR_PLAN_SUB + i] = QW[i];
                    }
                    if (par >= 0) {
                        const double *gp = G + (size_t)par * 4 * MR_PLAN_SUB;
                        for (ptrdiff_t i = 0; i < n; i++) {
                            double q[4];
                            mr_product(-gp[i], -gp[MR_PLAN_SUB + i], -gp[2 * MR_PLAN_SUB + i], gp[3 * MR_PLAN_SUB + i],
                                       QX[i], QY[i], QZ[i], QW[i], q);
                            QX[i] = q[0]; QY[i] = q[1]; QZ[i] = q[2]; QW[i] = q[3];
                        }
                    }
                } else {
                    const double *gp = par >= 0 ? G + (size_t)par * 4 * MR_PLAN_SUB : NULL;
                    for (ptrdiff_t i = 0; i < n; i++) {
                        QX[i] = 0.0; QY[i] = 0.0; QZ[i] = 0.0; QW[i] = 1.0;
                        gj[i] = gp ? gp[i] : 0.0;
                        gj[MR_PLAN_SUB + i] = gp ? gp[MR_PLAN_SUB + i] : 0.0;
                        gj[2 * MR_PLAN_SUB + i] = gp ? gp[2 * MR_PLAN_SUB + i] : 0.0;
                        gj[3 * MR_PLAN_SUB + i] = gp ? gp[3 * MR_PLAN_SUB + i] : 1.0;
                    }
                }
            }
            if (out32) {
                float *o = out32 + ((size_t)a * J + j) * 4;
                for (ptrdiff_t i = 0; i < n; i++, o += 4 * J) {
                    o[0] = (float)QX[i]; o[1] = (float)QY[i]; o[2] = (float)QZ[i]; o[3] = (float)QW[i];
                }
            } else {
                double *o = out64 + ((size_t)a * J + j) * 4;
                ptrdiff_t i = 0;
#if defined(__GNUC__)
                typedef double v4d __attribute__((vector_size(32)));
                typedef int64_t v4i __attribute__((vector_size(32)));
                for (; i + 4 <= n; i += 4, o += 16 * J) {  /* four poses: their x y z w from the four arrays */
                    v4d x, y, z, w;
                    memcpy(&x, QX + i, sizeof x);
                    memcpy(&y, QY + i, sizeof y);
                    memcpy(&z, QZ + i, sizeof z);
                    memcpy(&w, QW + i, sizeof w);
                    v4d xy02 = __builtin_shuffle(x, y, (v4i){0, 4, 2, 6}), xy13 = __builtin_shuffle(x, y, (v4i){1, 5, 3, 7});
                    v4d zw02 = __builtin_shuffle(z, w, (v4i){0, 4, 2, 6}), zw13 = __builtin_shuffle(z, w, (v4i){1, 5, 3, 7});
                    v4d p0 = __builtin_shuffle(xy02, zw02, (v4i){0, 1, 4, 5}), p2 = __builtin_shuffle(xy02, zw02, (v4i){2, 3, 6, 7});
                    v4d p1 = __builtin_shuffle(xy13, zw13, (v4i){0, 1, 4, 5}), p3 = __builtin_shuffle(xy13, zw13, (v4i){2, 3, 6, 7});
                    memcpy(o, &p0, sizeof p0);
                    memcpy(o + 4 * J, &p1, sizeof p1);
                    memcpy(o + 8 * J, &p2, sizeof p2);
                    memcpy(o + 12 * J, &p3, sizeof p3);
                }
#endif
#if defined(__SSE2__)
                for (; i + 2 <= n; i += 2, o += 8 * J) {  /* two poses: x y, z w of each from the four arrays */
                    __m128d x = _mm_loadu_pd(QX + i), y = _mm_loadu_pd(QY + i);
                    __m128d z = _mm_loadu_pd(QZ + i), w = _mm_loadu_pd(QW + i);
                    _mm_storeu_pd(o, _mm_unpacklo_pd(x, y));
                    _mm_storeu_pd(o + 2, _mm_unpacklo_pd(z, w));
                    _mm_storeu_pd(o + 4 * J, _mm_unpackhi_pd(x, y));
                    _mm_storeu_pd(o + 4 * J + 2, _mm_unpackhi_pd(z, w));
                }
#endif
                for (; i < n; i++, o += 4 * J) {
                    o[0] = QX[i]; o[1] = QY[i]; o[2] = QZ[i]; o[3] = QW[i];
                }
            }
            if (stream && sm->len > sm->done)  /* a piece of the rows waiting, while the next entry computes */
                stream_some(sm, piece);
        }
        for (ptrdiff_t i = a; i < a + n; i++) {
            for (ptrdiff_t e = 0; e < M; e++) {
                size_t at = ((size_t)i * J + p->ident[e]) * 4;
                if (out32) {
                    out32[at] = 0.0f; out32[at + 1] = 0.0f; out32[at + 2] = 0.0f; out32[at + 3] = 1.0f;
                } else {
                    out64[at] = 0.0; out64[at + 1] = 0.0; out64[at + 2] = 0.0; out64[at + 3] = 1.0;
                }
            }
            for (ptrdiff_t k = 0; N > 0 && k < 3; k++) {
                int64_t c = p->tcols[k];
                root[i * 3 + k] = c >= 0 ? X[c * ldx + i] : p->tvals[k];
            }
            for (ptrdiff_t q = 0; q < N - 1; q++)
                for (ptrdiff_t k = 0; k < 3; k++) {
                    int64_t c = p->tcols[3 * (q + 1) + k];
                    moved[(i * (N - 1) + q) * 3 + k] = c >= 0 ? X[c * ldx + i] : p->tvals[3 * (q + 1) + k];
                }
        }
        if (stream) {  /* what is still waiting, then this sub-block's rows wait in their turn */
            if (sm->len > sm->done)
                stream_some(sm, sm->len - sm->done);
            sm->src = sm->stage + (size_t)sm->half * MR_PLAN_SUB * J * 4;
            sm->dst = final64 + (size_t)a * J * 4;
            sm->len = (size_t)n * J * 4;
            sm->done = 0;
            sm->half ^= 1;
        }
    }
    if (zero)
        return MR_PLAN_ZERO_QUAT;
    if (degenerate)
        return MR_PLAN_DEGENERATE_6D;
    return MR_PLAN_OK;
}
