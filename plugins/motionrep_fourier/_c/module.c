/* motionrep_fourier._cfourier: the Fourier-feature networks' decoder in C (see motionrep_fourier/_network.py).
 *
 *   Decoder(frames, windowed, double, edges, ks, hs, omega, offsets, weights, b2)
 *       one network or a clip's windows of networks, as Networks prepares them: window s has ks[s] frequencies
 *       (from omega[sum ks[:s]]), hs[s] hidden units, its weights at weights[offsets[s, :]] (W0, b0, W1, b1, W2,
 *       then W0T, W1T, W2T) and output bias b2[s]; weights and b2 float32 (double false) or float64
 *   Decoder.sampler                     the C sampler motionrep.open calls (motionrep/sampler.h)
 *   sample(times, out, decoder)         the features at times (T,) into a feature-major out (D, >= T)
 *   elu(a, out)                         the float32 ELU of the decoder, element by element (tests)
 *
 * The arithmetic of the numba kernel it replaces: inputs [t, sin 2 pi w t, cos 2 pi w t, ...] in float64 (the
 * branch-free sincos of motionrep/mrkernels.h), then each layer a sum over its inputs in a fixed order (bias first)
 * in the weights' dtype, vectorised over the times of a block and never over the sum; ELU by a float32 polynomial,
 * or libm's expm1 in float64.  A time decodes to the same bits alone or in any batch.  The times are grouped by
 * window (a stable counting sort, GROUP at a time) so that each network runs on whole blocks. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <stdlib.h>

#include "motionrep/mrkernels.h"
#include "motionrep/sampler.h"
#include "motionrep/pybuf.h"

#define ROWS 64     /* times evaluated together */
#define GROUP 1024  /* times grouped by window before they are evaluated */
#define PARTS 8     /* per window: offsets of W0, b0, W1, b1, W2, W0T, W1T, W2T in the flat weights */

typedef struct {
    int64_t frames, S, D, kmax, H;
    int windowed;
    const int64_t *edges, *ks, *hs, *offsets, *first_omega;
    const double *omega;
    const void *weights, *b2;
} networks;

/* ELU (alpha 1) of a float32 v: v for v >= 0; for v < 0, expm1(v) as expm1(2 y) = expm1(y) (expm1(y) + 2) applied
 * six times to y = max(v, -30) / 64 (exact scaling), whose expm1 is its Taylor polynomial of degree 8; branch-free */
MR_INLINE float elu32(float v)
{
    float y = MR_PYMAX(v, -30.0f) * 0.015625f;
    float e = y * (1.0f + y * (0.5f + y * ((float)(1.0 / 6.0) + y * ((float)(1.0 / 24.0) + y * (
        (float)(1.0 / 120.0) + y * ((float)(1.0 / 720.0) + y * ((float)(1.0 / 5040.0) + y * (float)(1.0 / 40320.0))))))));
    for (int k = 0; k < 6; k++)
        e = e * (e + 2.0f);
    return v >= 0.0f ? v : e;
}

MR_INLINE double elu64(double v)
{
    return v >= 0.0 ? v : expm1(v);
}

