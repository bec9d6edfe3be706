/* motionrep_svd._csvd: the svd codec's decoder in C.
 *
 *   Decoder(coefficients, mean, basis)            the payload's arrays, all float32 (payload version 2) or all
 *                                                 float64 (version 1): coefficients (F, r), mean (D,), basis (r, D),
 *                                                 C-contiguous (kept; the transposed basis is made here)
 *   Decoder.sampler                               the C sampler motionrep.open calls (motionrep/sampler.h)
 *   sample(times, out, decoder)                   the features at times (T,) into a feature-major out (D, >= T)
 *
 * The arithmetic of the numba kernel it replaces, in the arrays' dtype: the coefficient rows interpolated linearly
 * at each time (clamped to [0, 1]), then mean + c(t) @ basis, each sum in a fixed order (mean first, then the
 * components in order; motionrep/mrkernels.h), so a time decodes to the same bits alone or in a batch. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <stdlib.h>

#include "motionrep/mrkernels.h"
#include "motionrep/sampler.h"
#include "motionrep/pybuf.h"

#define ROWS 64  /* times decoded together (the block's coefficients and features stay in the CPU cache) */

typedef struct {
    size_t F, r, D;
    const void *coeff, *mean, *basis_t, *basis;
} svd_arrays;

/* one kernel per dtype: T the arithmetic's type */
#define SVD_KERNEL(NAME, T, AFFINE_BLOCK, AFFINE_ONE)                                                              \
    MR_CLONES static int NAME(const void *state, const double *times, size_t count, double *out, size_t ldo)       \
    {                                                                                                              \
        const svd_arrays *s = state;                                                                               \
        const size_t F = s->F, r = s->r, D = s->D;                                                                 \
        const T *coeff = s->coeff, *mean = s->mean, *basis_t = s->basis_t, *basis = s->basis;                      \
        /* one time (a pose alone): its two vectors on the stack, no allocation */                                 \
        T small[1024];                                                                                             \
        size_t need = count == 1 ? r + D + 1 : (r ? r : 1) * ROWS + D * ROWS + r + D + 1;                          \
        T *C = need <= 1024 ? small : malloc(sizeof(T) * need);                                                    \
        if (!C)                                                                                                    \
            return 1;                                                                                              \
        T *Y = count == 1 ? C : C + (r ? r : 1) * ROWS, *c1 = count == 1 ? C : Y + D * ROWS, *y1 = c1 + r;         \
        const size_t stride = count == 1 ? 1 : ROWS; /* of C's rows: one time writes c1 straight away */           \
        for (size_t a = 0; a < count; a += ROWS) {                                                                 \
            size_t m = count - a < ROWS ? count - a : ROWS;                                                        \
            for (size_t i = 0; i < m; i++) {                                                                       \
                double t = MR_PYMIN(MR_PYMAX(times[a + i], 0.0), 1.0);                                             \
                t = t != t ? 0.0 : t; /* NaN (never from motionrep): the first frame */                            \
                double pos = t * (double)(F - 1);                                                                  \
                int64_t last = F >= 2 ? (int64_t)F - 2 : 0, j = (int64_t)floor(pos);                              \
                j = j < last ? j : last;                                                                           \
                T frac = (T)(pos - (double)j);                                                                     \
                T rest = (T)1.0 - frac;                                                                            \
                size_t k1 = (size_t)j + 1 < F - 1 ? (size_t)j + 1 : F - 1;                                         \
                const T *r0 = coeff + (size_t)j * r, *r1 = coeff + k1 * r;                                         \
                for (size_t k = 0; k < r; k++)                                                                     \
                    C[k * stride + i] = r0[k] * rest + r1[k] * frac;                                               \
            }                                                                                                      \
            if (m == 1) { /* one time: the same sums, vectorised over the features */                              \
                if (count > 1)                                                                                     \
                    for (size_t k = 0; k < r; k++)                                                                 \
                        c1[k] = C[k * ROWS];                                                                       \
                AFFINE_ONE(basis, (ptrdiff_t)D, (ptrdiff_t)r, mean, c1, y1);                                       \
                for (size_t d = 0; d < D; d++)                                                                     \
                    out[d * ldo + a] = (double)y1[d];                                                              \
                continue;                                                                                          \
            }                                                                                                      \
            AFFINE_BLOCK(basis_t, (ptrdiff_t)D, (ptrdiff_t)r, mean, C, ROWS, Y, ROWS, (ptrdiff_t)m);               \
            for (size_t d = 0; d < D; d++)                                                                         \
                for (size_t i = 0; i < m; i++)                                                                     \
                    out[d * ldo + a + i] = (double)Y[d * ROWS + i];                                                \
        }                                                                                                          \
        if (C != small)                                                                                            \
            free(C);                                                                                               \
        return 0;                                                                                                  \
    }

SVD_KERNEL(sample_f32, float, mr_affine_block_f32, mr_affine_one_f32)
SVD_KERNEL(sample_f64, double, mr_affine_block_f64, mr_affine_one_f64)

/* ---- Decoder -------------------------------------------------------------------------------------------- */

#define TRANSPOSE(NAME, T)                                                                                         \
    static void NAME(const T *a, Py_ssize_t rows, Py_ssize_t cols, T *out)                                         \
    {                                                                                                              \
        for (Py_ssize_t i = 0; i < rows; i++)                                                                      \
            for (Py_ssize_t j = 0; j < cols; j++)                                                                  \
                out[j * rows + i] = a[i * cols + j];                                                               \
    }

TRANSPOSE(transpose_f32, float)
TRANSPOSE(transpose_f64, double)

typedef struct {
    PyObject_HEAD
    Py_buffer views[3];
    void *basis_t;
    svd_arrays arrays;
    mr_sampler sampler;
} DecoderObject;

static void Decoder_dealloc(DecoderObject *self)
{
    for (int k = 0; k < 3; k++)
        if (self->views[k].obj)
            PyBuffer_Release(&self->views[k]);
    free(self->basis_t);
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
    size_t item = code == 'f' ? sizeof(float) : sizeof(double);
    if (!(self->basis_t = malloc(item * (size_t)(r * D > 0 ? r * D : 1)))) {
        PyErr_NoMemory();
        return -1;
    }
    if (code == 'f')  /* basis_t[d, k] = basis[k, d] */
        transpose_f32(self->views[2].buf, r, D, self->basis_t);
    else
        transpose_f64(self->views[2].buf, r, D, self->basis_t);
    self->arrays = (svd_arrays){(size_t)F, (size_t)r, (size_t)D, self->views[0].buf, self->views[1].buf,
                                self->basis_t, self->views[2].buf};
    self->sampler = (mr_sampler){MR_SAMPLER_ABI, (size_t)D, code == 'f' ? sample_f32 : sample_f64, &self->arrays, 0};
    return 0;
}

static PyTypeObject DecoderType;
MR_SAMPLER_BINDING(Decoder, DecoderObject, DecoderType)

static PyGetSetDef Decoder_getset[] = {
    {"sampler", Decoder_sampler_get, NULL, "the C sampler for motionrep.open (motionrep/sampler.h)", NULL},
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
