/* motionrep_transform._ccoder: the thin Python binding of mrcoder.c (the entropy coder of transform payloads of
 * version 2). Arrays cross as buffers (numpy int64 arrays, C-contiguous); the GIL is released while coding.
 *
 *   declared(data) -> (frames, features, region)     (the head only; decode checks they fit the bytes)
 *   encode(frames, features, region, fexp, rexp, coef) -> bytes
 *   decode(data, fexp, rexp, coef) -> None      (writes into the three writable int64 buffers)
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
    if (!PyArg_ParseTuple(args, "LLLOOO", &F, &D, &region, &fo, &ro, &co)) return NULL;
    if (F < 1 || F > MRC_MAX_FRAMES || D < 1 || D > MRC_MAX_FEATURES || region < 1 || region > MRC_MAX_REGION)
        return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(MRC_E_ARGUMENT));
    PyObject *const objs[3] = {fo, ro, co};
    Py_buffer v[3];
    if (get_arrays(objs, v, F, D, region, 0) < 0) return NULL;
    uint8_t *out = NULL;
    size_t n = 0;
    int e;
    Py_BEGIN_ALLOW_THREADS
    e = mrc_encode(F, D, region, (const int64_t *)v[0].buf, (const int64_t *)v[1].buf, (const int64_t *)v[2].buf,
                   &out, &n);
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
    if (!PyArg_ParseTuple(args, "y*OOO", &data, &fo, &ro, &co)) return NULL;
    int64_t F, D, region;
    int e = mrc_declared((const uint8_t *)data.buf, (size_t)data.len, &F, &D, &region);
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
    e = mrc_decode((const uint8_t *)data.buf, (size_t)data.len, (int64_t *)v[0].buf, (int64_t *)v[1].buf,
                   (int64_t *)v[2].buf);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&data);
    release_arrays(v);
    if (e) {
        if (e == MRC_E_MEMORY) return PyErr_NoMemory();
        return PyErr_Format(PyExc_ValueError, "%s", mrc_error_text(e));
    }
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"declared", py_declared, METH_VARARGS, "declared(data) -> (frames, features, region): the payload's head."},
    {"encode", py_encode, METH_VARARGS,
     "encode(frames, features, region, fexp, rexp, coef) -> bytes: the version-2 payload of int64 arrays."},
    {"decode", py_decode, METH_VARARGS,
     "decode(data, fexp, rexp, coef): decode a version-2 payload into writable int64 arrays of the declared "
     "sizes."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_ccoder",
                                    "The entropy coder of transform payloads of version 2 (C).", -1, methods,
                                    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__ccoder(void) { return PyModule_Create(&module); }
