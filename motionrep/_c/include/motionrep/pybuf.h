/* Reading numpy arrays through the buffer protocol in motionrep's extensions (no numpy headers needed to build).
 * Python bindings only: include after Python.h. */
#ifndef MOTIONREP_PYBUF_H
#define MOTIONREP_PYBUF_H

#include <string.h>

/* whether a buffer's struct format is the native `code` ('d' float64, 'f' float32, 'q' int64, 'B' uint8) */
static inline int mr_format_is(const Py_buffer *v, char code)
{
    const char *f = v->format ? v->format : "B";
    if (f[0] == '@' || f[0] == '=' || f[0] == '<')
        f++;
    if (code == 'q' && (f[0] == 'l' && f[1] == 0) && sizeof(long) == 8)
        return 1;
    return f[0] == code && f[1] == 0;
}

/* whether `obj`'s buffer has the native item format `code` (a probe: no error is left set) */
static inline int mr_format_is_buffer_of(PyObject *obj, char code)
{
    Py_buffer v;
    if (PyObject_GetBuffer(obj, &v, PyBUF_FORMAT | PyBUF_ND) < 0) {
        PyErr_Clear();
        return 0;
    }
    int is = mr_format_is(&v, code);
    PyBuffer_Release(&v);
    return is;
}

/* A C-contiguous buffer of `obj` with item format `code`, `ndim` dimensions and these `shape`s (-1: any); a
 * ValueError naming `name` otherwise.  Release it with PyBuffer_Release. */
static inline int mr_get_buffer(PyObject *obj, Py_buffer *v, char code, int ndim, const Py_ssize_t *shape, int writable,
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

/* A capsule of the sampler `s` that lives inside `owner` (motionrep/sampler.h; include it first): the capsule keeps
 * a reference to its owner, so the sampler stays valid while anyone holds the capsule. */
#ifdef MOTIONREP_SAMPLER_H
static inline void mr_capsule_release(PyObject *capsule)
{
    Py_XDECREF((PyObject *)PyCapsule_GetContext(capsule));
}

/* The Python call of a sampler: the features at times (T,) float64 into a feature-major float64 out (width, >= T),
 * without the GIL; None, or MemoryError when the sampler fails (ValueError while its `sample` is NULL). */
static inline PyObject *mr_run_sampler(const mr_sampler *s, PyObject *times, PyObject *out)
{
    if (!s->sample)
        return PyErr_Format(PyExc_ValueError, "the decoder is not initialised");
    Py_buffer bt, bo;
    Py_ssize_t any[1] = {-1}, so[2] = {(Py_ssize_t)s->width, -1};
    if (mr_get_buffer(times, &bt, 'd', 1, any, 0, "times") < 0)
        return NULL;
    if (mr_get_buffer(out, &bo, 'd', 2, so, 1, "out") < 0) {
        PyBuffer_Release(&bt);
        return NULL;
    }
    if (bo.shape[1] < bt.shape[0]) {
        PyBuffer_Release(&bt);
        PyBuffer_Release(&bo);
        PyErr_SetString(PyExc_ValueError, "out must have shape (D, >= T)");
        return NULL;
    }
    int e;
    Py_BEGIN_ALLOW_THREADS
    e = s->sample(s->state, bt.buf, (size_t)bt.shape[0], bo.buf, (size_t)bo.shape[1]);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&bt);
    PyBuffer_Release(&bo);
    if (e)
        return PyErr_NoMemory();
    Py_RETURN_NONE;
}

/* The capsule of an object's sampler (ValueError while its `sample` is NULL: the object is not initialised). */
static inline PyObject *mr_sampler_capsule(PyObject *owner, mr_sampler *s)
{
    if (!s->sample)
        return PyErr_Format(PyExc_ValueError, "the decoder is not initialised");
    PyObject *capsule = PyCapsule_New(s, MR_SAMPLER_CAPSULE, mr_capsule_release);
    if (!capsule)
        return NULL;
    Py_INCREF(owner);
    if (PyCapsule_SetContext(capsule, owner) < 0) {
        Py_DECREF(owner);
        Py_DECREF(capsule);
        return NULL;
    }
    return capsule;
}

/* The two Python faces of a decoder type TYPE whose objects (struct OBJECT) hold an mr_sampler `sampler`:
 * NAME_sampler_get, the getter of its `sampler` attribute (for a PyGetSetDef), and NAME_sample, the module function
 * sample(times, out, decoder).  TYPE must be declared before (a tentative `static PyTypeObject TYPE;`). */
#define MR_SAMPLER_BINDING(NAME, OBJECT, TYPE)                                                                     \
    static PyObject *NAME##_sampler_get(PyObject *self, void *closure)                                            \
    {                                                                                                             \
        (void)closure;                                                                                            \
        return mr_sampler_capsule(self, &((OBJECT *)self)->sampler);                                              \
    }                                                                                                             \
    static PyObject *NAME##_sample(PyObject *mod, PyObject *args)                                                 \
    {                                                                                                             \
        (void)mod;                                                                                                \
        PyObject *ot, *oo, *od;                                                                                   \
        if (!PyArg_ParseTuple(args, "OOO!", &ot, &oo, &(TYPE), &od))                                              \
            return NULL;                                                                                          \
        return mr_run_sampler(&((OBJECT *)od)->sampler, ot, oo);                                                  \
    }
#endif

#endif
