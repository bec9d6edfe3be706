/* motionrep_svd._csvd: the svd codec's decoder in C.
 *
 *   Decoder(coefficients, mean, basis)            the payload's arrays, all float32 (payload version 2) or all
 *                                                 float64 (version 1): coefficients (F, r), mean (D,), basis (r, D),
 *                                                 C-contiguous (kept; the transposed basis is made here)
 *   Decoder.sampler                               the C sampler motionrep.open calls (motionrep/sampler.h)
 *   sample(times, out, decoder)                   the features at times (T,) into a feature-major out (D, >= T)
 *
 * Preparing a decoder decodes every frame: at frame i's time, i / (F - 1), the arithmetic of the numba kernel the
 * decoder replaced, in the arrays' dtype (the coefficient rows interpolated linearly at the time, then
 * mean + c(t) @ basis, each sum in a fixed order: mean first, then the components in order; motionrep/mrkernels.h:
 * direct_f32, direct_f64).  Sampling then blends each time's two frames, R_j (1 - a) + R_{j+1} a in the dtype (the
 * fraction a rounded to it); a time that is a frame's time gives that frame exactly, and a feature constant over
 * the clip its mean.  A time decodes to the same bits alone or in a batch. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "motionrep/mrkernels.h"
#include "motionrep/sampler.h"
#include "motionrep/pybuf.h"

#define ROWS 64  /* times decoded together (the block's coefficients and features stay in the CPU cache) */

typedef struct {
    size_t F, r, D;
    const void *coeff, *mean, *basis;
    /* The block path's dense layer: D units, unit u the feature rows[u] (NULL: u), with the weights units_t (D, r)
     * (the basis transposed) and means units_mean (D) in that order.  The features of zero weights (ZERO_WEIGHTS)
     * come last, after the L others: in a block whose interpolated coefficients are all finite, only the first L
     * units are summed and the others, consts = rows + L, are written as their means (the sums' value). */
    size_t L;
    const void *units_t, *units_mean;
    const ptrdiff_t *rows, *consts;
    /* the prepared decoder: the features of every frame (F, D), frame-major in the dtype; consts_ok: every
     * coefficient finite and far from overflowing, so that the features of zero weights are their means */
    const void *frames;
    int consts_ok;
} svd_arrays;

/* A time's place among the F frames: t, the time clamped to [0, 1] (NaN, never from motionrep: the first frame);
 * j, its frame (floor of t (F - 1), the last but one frame for t = 1), k1 the next one (j itself for one frame);
 * returns the position t (F - 1). */
static inline double position(double time, size_t F, double *t, int64_t *j, size_t *k1)
{
    double u = MR_PYMIN(MR_PYMAX(time, 0.0), 1.0);
    u = u != u ? 0.0 : u;
    double pos = u * (double)(F - 1);
    int64_t last = F >= 2 ? (int64_t)F - 2 : 0, at = (int64_t)floor(pos);
    at = at < last ? at : last;
    *t = u, *j = at, *k1 = (size_t)at + 1 < F - 1 ? (size_t)at + 1 : F - 1;
    return pos;
}

/* C[k * ROWS + i] = R0[i][k] RE[i] + R1[i][k] FR[i] for i < m, k < r: a block's interpolated coefficients (each
 * value the one product-and-sum of the kernel's one-time path, so the same bits), made eight times by eight
 * coefficients at a time: the rows read along k, then turned with shuffles (which move values, exactly) so that
 * the stores go along the times (a store per value otherwise, each to another cache line). */