#define NETWORKS_KERNEL(NAME, T, ELU, AFFINE_BLOCK, AFFINE_ONE)                                                    \
    MR_CLONES static int NAME(const void *state, const double *times, size_t count, double *out, size_t ldo)       \
    {                                                                                                              \
        const networks *n = state;                                                                                 \
        const int64_t S = n->S, D = n->D, H = n->H, I = 2 * n->kmax + 1;                                           \
        const T *weights = n->weights, *b2 = n->b2;                                                                \
        const double two_pi = 2.0 * MR_PI;                                                                         \
        size_t G = count < GROUP ? (count ? count : 1) : GROUP;                                                    \
        /* activations are (units, times): the sums vectorise over times */                                        \
        T *X = malloc(sizeof(T) * ((size_t)(I + 2 * H + D) * ROWS + (size_t)(I + 2 * H + D)));                    \
        double *tau = malloc(sizeof(double) * (G + ROWS));                                                         \
        int64_t *window = malloc(sizeof(int64_t) * (2 * G + (size_t)S + 1));                                       \
        if (!X || !tau || !window) {                                                                               \
            free(X);                                                                                               \
            free(tau);                                                                                             \
            free(window);                                                                                          \
            return 1;                                                                                              \
        }                                                                                                          \
        T *H0 = X + (size_t)I * ROWS, *H1 = H0 + (size_t)H * ROWS, *Y = H1 + (size_t)H * ROWS;                    \
        T *x1 = Y + (size_t)D * ROWS, *z0 = x1 + I, *z1 = z0 + H, *y1 = z1 + H;                                   \
        double *local = tau + G;                                                                                   \
        int64_t *order = window + G, *start = order + G;                                                           \
        for (size_t a = 0; a < count; a += G) {                                                                    \
            size_t m = count - a < G ? count - a : G;                                                              \
            for (int64_t s = 0; s <= S; s++)                                                                       \
                start[s] = 0;                                                                                      \
            for (size_t i = 0; i < m; i++) {                                                                       \
                double t = times[a + i];                                                                           \
                int64_t s = 0;                                                                                     \
                if (n->windowed) {                                                                                 \
                    double x = t * (double)(n->frames - 1);                                                        \
                    int64_t lo = 0, hi = S - 1; /* the last s with edges[s] <= x */                                \
                    while (lo < hi) {                                                                              \
                        int64_t mid = (lo + hi + 1) / 2;                                                           \
                        if ((double)n->edges[mid] <= x)                                                            \
                            lo = mid;                                                                              \
                        else                                                                                       \
                            hi = mid - 1;                                                                          \
                    }                                                                                              \
                    s = lo;                                                                                        \
                    tau[i] = (x - (double)n->edges[s]) / (double)(n->edges[s + 1] - n->edges[s]);                  \
                } else {                                                                                           \
                    tau[i] = t;                                                                                    \
                }                                                                                                  \
                window[i] = s;                                                                                     \
                start[s + 1]++;                                                                                    \
            }                                                                                                      \
            for (int64_t s = 0; s < S; s++)                                                                        \
                start[s + 1] += start[s];                                                                          \
            for (size_t i = 0; i < m; i++) /* counting sort: order[start[s]:start[s + 1]] are window s's times */  \
                order[start[window[i]]++] = (int64_t)i;                                                            \
            int64_t begin = 0;                                                                                     \
            for (int64_t s = 0; s < S; s++) {                                                                      \
                int64_t end = start[s];                                                                            \
                if (end == begin)                                                                                  \
                    continue;                                                                                      \
                int identity = (size_t)(end - begin) == m; /* one window: the (stable) order is the identity */    \
                int64_t K = n->ks[s], h = n->hs[s], inputs = 2 * K + 1;                                            \
                const int64_t *o = n->offsets + PARTS * s;                                                         \
                const T *W0 = weights + o[0], *bias0 = weights + o[1], *W1 = weights + o[2];                       \
                const T *bias1 = weights + o[3], *W2 = weights + o[4], *bias2 = b2 + s * D;                        \
                const double *w = n->omega + n->first_omega[s];                                                    \
                for (int64_t c = begin; c < end; c += ROWS) {                                                      \
                    int64_t rows = end - c < ROWS ? end - c : ROWS;                                                \
                    if (rows == 1) { /* one time: the same sums, vectorised over the units */                      \
                        double t = tau[order[c]];                                                                  \
                        x1[0] = (T)t;                                                                              \
                        for (int64_t k = 0; k < K; k++) {                                                          \
                            double sn, cs;                                                                         \
                            mr_sincos(two_pi * t * w[k], &sn, &cs);                                                \
                            x1[1 + 2 * k] = (T)sn;                                                                 \
                            x1[2 + 2 * k] = (T)cs;                                                                 \
                        }                                                                                          \
                        AFFINE_ONE(weights + o[5], h, inputs, bias0, x1, z0);                                      \
                        for (int64_t u = 0; u < h; u++)                                                            \
                            z0[u] = ELU(z0[u]);                                                                    \
                        AFFINE_ONE(weights + o[6], h, h, bias1, z0, z1);                                           \
                        for (int64_t u = 0; u < h; u++)                                                            \
                            z1[u] = ELU(z1[u]);                                                                    \
                        AFFINE_ONE(weights + o[7], D, h, bias2, z1, y1);                                           \
                        size_t i = a + (size_t)order[c];                                                           \
                        for (int64_t d = 0; d < D; d++)                                                            \
                            out[d * ldo + i] = (double)y1[d];                                                      \
                        continue;                                                                                  \
                    }                                                                                              \
                    for (int64_t r = 0; r < rows; r++) { /* the block's times, contiguous */                       \
                        local[r] = tau[order[c + r]];                                                              \
                        X[r] = (T)local[r];                                                                        \
                    }                                                                                              \
                    for (int64_t k = 0; k < K; k++) {                                                              \
                        T *xs = X + (1 + 2 * k) * ROWS, *xc = xs + ROWS;                                           \
                        for (int64_t r = 0; r < rows; r++) {                                                       \
                            double sn, cs;                                                                         \
                            mr_sincos(two_pi * local[r] * w[k], &sn, &cs);                                         \
                            xs[r] = (T)sn;                                                                         \
                            xc[r] = (T)cs;                                                                         \
                        }                                                                                          \
                    }                                                                                              \
                    AFFINE_BLOCK(W0, h, inputs, bias0, X, ROWS, H0, ROWS, rows);                                   \
                    for (int64_t u = 0; u < h; u++)                                                                \
                        for (int64_t r = 0; r < rows; r++)                                                         \
                            H0[u * ROWS + r] = ELU(H0[u * ROWS + r]);                                              \
                    AFFINE_BLOCK(W1, h, h, bias1, H0, ROWS, H1, ROWS, rows);                                       \
                    for (int64_t u = 0; u < h; u++)                                                                \
                        for (int64_t r = 0; r < rows; r++)                                                         \
                            H1[u * ROWS + r] = ELU(H1[u * ROWS + r]);                                              \
                    AFFINE_BLOCK(W2, D, h, bias2, H1, ROWS, Y, ROWS, rows);                                        \
                    for (int64_t d = 0; d < D; d++) {                                                              \
                        double *od = out + d * ldo + a;                                                            \
                        const T *yd = Y + d * ROWS;                                                                \
                        if (identity)                                                                              \
                            for (int64_t r = 0; r < rows; r++)                                                     \
                                od[c + r] = (double)yd[r];                                                         \
                        else                                                                                       \
                            for (int64_t r = 0; r < rows; r++)                                                     \
                                od[order[c + r]] = (double)yd[r];                                                  \
                    }                                                                                              \
                }                                                                                                  \
                begin = end;                                                                                       \
            }                                                                                                      \
        }                                                                                                          \
        free(X);                                                                                                   \
        free(tau);                                                                                                 \
        free(window);                                                                                              \
        return 0;                                                                                                  \
    }

