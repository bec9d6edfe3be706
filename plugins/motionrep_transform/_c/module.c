/* motionrep_transform._cdecode: the CPython binding of mrtransform (the decoder library has no Python in it).
 *
 *   declared(data, version) -> (F, D, region_frames)
 *   unpack(data, version) -> (F, D, region_frames, feature_exponents, region_exponents, coefficients)  (int64 bytes)
 *   reconstruct(F, D, region_frames, feature_exponents, region_exponents, coefficients) -> Frames
 *   decode(data, version) -> Frames
 *   inverse(values, out)         the inverse wavelet of (F, D) float64 coefficients (storage order) into out (F, D)
 *   forward(values, out)         the forward wavelet of (F, D) float64 samples into out (F, D), storage order (the
 *                                encoder's analysis)
 *   sample(times, out, frames)   the features at times into a feature-major out (D, >= T): a decoder's kernel
 *   integers(data, segments) -> (values, exhausted)   the integer coding alone (tests: against constriction)
 *   put_columns(src, dst, cols, changed)   dst[:, cols] = src, marking the rows that changed (_plan.py)
 *   rounded(c, table, rows, cols, rounding, q, dq, subset, compare) -> status   the encoder's rounding of
 *                                coefficients to integers and their dequantised values (_plan.py)
 *
 * Frames: the decoded features of every frame; a (D, F) float64 buffer, rows(times, out) into (T, D), and
 * `sampler`, the capsule motionrep.open calls (motionrep/sampler.h).  A damaged payload raises
 * motionrep.errors.PayloadError with mrtransform's one-line message. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdlib.h>

#include "motionrep/sampler.h"
#include "motionrep/pybuf.h"
#include "mrtransform.h"

static PyObject *PayloadError;

static PyObject *raise_status(const mrt_status *st)
{
    if (st->code == MRT_NO_MEMORY)
        return PyErr_NoMemory();
    PyErr_SetString(PayloadError, st->message);
    return NULL;
}

/* ---- Frames ----------------------------------------------------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    mrt_frames frames;
    mr_sampler sampler;
    Py_ssize_t shape[2], strides[2];
} FramesObject;

static void Frames_dealloc(FramesObject *self)
{
    mrt_frames_free(&self->frames);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int sample_fn(const void *state, const double *times, size_t count, double *out, size_t ldo)
{
    mrt_sample(state, times, count, out, ldo);
    return 0;
}

static PyTypeObject FramesType;

static PyObject *frames_new(mrt_frames *f)
{
    FramesObject *self = PyObject_New(FramesObject, &FramesType);
    if (!self) {
        mrt_frames_free(f);
        return NULL;
    }
    self->frames = *f;
    self->sampler.abi = MR_SAMPLER_ABI;
    self->sampler.width = (size_t)f->features;
    self->sampler.sample = sample_fn;
    self->sampler.state = &self->frames;
    self->sampler.block = 0;
    self->shape[0] = (Py_ssize_t)f->features;
    self->shape[1] = (Py_ssize_t)f->frames;
    self->strides[0] = (Py_ssize_t)(f->frames * sizeof(double));
    self->strides[1] = sizeof(double);
    return (PyObject *)self;
}

static int Frames_getbuffer(FramesObject *self, Py_buffer *view, int flags)
{
    if (flags & PyBUF_WRITABLE) {
        PyErr_SetString(PyExc_BufferError, "decoded frames are read-only");
        return -1;
    }
    view->obj = (PyObject *)self;
    Py_INCREF(self);
    view->buf = self->frames.values;
    view->len = self->shape[0] * self->shape[1] * (Py_ssize_t)sizeof(double);
    view->readonly = 1;
    view->itemsize = sizeof(double);
    view->format = (flags & PyBUF_FORMAT) ? "d" : NULL;
    view->ndim = 2;
    view->shape = self->shape;
    view->strides = self->strides;
    view->suboffsets = NULL;
    view->internal = NULL;
    return 0;
}

static PyBufferProcs Frames_as_buffer = {(getbufferproc)Frames_getbuffer, NULL};

static PyObject *Frames_sampler(FramesObject *self, void *closure)
{
    (void)closure;
    if (mrt_frames_rows(&self->frames) != MRT_OK)  /* the runtime decoder samples random times: rows are faster */
        return PyErr_NoMemory();
    return mr_sampler_capsule((PyObject *)self, &self->sampler);
}

