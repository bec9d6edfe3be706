/* Reading numpy arrays through the buffer protocol in motionrep's extensions (no numpy headers needed to build).
 * Python bindings only: include after Python.h. */
#ifndef MOTIONREP_PYBUF_H
#define MOTIONREP_PYBUF_H

#include <string.h>

/* whether a buffer's struct format is the native `code` ('d' float64, 'f' float32, 'q' int64, 'B' uint8) */
static int mr_format_is(const Py_buffer *v, char code)
{
    const char *f = v->format ? v->format : "B";
    if (f[0] == '@' || f[0] == '=' || f[0] == '<')
        f++;
    if (code == 'q' && (f[0] == 'l' && f[1] == 0) && sizeof(long) == 8)
        return 1;
    return f[0] == code && f[1] == 0;
}

/* A C-contiguous buffer of `obj` with item format `code`, `ndim` dimensions and these `shape`s (-1: any); a
 * ValueError naming `name` otherwise.  Release it with PyBuffer_Release. */
static int mr_get_buffer(PyObject *obj, Py_buffer *v, char code, int ndim, const Py_ssize_t *shape, int writable,
                         const char *name)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, v, flags) < 0) {
        PyErr_Clear();
        PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous%s array", name, writable ? " writable" : "");
        return -1;
    }
    int ok = mr_format_is(v, code) && v->ndim == ndim;
    for (int k = 0; ok && k < ndim; k++)
        ok = shape[k] < 0 || v->shape[k] == shape[k];
    if (!ok) {
        PyBuffer_Release(v);
        PyErr_Format(PyExc_ValueError, "%s has the wrong dtype or shape", name);
        return -1;
    }
    return 0;
}

#endif