#if defined(__GNUC__)
#define INTERPOLATE(NAME, T, IT)                                                                                   \
    MR_CLONES __attribute__((noinline)) static void NAME(const T *const *R0, const T *const *R1, const T *RE,     \
                                                         const T *FR, size_t m, size_t r, T *C)                    \
    {                                                                                                              \
        typedef T vec __attribute__((vector_size(8 * sizeof(T))));                                                 \
        typedef IT ivec __attribute__((vector_size(8 * sizeof(T))));                                               \
        size_t i = 0;                                                                                              \
        for (; i + 8 <= m; i += 8) {                                                                               \
            for (size_t k0 = 0; k0 < r && r >= 8; k0 += 8) {                                                       \
                /* the last eight coefficients for the last tile (some of them made twice: the same values) */    \
                size_t k = k0 + 8 <= r ? k0 : r - 8;                                                               \
                vec v[8], t[8], u[8];                                                                              \
                for (int q = 0; q < 8; q++) { /* time i + q, coefficients k .. k + 7 */                           \
                    vec x0, x1;                                                                                    \
                    memcpy(&x0, R0[i + q] + k, sizeof x0);                                                         \
                    memcpy(&x1, R1[i + q] + k, sizeof x1);                                                         \
                    v[q] = x0 * RE[i + q] + x1 * FR[i + q];                                                        \
                }                                                                                                  \
                for (int q = 0; q < 8; q += 2) { /* pairs of times interleaved, in halves */                      \
                    t[q] = __builtin_shuffle(v[q], v[q + 1], (ivec){0, 8, 1, 9, 4, 12, 5, 13});                    \
                    t[q + 1] = __builtin_shuffle(v[q], v[q + 1], (ivec){2, 10, 3, 11, 6, 14, 7, 15});              \
                }                                                                                                  \
                for (int q = 0; q < 8; q += 4) { /* fours of times: u[q + c] holds coefficients c and c + 4 */    \
                    u[q] = __builtin_shuffle(t[q], t[q + 2], (ivec){0, 1, 8, 9, 4, 5, 12, 13});                    \
                    u[q + 1] = __builtin_shuffle(t[q], t[q + 2], (ivec){2, 3, 10, 11, 6, 7, 14, 15});              \
                    u[q + 2] = __builtin_shuffle(t[q + 1], t[q + 3], (ivec){0, 1, 8, 9, 4, 5, 12, 13});            \
                    u[q + 3] = __builtin_shuffle(t[q + 1], t[q + 3], (ivec){2, 3, 10, 11, 6, 7, 14, 15});          \
                }                                                                                                  \
                for (int c = 0; c < 4; c++) { /* coefficient k + c, then k + c + 4, of the eight times */         \
                    vec lo = __builtin_shuffle(u[c], u[c + 4], (ivec){0, 1, 2, 3, 8, 9, 10, 11});                  \
                    vec hi = __builtin_shuffle(u[c], u[c + 4], (ivec){4, 5, 6, 7, 12, 13, 14, 15});                \
                    memcpy(C + (k + c) * ROWS + i, &lo, sizeof lo);                                                \
                    memcpy(C + (k + c + 4) * ROWS + i, &hi, sizeof hi);                                            \
                }                                                                                                  \
            }                                                                                                      \
            for (size_t k = 0; r < 8 && k < r; k++)                                                                \
                for (size_t q = i; q < i + 8; q++)                                                                 \
                    C[k * ROWS + q] = R0[q][k] * RE[q] + R1[q][k] * FR[q];                                         \
        }                                                                                                          \
        for (; i < m; i++)                                                                                         \
            for (size_t k = 0; k < r; k++)                                                                         \
                C[k * ROWS + i] = R0[i][k] * RE[i] + R1[i][k] * FR[i];                                             \
    }
#else
#define INTERPOLATE(NAME, T, IT)                                                                                   \
    MR_INLINE void NAME(const T *const *R0, const T *const *R1, const T *RE, const T *FR, size_t m, size_t r, T *C)  \
    {                                                                                                              \
        for (size_t i = 0; i < m; i++)                                                                             \
            for (size_t k = 0; k < r; k++)                                                                         \
                C[k * ROWS + i] = R0[i][k] * RE[i] + R1[i][k] * FR[i];                                             \
    }
#endif

INTERPOLATE(interpolate_f32, float, int32_t)
INTERPOLATE(interpolate_f64, double, int64_t)