static PyObject *Frames_count(FramesObject *self, void *which)
{
    return PyLong_FromUnsignedLongLong(which ? self->frames.features : self->frames.frames);
}

/* times (T,) float64 and a writable float64 array out of `shape`: the sampled features */
static int sample_args(PyObject *ot, PyObject *oo, Py_buffer *bt, Py_buffer *bo, Py_ssize_t rows, int feature_major)
{
    Py_ssize_t any[1] = {-1}, any2[2] = {-1, -1};
    if (mr_get_buffer(ot, bt, 'd', 1, any, 0, "times") < 0)
        return -1;
    if (mr_get_buffer(oo, bo, 'd', 2, any2, 1, "out") < 0) {
        PyBuffer_Release(bt);
        return -1;
    }
    Py_ssize_t T = bt->shape[0];
    int ok = feature_major ? bo->shape[0] == rows && bo->shape[1] >= T : bo->shape[0] == T && bo->shape[1] == rows;
    if (!ok) {
        PyBuffer_Release(bt);
        PyBuffer_Release(bo);
        PyErr_SetString(PyExc_ValueError, feature_major ? "out must have shape (D, >= T)" : "out must have shape (T, D)");
        return -1;
    }
    return 0;
}

static PyObject *Frames_rows(FramesObject *self, PyObject *args)
{
    PyObject *ot, *oo;
    Py_buffer bt, bo;
    if (!PyArg_ParseTuple(args, "OO", &ot, &oo))
        return NULL;
    if (sample_args(ot, oo, &bt, &bo, self->shape[0], 0) < 0)
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    mrt_sample_rows(&self->frames, bt.buf, (size_t)bt.shape[0], bo.buf);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&bt);
    PyBuffer_Release(&bo);
    Py_RETURN_NONE;
}

static PyMethodDef Frames_methods[] = {
    {"rows", (PyCFunction)Frames_rows, METH_VARARGS, "rows(times, out): the features at times (T,) into out (T, D)."},
    {NULL, NULL, 0, NULL}};

static PyGetSetDef Frames_getset[] = {
    {"sampler", (getter)Frames_sampler, NULL, "the C sampler for motionrep.open (a capsule, motionrep/sampler.h)",
     NULL},
    {"frames", (getter)Frames_count, NULL, "F", NULL},
    {"features", (getter)Frames_count, NULL, "D", (void *)1},
    {NULL, NULL, NULL, NULL, NULL}};

static PyTypeObject FramesType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "motionrep_transform._cdecode.Frames",
    .tp_basicsize = sizeof(FramesObject),
    .tp_dealloc = (destructor)Frames_dealloc,
    .tp_as_buffer = &Frames_as_buffer,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The decoded features of every frame: a read-only (D, F) float64 buffer.",
    .tp_methods = Frames_methods,
    .tp_getset = Frames_getset,
};

/* ---- functions ----------------------------------------------------------------------------------------- */

static PyObject *py_declared(PyObject *mod, PyObject *args)
{
    (void)mod;
    Py_buffer b;
    int version;
    if (!PyArg_ParseTuple(args, "y*i", &b, &version))
        return NULL;
    uint64_t F, D, region;
    mrt_status st;
    int code = mrt_declared(b.buf, (size_t)b.len, version, &F, &D, &region, &st);
    PyBuffer_Release(&b);
    if (code)
        return raise_status(&st);
    return Py_BuildValue("KKK", (unsigned long long)F, (unsigned long long)D, (unsigned long long)region);
}

static PyObject *bytes_of(const void *p, uint64_t n)
{
    return PyBytes_FromStringAndSize(p, (Py_ssize_t)n);
}

static PyObject *py_unpack(PyObject *mod, PyObject *args)
{
    (void)mod;
    Py_buffer b;
    int version;
    if (!PyArg_ParseTuple(args, "y*i", &b, &version))
        return NULL;
    mrt_quantised q;
    mrt_status st;
    int code;
    Py_BEGIN_ALLOW_THREADS
    code = mrt_unpack(b.buf, (size_t)b.len, version, &q, &st);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&b);
    PyObject *out = NULL;
    if (code)
        raise_status(&st);
    else
        out = Py_BuildValue("KKKNNN", (unsigned long long)q.frames, (unsigned long long)q.features,
                            (unsigned long long)q.region_frames, bytes_of(q.feature_exponents, 8 * q.features),
                            bytes_of(q.region_exponents, 8 * q.regions),
                            bytes_of(q.coefficients, 8 * q.frames * q.features));
    mrt_quantised_free(&q);
    return out;
}