NETWORKS_KERNEL(sample_f32, float, elu32, mr_affine_block_f32, mr_affine_one_f32)
NETWORKS_KERNEL(sample_f64, double, elu64, mr_affine_block_f64, mr_affine_one_f64)

/* ---- Decoder ------------------------------------------------------------------------------------------ */

enum { V_EDGES, V_KS, V_HS, V_OMEGA, V_OFFSETS, V_WEIGHTS, V_B2, VIEWS };

typedef struct {
    PyObject_HEAD
    Py_buffer views[VIEWS];
    int64_t *first_omega;
    networks net;
    mr_sampler sampler;
} DecoderObject;

static void Decoder_dealloc(DecoderObject *self)
{
    for (int k = 0; k < VIEWS; k++)
        if (self->views[k].obj)
            PyBuffer_Release(&self->views[k]);
    free(self->first_omega);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int invalid(const char *what)
{
    PyErr_Format(PyExc_ValueError, "Fourier decoder arrays do not fit together: %s", what);
    return -1;
}

static int Decoder_init(DecoderObject *self, PyObject *args, PyObject *kw)
{
    long long frames;
    int windowed, dbl;
    PyObject *o[VIEWS];
    static char *names[] = {"frames", "windowed", "double", "edges", "ks", "hs", "omega", "offsets", "weights",
                            "b2", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kw, "LppOOOOOOO", names, &frames, &windowed, &dbl, &o[V_EDGES],
                                     &o[V_KS], &o[V_HS], &o[V_OMEGA], &o[V_OFFSETS], &o[V_WEIGHTS], &o[V_B2]))
        return -1;
    if (self->views[0].obj) {
        PyErr_SetString(PyExc_TypeError, "Decoder is initialised once");
        return -1;
    }
    Py_ssize_t any1[1] = {-1}, any2[2] = {-1, -1}, parts[2] = {-1, PARTS};
    static const char *labels[VIEWS] = {"edges", "ks", "hs", "omega", "offsets", "weights", "b2"};
    char codes[VIEWS] = {'q', 'q', 'q', 'd', 'q', dbl ? 'd' : 'f', dbl ? 'd' : 'f'};
    for (int k = 0; k < VIEWS; k++)
        if (mr_get_buffer(o[k], &self->views[k], codes[k], k == V_OFFSETS || k == V_B2 ? 2 : 1,
                          k == V_OFFSETS ? parts : k == V_B2 ? any2 : any1, 0, labels[k]) < 0)
            return -1;
    const int64_t *edges = self->views[V_EDGES].buf, *ks = self->views[V_KS].buf, *hs = self->views[V_HS].buf;
    const int64_t *offsets = self->views[V_OFFSETS].buf;
    int64_t S = self->views[V_KS].shape[0], D = self->views[V_B2].shape[1];
    int64_t nw = self->views[V_WEIGHTS].shape[0], nomega = self->views[V_OMEGA].shape[0];
    if (S < 1 || self->views[V_HS].shape[0] != S || self->views[V_OFFSETS].shape[0] != S
        || self->views[V_B2].shape[0] != S || self->views[V_EDGES].shape[0] != S + 1 || D < 1)
        return invalid("counts");
    if (edges[0] != 0 || frames != edges[S] + 1)
        return invalid("window edges");
    for (int64_t s = 0; s < S; s++)
        if (edges[s + 1] <= edges[s])
            return invalid("window edges");
    if (!(self->first_omega = malloc(sizeof(int64_t) * (size_t)(S + 1)))) {
        PyErr_NoMemory();
        return -1;
    }
    self->first_omega[0] = 0;
    int64_t kmax = 0, H = 0;
    for (int64_t s = 0; s < S; s++) {
        int64_t K = ks[s], h = hs[s];
        if (K < 0 || h < 0 || K > (1 << 20) || h > (1 << 20))
            return invalid("sizes");
        self->first_omega[s + 1] = self->first_omega[s] + K;
        kmax = K > kmax ? K : kmax;
        H = h > H ? h : H;
        int64_t in = 2 * K + 1;
        int64_t sizes[PARTS] = {h * in, h, h * h, h, D * h, in * h, h * h, h * D};
        for (int k = 0; k < PARTS; k++)
            if (offsets[PARTS * s + k] < 0 || offsets[PARTS * s + k] > nw || sizes[k] > nw - offsets[PARTS * s + k])
                return invalid("weight offsets");
    }
    if (self->first_omega[S] > nomega)
        return invalid("frequencies");
    self->net = (networks){frames, S, D, kmax, H, windowed, edges, ks, hs, offsets, self->first_omega,
                           self->views[V_OMEGA].buf, self->views[V_WEIGHTS].buf, self->views[V_B2].buf};
    /* the runtime decoder's blocks: GROUP / 2 times, so that times spread over the windows still fill blocks */
    self->sampler = (mr_sampler){MR_SAMPLER_ABI, (size_t)D, dbl ? sample_f64 : sample_f32, &self->net, GROUP / 2};
    return 0;
}