/* one kernel per dtype: T the arithmetic's type */
#define SVD_KERNEL(NAME, T, AFFINE_BLOCK, AFFINE_ONE, INTERPOLATE)                                                              \
    MR_CLONES static int NAME(const void *state, const double *times, size_t count, double *out, size_t ldo)       \
    {                                                                                                              \
        const svd_arrays *s = state;                                                                               \
        const size_t F = s->F, r = s->r, D = s->D;                                                                 \
        const T *coeff = s->coeff, *mean = s->mean, *basis = s->basis;                                             \
        /* the block's interpolated coefficients (and one time's two vectors) on the stack when they fit: no    \
         * allocation per call; the features go straight into out, converted from T as they are stored */         \
        T small[4096];                                                                                             \
        size_t need = count == 1 ? r + D + 1 : (r ? r : 1) * ROWS + r + D + 1;                                     \
        T *C = need <= 4096 ? small : malloc(sizeof(T) * need);                                                    \
        if (!C)                                                                                                    \
            return 1;                                                                                              \
        T *c1 = count == 1 ? C : C + (r ? r : 1) * ROWS, *y1 = c1 + r;                                             \
        const size_t stride = count == 1 ? 1 : ROWS; /* of C's rows: one time writes c1 straight away */           \
        const T *R0[ROWS], *R1[ROWS]; /* each time's two coefficient rows and their weights */                     \
        T RE[ROWS], FR[ROWS];                                                                                      \
        for (size_t a = 0; a < count; a += ROWS) {                                                                 \
            size_t m = count - a < ROWS ? count - a : ROWS;                                                        \
            for (size_t i = 0; i < m; i++) {                                                                       \
                double t;                                                                                          \
                int64_t j;                                                                                         \
                size_t k1;                                                                                         \
                double pos = position(times[a + i], F, &t, &j, &k1);                                               \
                T frac = (T)(pos - (double)j);                                                                     \
                T rest = (T)1.0 - frac;                                                                            \
                const T *r0 = coeff + (size_t)j * r, *r1 = coeff + k1 * r;                                         \
                R0[i] = r0; R1[i] = r1; RE[i] = rest; FR[i] = frac;                                                \
                for (size_t k = 0; stride == 1 && k < r; k++) /* one time: c1 */                                   \
                    C[k] = r0[k] * rest + r1[k] * frac;                                                            \
            }                                                                                                      \
            if (stride != 1)                                                                                       \
                INTERPOLATE(R0, R1, RE, FR, m, r, C);                                                              \
            if (m == 1) { /* one time: the same sums, vectorised over the features */                              \
                if (count > 1)                                                                                     \
                    for (size_t k = 0; k < r; k++)                                                                 \
                        c1[k] = C[k * ROWS];                                                                       \
                AFFINE_ONE(basis, (ptrdiff_t)D, (ptrdiff_t)r, mean, c1, y1);                                       \
                for (size_t d = 0; d < D; d++)                                                                     \
                    out[d * ldo + a] = (double)y1[d];                                                              \
                continue;                                                                                          \
            }                                                                                                      \
            unsigned infinite = 0; /* interpolated coefficients that are not finite (c * 0 would not be zero) */   \
            for (size_t k = 0; s->L < D && k < r; k++) /* (only for a clip with features of zero weights) */       \
                for (size_t i = 0; i < m; i++) {                                                                   \
                    T c = C[k * ROWS + i];                                                                         \
                    infinite += (unsigned)((c > -(T)INFINITY) & (c < (T)INFINITY)) ^ 1u;                           \
                }                                                                                                  \
            int skip = s->L < D && !infinite; /* the features of zero weights summed only when c is not finite */ \
            AFFINE_BLOCK((const T *)s->units_t, (ptrdiff_t)(skip ? s->L : D), (ptrdiff_t)r,                        \
                         (const T *)s->units_mean, C, ROWS, out + a, (ptrdiff_t)ldo, (ptrdiff_t)m, s->rows);        \
            for (size_t e = 0; skip && e < D - s->L; e++) /* the others: their means (the sums' value) */         \
                for (size_t i = 0; i < m; i++)                                                                     \
                    out[(size_t)s->consts[e] * ldo + a + i] = (double)mean[s->consts[e]];                          \
        }                                                                                                          \
        if (C != small)                                                                                            \
            free(C);                                                                                               \
        return 0;                                                                                                  \
    }

SVD_KERNEL(direct_f32, float, mr_affine_block_f32_f64, mr_affine_one_f32, interpolate_f32)
SVD_KERNEL(direct_f64, double, mr_affine_block_f64_to, mr_affine_one_f64, interpolate_f64)

#define CHUNK 64 /* features blended together (a block's values stay in the CPU cache, on the stack) */