static PyObject *py_decode(PyObject *mod, PyObject *args)
{
    (void)mod;
    Py_buffer b;
    int version;
    if (!PyArg_ParseTuple(args, "y*i", &b, &version))
        return NULL;
    mrt_frames f;
    mrt_status st;
    int code;
    Py_BEGIN_ALLOW_THREADS
    code = mrt_decode(b.buf, (size_t)b.len, version, &f, &st);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&b);
    if (code) {
        mrt_frames_free(&f);
        return raise_status(&st);
    }
    return frames_new(&f);
}

static PyObject *py_reconstruct(PyObject *mod, PyObject *args)
{
    (void)mod;
    unsigned long long F, D, region;
    PyObject *of, *orr, *oc;
    if (!PyArg_ParseTuple(args, "KKKOOO", &F, &D, &region, &of, &orr, &oc))
        return NULL;
    if (F < 1 || D < 1 || region < 1 || F > ((uint64_t)1 << 40) || D > ((uint64_t)1 << 30)) {
        PyErr_SetString(PyExc_ValueError, "frames, features and region frames must be >= 1");
        return NULL;
    }
    mrt_quantised q;
    memset(&q, 0, sizeof q);
    q.frames = F;
    q.features = D;
    q.region_frames = region;
    q.regions = (F + region - 1) / region;
    q.levels = mrt_levels(F, q.sizes);
    Py_buffer bf, br, bc;
    Py_ssize_t sf[1] = {(Py_ssize_t)D}, sr[1] = {(Py_ssize_t)q.regions}, sc[2] = {(Py_ssize_t)F, (Py_ssize_t)D};
    if (mr_get_buffer(of, &bf, 'q', 1, sf, 0, "feature_exponents") < 0)
        return NULL;
    if (mr_get_buffer(orr, &br, 'q', 1, sr, 0, "region_exponents") < 0) {
        PyBuffer_Release(&bf);
        return NULL;
    }
    if (mr_get_buffer(oc, &bc, 'q', 2, sc, 0, "coefficients") < 0) {
        PyBuffer_Release(&bf);
        PyBuffer_Release(&br);
        return NULL;
    }
    q.feature_exponents = bf.buf;
    q.region_exponents = br.buf;
    q.coefficients = bc.buf;
    mrt_frames f;
    mrt_status st;
    int code;
    Py_BEGIN_ALLOW_THREADS
    code = mrt_reconstruct(&q, &f, &st);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&bf);
    PyBuffer_Release(&br);
    PyBuffer_Release(&bc);
    if (code) {
        mrt_frames_free(&f);
        return raise_status(&st);
    }
    return frames_new(&f);
}

/* (F, D) values into out (F, D), column by column through one of mrtransform's wavelet transforms */
static PyObject *by_columns(PyObject *args, void (*transform)(double *, const uint64_t *, int, double *))
{
    PyObject *ov, *oo;
    if (!PyArg_ParseTuple(args, "OO", &ov, &oo))
        return NULL;
    Py_buffer bv, bo;
    Py_ssize_t any2[2] = {-1, -1};
    if (mr_get_buffer(ov, &bv, 'd', 2, any2, 0, "values") < 0)
        return NULL;
    Py_ssize_t so[2] = {bv.shape[0], bv.shape[1]};
    if (mr_get_buffer(oo, &bo, 'd', 2, so, 1, "out") < 0) {
        PyBuffer_Release(&bv);
        return NULL;
    }
    uint64_t F = (uint64_t)bv.shape[0], D = (uint64_t)bv.shape[1], sizes[MRT_MAX_LEVELS + 1];
    int levels = F ? mrt_levels(F, sizes) : 0;
    double *x = malloc((F ? F : 1) * 2 * sizeof(double));
    if (!x) {
        PyBuffer_Release(&bv);
        PyBuffer_Release(&bo);
        return PyErr_NoMemory();
    }
    const double *v = bv.buf;
    double *o = bo.buf;
    for (uint64_t d = 0; d < D; d++) {
        for (uint64_t i = 0; i < F; i++)
            x[i] = v[i * D + d];
        transform(x, sizes, levels, x + F);
        for (uint64_t i = 0; i < F; i++)
            o[i * D + d] = x[i];
    }
    free(x);
    PyBuffer_Release(&bv);
    PyBuffer_Release(&bo);
    Py_RETURN_NONE;
}

