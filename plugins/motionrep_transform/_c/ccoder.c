/* motionrep_transform._ccoder: the thin Python binding of mrcoder.c (the entropy coder of transform payloads of
 * versions 2 and 3). Arrays cross as buffers (numpy int64 arrays, C-contiguous); the GIL is released while coding.
 *
 *   declared(data) -> (frames, features, region)     (the head only; decode checks they fit the bytes)
 *   encode(frames, features, region, fexp, rexp, coef, version) -> bytes
 *   decode(data, fexp, rexp, coef, version, feature_major=0, reference=0) -> None
 *                                                      (writes into the three writable int64 buffers; coef F x D,
 *                                                       or D x F with feature_major; reference: the generic loop,
 *                                                       mrc_decode_reference, for tests of the decoder's own) 
 *   states(frames, features, region, fexp, rexp, coef) -> bytes   (mrc_states: MRC_STATES int16 stretches, then
 *                                                                  MRC_STATES uint16 counts, native order)
 *
 * Errors: ValueError with mrcoder's one-line text (the Python side turns it into a PayloadError).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <stdlib.h>

#include "mrcoder.h"

static int get_int64s(PyObject *obj, Py_buffer *view, Py_ssize_t count, int writable, const char *what) {
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0)) < 0)
        return -1;
    const char *f = view->format ? view->format : "B";
    if (*f == '<' || *f == '=' || *f == '@') f++;
    if (view->itemsize != 8 || (*f != 'q' && *f != 'l') || f[1] != '\0' || view->len != count * 8) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd int64 values", what, count);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

/* the three int64 arrays of a payload (fexp D, rexp R, coef F x D); on failure none is held */
static int get_arrays(PyObject *const objs[3], Py_buffer views[3], long long F, long long D, long long region,
                      int writable) {
    static const char *names[3] = {"fexp", "rexp", "coef"};
    Py_ssize_t counts[3] = {(Py_ssize_t)D, (Py_ssize_t)((F + region - 1) / region), (Py_ssize_t)(F * D)};
    for (int i = 0; i < 3; i++) {
        if (get_int64s(objs[i], &views[i], counts[i], writable, names[i]) < 0) {
            while (i-- > 0) PyBuffer_Release(&views[i]);
            return -1;
        }
    }
    return 0;
}

static void release_arrays(Py_buffer views[3]) {
    for (int i = 0; i < 3; i++) PyBuffer_Release(&views[i]);
}

static PyObject *py_declared(PyObject *self, PyObject *args) {
    Py_buffer data;
    (void)self;
    if (!PyArg_ParseTuple(args, "y*", &data)) return NULL;
    int64_t F, D, region;
    int e = mrc_declared((const uint8_t *)data.buf, (size_t)data.len, &F, &D, &region);
    PyBuffer_Release(&data);
    if (e) return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(e));
    return Py_BuildValue("LLL", (long long)F, (long long)D, (long long)region);
}

static PyObject *py_encode(PyObject *self, PyObject *args) {
    long long F, D, region;
    PyObject *fo, *ro, *co;
    (void)self;
    int version;
    if (!PyArg_ParseTuple(args, "LLLOOOi", &F, &D, &region, &fo, &ro, &co, &version)) return NULL;
    if (F < 1 || F > MRC_MAX_FRAMES || D < 1 || D > MRC_MAX_FEATURES || region < 1 || region > MRC_MAX_REGION ||
        (version != 2 && version != 3))
        return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(MRC_E_ARGUMENT));
    PyObject *const objs[3] = {fo, ro, co};
    Py_buffer v[3];
    if (get_arrays(objs, v, F, D, region, 0) < 0) return NULL;
    uint8_t *out = NULL;
    size_t n = 0;
    int e;
    Py_BEGIN_ALLOW_THREADS
    e = mrc_encode_version(version, F, D, region, (const int64_t *)v[0].buf, (const int64_t *)v[1].buf,
                           (const int64_t *)v[2].buf, &out, &n);
    Py_END_ALLOW_THREADS
    release_arrays(v);
    if (e) {
        if (e == MRC_E_MEMORY) return PyErr_NoMemory();
        return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(e));
    }
    PyObject *result = PyBytes_FromStringAndSize((const char *)out, (Py_ssize_t)n);
    free(out);
    return result;
}