/* The sampler of a prepared decoder: out[d * ldo + i] = R0[d] RE + R1[d] FR of time i in T, widened, where (R0, R1)
 * are the time's frame j and its successor (j = floor(t (F - 1)), the last pair for t = 1), FR the fraction
 * between them rounded to T and RE = 1 - FR; a time equal to frame k's time k / (F - 1), or whose fraction in T is
 * 0 or 1, takes its frame alone (R0 = R1 = that frame, RE = 1, FR = 0: the frame's values exactly); the features
 * of zero weights are written as their means when consts_ok. interpolate_* blends (each value the one
 * product-and-sum of the scalar loop, in T without FMA: the same bits for a time alone or in a block). */
#define FRAMES_KERNEL(NAME, T, INTERPOLATE)                                                                        \
    MR_CLONES static int NAME(const void *state, const double *times, size_t count, double *out, size_t ldo)       \
    {                                                                                                              \
        const svd_arrays *s = state;                                                                               \
        const size_t F = s->F, D = s->D;                                                                           \
        const T *frames = s->frames, *mean = s->mean;                                                              \
        const T *R0[ROWS], *R1[ROWS], *P0[ROWS], *P1[ROWS];                                                        \
        T RE[ROWS], FR[ROWS], C[CHUNK * ROWS];                                                                     \
        for (size_t a = 0; a < count; a += ROWS) {                                                                 \
            size_t m = count - a < ROWS ? count - a : ROWS;                                                        \
            for (size_t i = 0; i < m; i++) {                                                                       \
                double t;                                                                                          \
                int64_t j;                                                                                         \
                size_t k1;                                                                                         \
                double pos = position(times[a + i], F, &t, &j, &k1);                                               \
                T frac = (T)(pos - (double)j);                                                                     \
                T rest = (T)1.0 - frac;                                                                            \
                size_t k = F >= 2 ? (size_t)floor(pos + 0.5) : 0; /* the nearest frame */                         \
                k = k < F - 1 ? k : F - 1;                                                                         \
                int on = F < 2 || (double)k / (double)(F - 1) == t;                                                \
                size_t alone = on ? k : frac == (T)0 ? (size_t)j : rest == (T)0 ? k1 : F;                        \
                if (alone < F) {                                                                                   \
                    R0[i] = R1[i] = frames + alone * D;                                                            \
                    RE[i] = (T)1, FR[i] = (T)0;                                                                    \
                } else {                                                                                           \
                    R0[i] = frames + (size_t)j * D, R1[i] = frames + k1 * D;                                       \
                    RE[i] = rest, FR[i] = frac;                                                                    \
                }                                                                                                  \
            }                                                                                                      \
            for (size_t d0 = 0; d0 < D; d0 += CHUNK) {                                                             \
                size_t w = D - d0 < CHUNK ? D - d0 : CHUNK;                                                        \
                for (size_t i = 0; i < m; i++)                                                                     \
                    P0[i] = R0[i] + d0, P1[i] = R1[i] + d0;                                                        \
                INTERPOLATE(P0, P1, RE, FR, m, w, C);                                                              \
                for (size_t d = 0; d < w; d++)                                                                     \
                    for (size_t i = 0; i < m; i++)                                                                 \
                        out[(d0 + d) * ldo + a + i] = (double)C[d * ROWS + i];                                     \
            }                                                                                                      \
            for (size_t e = 0; s->consts_ok && e < D - s->L; e++) /* constant: their means, exactly */            \
                for (size_t i = 0; i < m; i++)                                                                     \
                    out[(size_t)s->consts[e] * ldo + a + i] = (double)mean[s->consts[e]];                          \
        }                                                                                                          \
        return 0;                                                                                                  \
    }

FRAMES_KERNEL(sample_f32, float, interpolate_f32)
FRAMES_KERNEL(sample_f64, double, interpolate_f64)

/* frames (F, D), frame-major in T: every frame decoded by DIRECT at its time i / (F - 1) (ROWS at a time through
 * tmp, D x ROWS doubles; the values are T's, widened, so narrowing them back is exact) */