static PyObject *py_inverse(PyObject *mod, PyObject *args)
{
    (void)mod;
    return by_columns(args, mrt_inverse);
}

static PyObject *py_forward(PyObject *mod, PyObject *args)
{
    (void)mod;
    return by_columns(args, mrt_forward);
}

static PyObject *py_sample(PyObject *mod, PyObject *args)
{
    (void)mod;
    PyObject *ot, *oo, *of;
    if (!PyArg_ParseTuple(args, "OOO!", &ot, &oo, &FramesType, &of))
        return NULL;
    return mr_run_sampler(&((FramesObject *)of)->sampler, ot, oo);
}

static PyObject *py_rounded(PyObject *mod, PyObject *args)
{
    (void)mod;
    PyObject *oc, *ot, *orows, *ocols, *oq, *odq, *osub = Py_None;
    double rounding;
    int compare = 0;
    if (!PyArg_ParseTuple(args, "OOOOdOO|Op", &oc, &ot, &orows, &ocols, &rounding, &oq, &odq, &osub, &compare))
        return NULL;
    Py_buffer b[7];
    int held = 0, result = 0;
    const Py_ssize_t any2[2] = {-1, -1}, any1[1] = {-1};
    if (mr_get_buffer(oc, &b[held], 'd', 2, any2, 0, "c") < 0)
        goto done;
    held++;
    const Py_ssize_t n = b[0].shape[0], m = b[0].shape[1], nm[2] = {n, m}, nrows[1] = {n}, mcols[1] = {m};
    if (mr_get_buffer(ot, &b[held], 'd', 2, any2, 0, "table") < 0)
        goto done;
    held++;
    if (mr_get_buffer(orows, &b[held], 'q', 1, nrows, 0, "rows") < 0)
        goto done;
    held++;
    if (mr_get_buffer(ocols, &b[held], 'q', 1, mcols, 0, "cols") < 0)
        goto done;
    held++;
    if (mr_get_buffer(oq, &b[held], 'q', 2, nm, 1, "q") < 0)
        goto done;
    held++;
    if (mr_get_buffer(odq, &b[held], 'd', 2, nm, 1, "dq") < 0)
        goto done;
    held++;
    if (osub != Py_None) {
        if (mr_get_buffer(osub, &b[held], 'q', 1, any1, 0, "subset") < 0)
            goto done;
        held++;
    }
    const Py_ssize_t K = b[1].shape[0], W = b[1].shape[1], count = osub != Py_None ? b[6].shape[0] : n;
    const int64_t *rows = b[2].buf, *cols = b[3].buf, *sub = osub != Py_None ? b[6].buf : NULL;
    int ok = 1;
    for (Py_ssize_t i = 0; i < n; i++)
        ok &= rows[i] >= 0 && rows[i] < K;
    for (Py_ssize_t j = 0; j < m; j++)
        ok &= cols[j] >= 0 && cols[j] < W;
    for (Py_ssize_t i = 0; sub && i < count; i++)
        ok &= sub[i] >= 0 && sub[i] < n;
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "rounded: rows, cols or subset out of range");
        goto done;
    }
    double *work = malloc(((size_t)K * (size_t)m + 256 * (size_t)m + 1) * sizeof(double));
    if (!work) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    result = mrt_round(b[0].buf, m, b[1].buf, K, W, rows, cols, rounding, b[4].buf, b[5].buf, sub, count, compare,
                       work);
    Py_END_ALLOW_THREADS
    free(work);
    while (held)
        PyBuffer_Release(&b[--held]);
    return PyLong_FromLong(result);
done:
    while (held)
        PyBuffer_Release(&b[--held]);
    return NULL;
}

/* dst[:, cols] = src for (F, m) src and (F, D) dst of one 8-byte type (float64 or int64), copied as they are; with
 * changed (F,) uint8 (float64 only), changed[i] = 1 where a value of row i differs (!=, as numpy's: -0.0 == 0.0)
 * from the one it overwrites. */