static PyObject *py_decode(PyObject *self, PyObject *args) {
    Py_buffer data;
    PyObject *fo, *ro, *co;
    (void)self;
    int version, feature_major = 0, reference = 0;
    if (!PyArg_ParseTuple(args, "y*OOOi|pp", &data, &fo, &ro, &co, &version, &feature_major, &reference))
        return NULL;
    int64_t F, D, region;
    int e = (version == 2 || version == 3) ? mrc_declared((const uint8_t *)data.buf, (size_t)data.len, &F, &D, &region)
                                           : MRC_E_ARGUMENT;
    if (!e && !mrc_fits(F, D, region, (size_t)data.len)) e = MRC_E_TOO_MANY;
    if (e) {
        PyBuffer_Release(&data);
        return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(e));
    }
    PyObject *const objs[3] = {fo, ro, co};
    Py_buffer v[3];
    if (get_arrays(objs, v, F, D, region, 1) < 0) {
        PyBuffer_Release(&data);
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    e = (reference ? mrc_decode_reference : mrc_decode_version)(version, (const uint8_t *)data.buf, (size_t)data.len,
                                                                (int64_t *)v[0].buf, (int64_t *)v[1].buf,
                                                                (int64_t *)v[2].buf, feature_major);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&data);
    release_arrays(v);
    if (e) {
        if (e == MRC_E_MEMORY) return PyErr_NoMemory();
        return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(e));
    }
    Py_RETURN_NONE;
}

static PyObject *py_states(PyObject *self, PyObject *args) {
    long long F, D, region;
    PyObject *fo, *ro, *co;
    (void)self;
    if (!PyArg_ParseTuple(args, "LLLOOO", &F, &D, &region, &fo, &ro, &co)) return NULL;
    if (F < 1 || F > MRC_MAX_FRAMES || D < 1 || D > MRC_MAX_FEATURES || region < 1 || region > MRC_MAX_REGION)
        return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(MRC_E_ARGUMENT));
    PyObject *const objs[3] = {fo, ro, co};
    Py_buffer v[3];
    if (get_arrays(objs, v, F, D, region, 0) < 0) return NULL;
    PyObject *result = PyBytes_FromStringAndSize(NULL, (Py_ssize_t)(MRC_STATES * 4));
    if (!result) {
        release_arrays(v);
        return NULL;
    }
    char *buf = PyBytes_AS_STRING(result);
    int e;
    Py_BEGIN_ALLOW_THREADS
    e = mrc_states(F, D, region, (const int64_t *)v[0].buf, (const int64_t *)v[1].buf, (const int64_t *)v[2].buf,
                   (int16_t *)buf, (uint16_t *)(buf + 2 * MRC_STATES));
    Py_END_ALLOW_THREADS
    release_arrays(v);
    if (e) {
        Py_DECREF(result);
        if (e == MRC_E_MEMORY) return PyErr_NoMemory();
        return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(e));
    }
    return result;
}

static PyMethodDef methods[] = {
    {"declared", py_declared, METH_VARARGS, "declared(data) -> (frames, features, region): the payload's head."},
    {"encode", py_encode, METH_VARARGS,
     "encode(frames, features, region, fexp, rexp, coef, version) -> bytes: the payload (version 2 or 3) of int64 "
     "arrays."},
    {"decode", py_decode, METH_VARARGS,
     "decode(data, fexp, rexp, coef, version, feature_major=False, reference=False): decode a payload (version 2 "
     "or 3) into writable int64 arrays of the declared sizes (coef D x F with feature_major; reference: by the "
     "generic loop the decoder's own is tested against)."},
    {"states", py_states, METH_VARARGS,
     "states(frames, features, region, fexp, rexp, coef) -> bytes: the final fixed-counter states of version 2's "
     "models (int16 stretches, then uint16 counts; for benchmarks/prior3.py)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_ccoder",
                                    "The entropy coder of transform payloads of versions 2 and 3 (C).", -1, methods,
                                    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__ccoder(void) { return PyModule_Create(&module); }