#define PREPARE(NAME, T, DIRECT)                                                                                   \
    static int NAME(const svd_arrays *s, T *frames, double *tmp)                                                   \
    {                                                                                                              \
        const size_t F = s->F, D = s->D;                                                                           \
        double times[ROWS];                                                                                        \
        for (size_t b = 0; b < F; b += ROWS) {                                                                     \
            size_t m = F - b < ROWS ? F - b : ROWS;                                                                \
            for (size_t i = 0; i < m; i++)                                                                         \
                times[i] = F >= 2 ? (double)(b + i) / (double)(F - 1) : 0.0;                                       \
            if (DIRECT(s, times, m, tmp, ROWS))                                                                    \
                return 1;                                                                                          \
            for (size_t i = 0; i < m; i++)                                                                         \
                for (size_t d = 0; d < D; d++)                                                                     \
                    frames[(b + i) * D + d] = (T)tmp[d * ROWS + i];                                                \
        }                                                                                                          \
        return 0;                                                                                                  \
    }

PREPARE(prepare_f32, float, direct_f32)
PREPARE(prepare_f64, double, direct_f64)

/* ---- Decoder -------------------------------------------------------------------------------------------- */

/* out[at[j], i] = a[i, j] (at NULL: j): the basis (rows, cols) transposed, each feature's weights at its unit;
 * at[cols + j]: the end of the run of columns from j whose units follow at[j] one by one */
#define TRANSPOSE(NAME, T)                                                                                         \
    static void NAME(const T *a, Py_ssize_t rows, Py_ssize_t cols, const ptrdiff_t *at, T *out)                   \
    {                                                                                                              \
        for (Py_ssize_t i = 0; i < rows; i++)                                                                      \
            for (Py_ssize_t j = 0; j < cols;) { /* a run of columns whose units follow each other */              \
                Py_ssize_t u = at ? at[j] : j, e = at ? at[cols + j] : cols;                                       \
                for (; j < e; j++, u++)                                                                            \
                    out[u * rows + i] = a[i * cols + j];                                                           \
            }                                                                                                      \
    }

TRANSPOSE(transpose_f32, float)
TRANSPOSE(transpose_f64, double)

/* the count of the n values x that are not within (-LIMIT, LIMIT) (NaN is not) */
#define OUTSIDE(NAME, T, LIMIT)                                                                                    \
    MR_CLONES static size_t NAME(const T *x, size_t n)                                                            \
    {                                                                                                              \
        size_t bad = 0;                                                                                            \
        for (size_t a = 0; a < n; a += (size_t)1 << 30) { /* 32-bit lanes: a count per chunk */                  \
            size_t end = n - a < ((size_t)1 << 30) ? n : a + ((size_t)1 << 30);                                    \
            uint32_t part = 0;                                                                                     \
            for (size_t e = a; e < end; e++)                                                                       \
                part += (uint32_t)((x[e] > -(T)(LIMIT)) & (x[e] < (T)(LIMIT))) ^ 1u;                              \
            bad += part;                                                                                           \
        }                                                                                                          \
        return bad;                                                                                                \
    }

OUTSIDE(outside_f32, float, 1e37)
OUTSIDE(outside_f64, double, 1e306)

/* The features whose weights (basis column) are all zeros (+0.0 or -0.0) and whose mean is finite and not -0.0:
 * wherever the interpolated coefficients c are finite, each c * 0 is a zero and the mean plus zeros of either sign
 * is the mean (+0.0 + -0.0 is +0.0), exactly.  zero[d] = 1 for those; returns their count. */
#define ZERO_WEIGHTS(NAME, T)                                                                                      \
    static size_t NAME(const T *mean, const T *basis, size_t r, size_t D, unsigned char *zero)                    \
    {                                                                                                              \
        size_t any = 0;                                                                                            \
        for (size_t d = 0; d < D; d++) {                                                                           \
            T m = mean[d];                                                                                         \
            int c = m > -(T)INFINITY && m < (T)INFINITY && !(m == 0 && signbit(m));                                \
            for (size_t k = 0; c && k < r; k++) /* (most columns stop at their first weight) */                   \
                c = basis[k * D + d] == 0;                                                                         \
            zero[d] = (unsigned char)c;                                                                            \
            any += (size_t)c;                                                                                      \
        }                                                                                                          \
        return any;                                                                                                \
    }