static PyObject *py_put_columns(PyObject *mod, PyObject *args)
{
    (void)mod;
    PyObject *osrc, *odst, *ocols, *ochanged = Py_None;
    if (!PyArg_ParseTuple(args, "OOO|O", &osrc, &odst, &ocols, &ochanged))
        return NULL;
    Py_buffer src, dst, cols, changed;
    const Py_ssize_t any2[2] = {-1, -1};
    int f64 = mr_format_is_buffer_of(osrc, 'd');
    char code = f64 ? 'd' : 'q';
    if (mr_get_buffer(osrc, &src, code, 2, any2, 0, "src") < 0)
        return NULL;
    const Py_ssize_t F = src.shape[0], m = src.shape[1], rows[2] = {F, -1}, ms[1] = {m}, fs[1] = {F};
    if (mr_get_buffer(odst, &dst, code, 2, rows, 1, "dst") < 0) {
        PyBuffer_Release(&src);
        return NULL;
    }
    if (mr_get_buffer(ocols, &cols, 'q', 1, ms, 0, "cols") < 0) {
        PyBuffer_Release(&src);
        PyBuffer_Release(&dst);
        return NULL;
    }
    int have = ochanged != Py_None;
    if (have && (!f64 || mr_get_buffer(ochanged, &changed, 'B', 1, fs, 1, "changed") < 0)) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "put_columns: changed is for float64 values");
        PyBuffer_Release(&src);
        PyBuffer_Release(&dst);
        PyBuffer_Release(&cols);
        return NULL;
    }
    const Py_ssize_t D = dst.shape[1];
    const int64_t *c = cols.buf;
    int ok = 1;
    for (Py_ssize_t j = 0; j < m; j++)
        ok &= c[j] >= 0 && c[j] < D;
    if (ok) {
        Py_BEGIN_ALLOW_THREADS
        if (have) {
            const double *s = src.buf;
            double *d = dst.buf;
            uint8_t *ch = changed.buf;
            for (Py_ssize_t i = 0; i < F; i++) {
                int differ = 0;
                for (Py_ssize_t j = 0; j < m; j++) {
                    differ |= s[i * m + j] != d[i * D + c[j]];
                    d[i * D + c[j]] = s[i * m + j];
                }
                ch[i] |= (uint8_t)differ;
            }
        } else {
            const uint64_t *s = src.buf;
            uint64_t *d = dst.buf;
            for (Py_ssize_t i = 0; i < F; i++)
                for (Py_ssize_t j = 0; j < m; j++)
                    d[i * D + c[j]] = s[i * m + j];
        }
        Py_END_ALLOW_THREADS
    } else {
        PyErr_SetString(PyExc_ValueError, "put_columns: cols outside dst");
    }
    if (have)
        PyBuffer_Release(&changed);
    PyBuffer_Release(&src);
    PyBuffer_Release(&dst);
    PyBuffer_Release(&cols);
    if (!ok)
        return NULL;
    Py_RETURN_NONE;
}

/* segments: a sequence of (bits, 0, count) raw fields or (zero, decay, count) model-coded integers, the first
 * element negative for raw: (-bits, 0, count) */