static PyTypeObject DecoderType;
MR_SAMPLER_BINDING(Decoder, DecoderObject, DecoderType)

static PyGetSetDef Decoder_getset[] = {
    {"sampler", Decoder_sampler_get, NULL, "the C sampler for motionrep.open (motionrep/sampler.h)", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PyTypeObject DecoderType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "motionrep_fourier._cfourier.Decoder",
    .tp_basicsize = sizeof(DecoderObject),
    .tp_dealloc = (destructor)Decoder_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Decoder(frames, windowed, double, edges, ks, hs, omega, offsets, weights, b2): prepared networks.",
    .tp_getset = Decoder_getset,
    .tp_init = (initproc)Decoder_init,
    .tp_new = PyType_GenericNew,
};

static PyObject *py_elu(PyObject *mod, PyObject *args)
{
    (void)mod;
    PyObject *oa, *oo;
    if (!PyArg_ParseTuple(args, "OO", &oa, &oo))
        return NULL;
    Py_buffer ba, bo;
    Py_ssize_t any[1] = {-1};
    if (mr_get_buffer(oa, &ba, 'f', 1, any, 0, "a") < 0)
        return NULL;
    Py_ssize_t so[1] = {ba.shape[0]};
    if (mr_get_buffer(oo, &bo, 'f', 1, so, 1, "out") < 0) {
        PyBuffer_Release(&ba);
        return NULL;
    }
    const float *a = ba.buf;
    float *o = bo.buf;
    for (Py_ssize_t i = 0; i < ba.shape[0]; i++)
        o[i] = elu32(a[i]);
    PyBuffer_Release(&ba);
    PyBuffer_Release(&bo);
    Py_RETURN_NONE;
}

static PyMethodDef functions[] = {
    {"sample", Decoder_sample, METH_VARARGS, "sample(times, out, decoder): the features at times, feature-major"},
    {"elu", py_elu, METH_VARARGS, "elu(a, out): the decoder's float32 ELU of a (T,) float32 into out"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "motionrep_fourier._cfourier",
                                    "The Fourier codecs' decoder in C.", -1, functions};

PyMODINIT_FUNC PyInit__cfourier(void)
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