ZERO_WEIGHTS(zero_weights_f32, float)
ZERO_WEIGHTS(zero_weights_f64, double)


typedef struct {
    PyObject_HEAD
    Py_buffer views[3];
    void *basis_t, *units_mean; /* the arrays' units_t, and units_mean when some feature has zero weights */
    ptrdiff_t *rows;           /* the arrays' rows (D), then each feature's unit (D) and runs (D) */
    unsigned char *constant;   /* (D): the features of zero weights (ZERO_WEIGHTS) */
    void *frames;              /* (F, D): every frame decoded (PREPARE) */
    svd_arrays arrays;
    mr_sampler sampler;
} DecoderObject;

static void Decoder_dealloc(DecoderObject *self)
{
    for (int k = 0; k < 3; k++)
        if (self->views[k].obj)
            PyBuffer_Release(&self->views[k]);
    free(self->basis_t);  /* (one allocation: basis_t, units_mean, rows, constant) */
    free(self->frames);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int Decoder_init(DecoderObject *self, PyObject *args, PyObject *kw)
{
    PyObject *o[3];
    static char *names[] = {"coefficients", "mean", "basis", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OOO", names, &o[0], &o[1], &o[2]))
        return -1;
    if (self->views[0].obj) {
        PyErr_SetString(PyExc_TypeError, "Decoder is initialised once");
        return -1;
    }
    Py_ssize_t any2[2] = {-1, -1}, any1[1] = {-1};
    static const char *labels[3] = {"coefficients", "mean", "basis"};
    if (mr_get_buffer(o[1], &self->views[1], mr_format_is_buffer_of(o[1], 'f') ? 'f' : 'd', 1, any1, 0, "mean") < 0)
        return -1;
    char code = mr_format_is(&self->views[1], 'f') ? 'f' : 'd';
    for (int k = 0; k < 3; k += 2)
        if (mr_get_buffer(o[k], &self->views[k], code, 2, any2, 0, labels[k]) < 0)
            return -1;
    Py_ssize_t F = self->views[0].shape[0], r = self->views[0].shape[1], D = self->views[1].shape[0];
    if (F < 1 || self->views[2].shape[0] != r || self->views[2].shape[1] != D) {
        PyErr_SetString(PyExc_ValueError, "inconsistent svd arrays");
        return -1;
    }
    size_t item = code == 'f' ? sizeof(float) : sizeof(double), nD = (size_t)D ? (size_t)D : 1, nconst;
    /* one allocation: basis_t (D, r), units_mean (D), rows (3 D), constant (D) */
    size_t nt = item * ((size_t)(r * D) + nD), nall = nt + 3 * nD * sizeof(ptrdiff_t) + nD;
    if (!(self->basis_t = malloc(nall))) {
        PyErr_NoMemory();
        return -1;
    }
    self->constant = (unsigned char *)self->basis_t + nall - nD;
    const void *mean = self->views[1].buf, *basis = self->views[2].buf;
    if (code == 'f')
        nconst = zero_weights_f32(mean, basis, (size_t)r, (size_t)D, self->constant);
    else
        nconst = zero_weights_f64(mean, basis, (size_t)r, (size_t)D, self->constant);
    size_t L = (size_t)D - nconst;
    ptrdiff_t *at = NULL;
    if (nconst) {  /* the units: the other features in order, then those of zero weights, and their means */
        self->units_mean = (char *)self->basis_t + item * (size_t)(r * D);
        self->rows = (ptrdiff_t *)((char *)self->basis_t + nt);
        at = self->rows + D;  /* at[d]: the unit of feature d (then the runs' ends, TRANSPOSE) */
        for (size_t d = 0, u = 0, e = L; d < (size_t)D; d++) {
            at[d] = (ptrdiff_t)(self->constant[d] ? e++ : u++);
            self->rows[at[d]] = (ptrdiff_t)d;
            if (code == 'f')
                ((float *)self->units_mean)[at[d]] = ((const float *)mean)[d];
            else
                ((double *)self->units_mean)[at[d]] = ((const double *)mean)[d];
        }
        for (Py_ssize_t d = D - 1; d >= 0; d--)
            at[D + d] = d + 1 < D && at[d + 1] == at[d] + 1 ? at[D + d + 1] : d + 1;
    }
    if (code == 'f')  /* basis_t[unit of d, k] = basis[k, d] */
        transpose_f32(basis, r, D, at, self->basis_t);
    else
        transpose_f64(basis, r, D, at, self->basis_t);
    /* every coefficient below 1e37 in magnitude (float32; 1e306 for float64): c_i (1 - a) + c_{i+1} a cannot
     * overflow, so the features of zero weights decode to their means at every time */
    size_t nc = (size_t)(F * r);
    int finite = !nconst || !(code == 'f' ? outside_f32(self->views[0].buf, nc) : outside_f64(self->views[0].buf, nc));
    self->arrays = (svd_arrays){(size_t)F, (size_t)r, (size_t)D, self->views[0].buf, mean, basis, L, self->basis_t,
                                nconst ? self->units_mean : mean, self->rows, self->rows ? self->rows + L : NULL,
                                NULL, finite};
    double *tmp = malloc(sizeof(double) * nD * ROWS);
    self->frames = malloc(item * (size_t)F * nD);
    if (!tmp || !self->frames) {
        free(tmp);
        PyErr_NoMemory();
        return -1;
    }
    int failed = code == 'f' ? prepare_f32(&self->arrays, self->frames, tmp)
                             : prepare_f64(&self->arrays, self->frames, tmp);
    free(tmp);
    if (failed) {
        PyErr_NoMemory();
        return -1;
    }
    self->arrays.frames = self->frames;
    self->sampler = (mr_sampler){MR_SAMPLER_ABI, (size_t)D, code == 'f' ? sample_f32 : sample_f64, &self->arrays, 0};
    return 0;
}

static PyTypeObject DecoderType;
MR_SAMPLER_BINDING(Decoder, DecoderObject, DecoderType)

/* constant: a list of D floats, each feature's value where it is constant over the clip, NaN where not (whether the
 * coefficients allow it, consts_ok, is found when the decoder is prepared: its sampler writes those means too) */
static PyObject *Decoder_constant_get(DecoderObject *self, void *closure)
{
    (void)closure;
    if (!self->views[0].obj) {
        PyErr_SetString(PyExc_ValueError, "Decoder is not initialised");
        return NULL;
    }
    size_t D = self->arrays.D;
    int finite = self->arrays.consts_ok; /* those features are constant when every coefficient is (Decoder_init) */
    PyObject *out = PyList_New((Py_ssize_t)D);
    for (size_t d = 0; out && d < D; d++) {
        double v = !(finite && self->constant[d]) ? NAN
                   : mr_format_is(&self->views[1], 'f') ? (double)((const float *)self->arrays.mean)[d]
                                                        : ((const double *)self->arrays.mean)[d];
        PyObject *f = PyFloat_FromDouble(v);
        if (!f) {
            Py_CLEAR(out);
            break;
        }
        PyList_SET_ITEM(out, (Py_ssize_t)d, f);
    }
    return out;
}

static PyGetSetDef Decoder_getset[] = {
    {"sampler", Decoder_sampler_get, NULL, "the C sampler for motionrep.open (motionrep/sampler.h)", NULL},
    {"constant", (getter)Decoder_constant_get, NULL,
     "each feature's value where it is constant over the clip (the same bits at any time), NaN where not", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PyTypeObject DecoderType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "motionrep_svd._csvd.Decoder",
    .tp_basicsize = sizeof(DecoderObject),
    .tp_dealloc = (destructor)Decoder_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Decoder(coefficients, mean, basis): an svd payload's arrays prepared for decoding.",
    .tp_getset = Decoder_getset,
    .tp_init = (initproc)Decoder_init,
    .tp_new = PyType_GenericNew,
};

static PyMethodDef functions[] = {
    {"sample", Decoder_sample, METH_VARARGS, "sample(times, out, decoder): the features at times, feature-major"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "motionrep_svd._csvd", "The svd codec's decoder in C.", -1,
                                    functions};

PyMODINIT_FUNC PyInit__csvd(void)
{
    if (PyType_Ready(&DecoderType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (!m)
        return NULL;
    Py_INCREF(&DecoderType);
    if (PyModule_AddObject(m, "Decoder", (PyObject *)&DecoderType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