static PyObject *py_integers(PyObject *mod, PyObject *args)
{
    (void)mod;
    Py_buffer b;
    PyObject *segments;
    if (!PyArg_ParseTuple(args, "y*O", &b, &segments))
        return NULL;
    PyObject *seq = PySequence_Fast(segments, "segments must be a sequence");
    if (!seq) {
        PyBuffer_Release(&b);
        return NULL;
    }
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq), total = 0;
    long long (*spec)[3] = calloc((size_t)n + 1, sizeof *spec);
    for (Py_ssize_t k = 0; spec && k < n; k++) {
        if (!PyArg_ParseTuple(PySequence_Fast_GET_ITEM(seq, k), "LLL", &spec[k][0], &spec[k][1], &spec[k][2])) {
            free(spec);
            Py_DECREF(seq);
            PyBuffer_Release(&b);
            return NULL;
        }
        if (spec[k][2] < 0 || spec[k][0] < -62 || spec[k][0] > 255 || spec[k][1] < 0
            || spec[k][1] > 255 || spec[k][2] > (1LL << 30)) {
            free(spec);
            Py_DECREF(seq);
            PyBuffer_Release(&b);
            PyErr_SetString(PyExc_ValueError, "a segment is out of range");
            return NULL;
        }
        total += (Py_ssize_t)spec[k][2];
    }
    Py_DECREF(seq);
    int64_t *values = malloc(((size_t)total + 1) * sizeof(int64_t));
    if (!spec || !values) {
        free(spec);
        free(values);
        PyBuffer_Release(&b);
        return PyErr_NoMemory();
    }
    mrt_status st;
    st.code = MRT_OK;
    mrt_range_decoder rd;
    if (b.len % 4) {
        st.code = MRT_DAMAGED;
        snprintf(st.message, sizeof st.message, "coded integers must be whole 32-bit words, got %zd bytes", b.len);
    }
    mrt_range_init(&rd, b.buf, (size_t)b.len);
    int64_t *at = values;
    for (Py_ssize_t k = 0; k < n && st.code == MRT_OK; k++) {
        size_t count = (size_t)spec[k][2];
        if (spec[k][0] < 0) {
            int bits = (int)-spec[k][0];
            for (size_t i = 0; i < count; i++)
                at[i] = 0;
            for (int shift = 0; shift < bits && st.code == MRT_OK; shift += 16) {
                int width = bits - shift < 16 ? bits - shift : 16;
                for (size_t i = 0; i < count; i++) {
                    uint32_t s;
                    if (mrt_range_uniform(&rd, width, &s)) {
                        st.code = MRT_DAMAGED;
                        snprintf(st.message, sizeof st.message, "coded integers are damaged (Tried to decode from "
                                 "compressed data that is invalid for the employed entropy model.)");
                        break;
                    }
                    at[i] |= (int64_t)((uint64_t)s << shift);
                }
            }
        } else if (count) {
            mrt_model m;
            mrt_model_build((int)spec[k][0], (int)spec[k][1], &m);
            mrt_decode_integers(&rd, &m, count, at, &st);
        }
        at += count;
    }
    free(spec);
    PyObject *out = NULL;
    if (st.code)
        raise_status(&st);
    else
        out = Py_BuildValue("NO", bytes_of(values, 8 * (uint64_t)total),
                            mrt_range_maybe_exhausted(&rd) ? Py_True : Py_False);
    free(values);
    PyBuffer_Release(&b);
    return out;
}

static PyMethodDef functions[] = {
    {"declared", py_declared, METH_VARARGS, "declared(data, version) -> (frames, features, region_frames)"},
    {"unpack", py_unpack, METH_VARARGS, "unpack(data, version) -> (F, D, region, feature_exp, region_exp, coefficients)"},
    {"decode", py_decode, METH_VARARGS, "decode(data, version) -> Frames"},
    {"reconstruct", py_reconstruct, METH_VARARGS,
     "reconstruct(F, D, region, feature_exponents, region_exponents, coefficients) -> Frames"},
    {"inverse", py_inverse, METH_VARARGS, "inverse(values, out): the inverse wavelet of (F, D) coefficients"},
    {"forward", py_forward, METH_VARARGS,
     "forward(values, out): the forward wavelet of (F, D) samples, the coefficients in inverse's layout (the "
     "encoder's)"},
    {"sample", py_sample, METH_VARARGS, "sample(times, out, frames): the features at times, feature-major"},
    {"put_columns", py_put_columns, METH_VARARGS,
     "put_columns(src, dst, cols, changed=None): dst[:, cols] = src (float64 or int64); with changed (F,) uint8, "
     "changed[i] |= any value of row i differs from the one it overwrites (float64)"},
    {"rounded", py_rounded, METH_VARARGS,
     "rounded(c, table, rows, cols, rounding, q, dq, subset=None, compare=False) -> status: the encoder's rounding "
     "of (n, m) coefficients c into q (int64) and dq (their dequantised values), steps table[rows][:, cols]; -1: "
     "a value too large to code; with compare, 1 when dq is unchanged"},
    {"integers", py_integers, METH_VARARGS, "integers(data, segments) -> (int64 bytes, maybe_exhausted)"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "motionrep_transform._cdecode",
                                    "The transform payload decoder (mrtransform) for Python.", -1, functions};

PyMODINIT_FUNC PyInit__cdecode(void)
{
    if (PyType_Ready(&FramesType) < 0)
        return NULL;
    PyObject *errors = PyImport_ImportModule("motionrep.errors");
    if (!errors)
        return NULL;
    PayloadError = PyObject_GetAttrString(errors, "PayloadError");
    Py_DECREF(errors);
    if (!PayloadError)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (!m)
        return NULL;
    Py_INCREF(&FramesType);
    if (PyModule_AddObject(m, "Frames", (PyObject *)&FramesType) < 0
        || PyModule_AddIntConstant(m, "MAX_VERSION", MRT_MAX_VERSION) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
