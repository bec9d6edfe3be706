/* motionrep._ccore: the Python glue of the compiled core (the kernels are plain C: numbers.c, shortest.c, fk.c,
 * rotations.c, edits.c, euler.c, chain.c).  Arrays come in through the buffer protocol (numpy arrays, bytes); each is checked here for its
 * element type, its number of dimensions, C order and the sizes the kernel will touch, so a wrong call raises
 * TypeError or ValueError instead of reading or writing out of bounds.  The kernels run without the GIL.
 * The Python modules that call these (motionrep/io/_numbers.py, motionrep/io/_shortest.py,
 * motionrep/model/kinematics.py, motionrep/model/rotations.py, motionrep/pipeline/edits.py) validate arguments with motionrep's own errors
 * first; this layer is the last line, not the user-facing one. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdlib.h>
#include <string.h>

#include "ccore.h"
#include "mr_rotconv.h"

#define MAX_BUFFERS 16

typedef struct {
    Py_buffer b[MAX_BUFFERS];
    int n;
} buffers;

static void release(buffers *bs)
{
    for (int i = 0; i < bs->n; i++)
        PyBuffer_Release(&bs->b[i]);
    bs->n = 0;
}

/* kind: 'd' float64, 'f' float32, 'r' float32 or float64, 'q' int64, 'B' bytes.  ndim < 0: any.  Returns the
 * buffer (held in bs until release) or NULL with an exception set. */
static Py_buffer *get(buffers *bs, PyObject *obj, const char *name, char kind, int ndim, int writable)
{
    Py_buffer *b = &bs->b[bs->n];
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, b, flags) < 0) {
        PyErr_Format(PyExc_TypeError, "%s must be a C-contiguous%s array", name, writable ? " writable" : "");
        return NULL;
    }
    bs->n++;
    const char *fmt = b->format ? b->format : "B";
    if (*fmt == '@' || *fmt == '=' || *fmt == '<')
        fmt++;
    int single = fmt[0] && !fmt[1], good = 0;
    switch (kind) {
    case 'd':
        good = single && fmt[0] == 'd' && b->itemsize == 8;
        break;
    case 'r':
        good = single && ((fmt[0] == 'd' && b->itemsize == 8) || (fmt[0] == 'f' && b->itemsize == 4));
        break;
    case 'q':
        good = single && (fmt[0] == 'q' || fmt[0] == 'l') && b->itemsize == 8;
        break;
    case 'B':
        good = single && (fmt[0] == 'B' || fmt[0] == 'b' || fmt[0] == 'c') && b->itemsize == 1;
        break;
    }
    if (!good || (ndim >= 0 && b->ndim != ndim)) {
        static const char *what[] = {"float64", "float32 or float64", "int64", "uint8"};
        int w = kind == 'd' ? 0 : kind == 'r' ? 1 : kind == 'q' ? 2 : 3;
        if (ndim >= 0)
            PyErr_Format(PyExc_TypeError, "%s must be a %d-D %s array", name, ndim, what[w]);
        else
            PyErr_Format(PyExc_TypeError, "%s must be a %s array", name, what[w]);
        return NULL;
    }
    return b;
}

static Py_ssize_t dim(const Py_buffer *b, int k) { return b->shape ? b->shape[k] : b->len / b->itemsize; }

static PyObject *fail(buffers *bs, const char *message)
{
    release(bs);
    PyErr_SetString(PyExc_ValueError, message);
    return NULL;
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(scan_doc, "scan(u, width, rows_max, by_line, out, fallback, info)\n--\n\n"
                       "The numbers of the bytes u (motionrep.io._numbers.scan_block): float64 values into out,\n"
                       "(slot, start, end, line) of each token left to Python's float into fallback (K, 4) int64,\n"
                       "the counts into info (8,) int64.");

static PyObject *py_scan(PyObject *self, PyObject *args)
{
    PyObject *ou, *oout, *ofb, *oinfo;
    Py_ssize_t width, rows_max;
    int by_line;
    if (!PyArg_ParseTuple(args, "OnnpOOO", &ou, &width, &rows_max, &by_line, &oout, &ofb, &oinfo))
        return NULL;
    buffers bs = {.n = 0};
    Py_buffer *u, *out, *fb, *info;
    if (!(u = get(&bs, ou, "u", 'B', -1, 0)) || !(out = get(&bs, oout, "out", 'd', 1, 1))
        || !(fb = get(&bs, ofb, "fallback", 'q', 2, 1)) || !(info = get(&bs, oinfo, "info", 'q', 1, 1))) {
        release(&bs);
        return NULL;
    }
    if (width < 0 || rows_max < 0 || dim(fb, 1) != 4 || dim(info, 0) != MR_SCAN_INFO)
        return fail(&bs, "scan: fallback must be (K, 4) and info (8,), width and rows_max >= 0");
    if (by_line && (width && rows_max > dim(out, 0) / width))
        return fail(&bs, "scan: out must hold rows_max * width values");
    Py_BEGIN_ALLOW_THREADS
    mr_scan((const uint8_t *)u->buf, (int64_t)u->len, width, rows_max, by_line, (double *)out->buf, dim(out, 0),
            (int64_t *)fb->buf, dim(fb, 0), (int64_t *)info->buf);
    Py_END_ALLOW_THREADS
    release(&bs);
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(format_doc, "format_shortest(flat, per_line, out, fallback) -> (length, left)\n--\n\n"
                         "flat's float64 values as the shortest decimals (motionrep.io._shortest), per_line to a line,\n"
                         "into the uint8 array out (26 bytes a value); (offset, index) of each value left to repr into\n"
                         "fallback (K, 2) int64.");

static PyObject *py_format_shortest(PyObject *self, PyObject *args)
{
    PyObject *oflat, *oout, *ofb;
    Py_ssize_t per_line;
    if (!PyArg_ParseTuple(args, "OnOO", &oflat, &per_line, &oout, &ofb))
        return NULL;
    buffers bs = {.n = 0};
    Py_buffer *flat, *out, *fb;
    if (!(flat = get(&bs, oflat, "flat", 'd', 1, 0)) || !(out = get(&bs, oout, "out", 'B', 1, 1))
        || !(fb = get(&bs, ofb, "fallback", 'q', 2, 1))) {
        release(&bs);
        return NULL;
    }
    Py_ssize_t count = dim(flat, 0);
    if (per_line < 1 || dim(fb, 1) != 2 || out->len / MR_SHORTEST_WIDTH < count)
        return fail(&bs, "format_shortest: per_line >= 1, fallback (K, 2), out of 26 bytes a value");
    int64_t length, left;
    Py_BEGIN_ALLOW_THREADS
    length = mr_format_shortest((const double *)flat->buf, count, per_line, (uint8_t *)out->buf, (int64_t *)fb->buf,
                                dim(fb, 0), &left);
    Py_END_ALLOW_THREADS
    release(&bs);
    return Py_BuildValue("LL", (long long)length, (long long)left);
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(fk_doc, "fk(rot, root, offsets, parents, translated, joint_t, site_parents, site_offsets, out_pos, out_rot)\n"
                     "--\n\n"
                     "Forward kinematics (motionrep.model.kinematics.fk_arrays): rot (F, J, 4) float32 or float64,\n"
                     "root (F, 3), offsets (J, 3), parents (J,), translated (P,), joint_t (F, P, 3), site_parents\n"
                     "(E,), site_offsets (E, 3); out_pos (F, J + E, 3) and out_rot (F, J + E, 4) or None, written.");

static PyObject *py_fk(PyObject *self, PyObject *args)
{
    PyObject *o[10];
    if (!PyArg_ParseTuple(args, "OOOOOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8], &o[9]))
        return NULL;
    buffers bs = {.n = 0};
    Py_buffer *rot, *root, *offsets, *parents, *translated, *joint_t, *sp, *so, *pos, *orot = NULL;
    if (!(rot = get(&bs, o[0], "rot", 'r', 3, 0)) || !(root = get(&bs, o[1], "root", 'd', 2, 0))
        || !(offsets = get(&bs, o[2], "offsets", 'd', 2, 0)) || !(parents = get(&bs, o[3], "parents", 'q', 1, 0))
        || !(translated = get(&bs, o[4], "translated", 'q', 1, 0))
        || !(joint_t = get(&bs, o[5], "joint_t", 'd', 3, 0)) || !(sp = get(&bs, o[6], "site_parents", 'q', 1, 0))
        || !(so = get(&bs, o[7], "site_offsets", 'd', 2, 0)) || !(pos = get(&bs, o[8], "out_pos", 'd', 3, 1))
        || (o[9] != Py_None && !(orot = get(&bs, o[9], "out_rot", 'd', 3, 1)))) {
        release(&bs);
        return NULL;
    }
    int64_t F = dim(rot, 0), J = dim(rot, 1), P = dim(translated, 0), E = dim(sp, 0);
    if (dim(rot, 2) != 4 || dim(root, 0) != F || dim(root, 1) != 3 || dim(offsets, 0) != J || dim(offsets, 1) != 3
        || dim(parents, 0) != J || dim(joint_t, 0) != F || dim(joint_t, 1) != P || dim(joint_t, 2) != 3
        || dim(so, 0) != E || dim(so, 1) != 3 || dim(pos, 0) != F || dim(pos, 1) != J + E || dim(pos, 2) != 3
        || (orot && (dim(orot, 0) != F || dim(orot, 1) != J + E || dim(orot, 2) != 4)))
        return fail(&bs, "fk: array shapes do not agree");
    const int64_t *par = parents->buf, *tr = translated->buf, *spa = sp->buf;
    for (int64_t j = 0; j < J; j++)
        if (par[j] >= j || (par[j] < 0 && j > 0) || (j == 0 && par[0] >= 0))
            return fail(&bs, "fk: parents must come before their children, the root (parent -1) first");
    for (int64_t k = 0; k < P; k++)
        if (tr[k] < 0 || tr[k] >= J)
            return fail(&bs, "fk: translated joints out of range");
    for (int64_t e = 0; e < E; e++)
        if (spa[e] < 0 || spa[e] >= J)
            return fail(&bs, "fk: end-site parents out of range");
    if (F > 0 && J == 0)
        return fail(&bs, "fk: no joints");
    mr_fk_args a = {F, J, E, P, rot->buf, rot->itemsize == 4, root->buf, offsets->buf, joint_t->buf, so->buf,
                    par, tr, spa, pos->buf, orot ? orot->buf : NULL};
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = mr_fk(&a);
    Py_END_ALLOW_THREADS
    if (status) {
        release(&bs);
        return PyErr_NoMemory();
    }
    release(&bs);
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(distances_doc, "max_distances(positions, reference, out) -> finite\n--\n\n"
                            "out[k] = the largest distance between positions[k] (N, P, 3) and reference[k % M]\n"
                            "(M, P, 3) over the P points (motionrep.pipeline.evaluate); False if one is not finite.");

static PyObject *py_max_distances(PyObject *self, PyObject *args)
{
    PyObject *opos, *oref, *oout;
    if (!PyArg_ParseTuple(args, "OOO", &opos, &oref, &oout))
        return NULL;
    buffers bs = {.n = 0};
    Py_buffer *pos, *ref, *out;
    if (!(pos = get(&bs, opos, "positions", 'd', 3, 0)) || !(ref = get(&bs, oref, "reference", 'd', 3, 0))
        || !(out = get(&bs, oout, "out", 'd', 1, 1))) {
        release(&bs);
        return NULL;
    }
    int64_t N = dim(pos, 0), P = dim(pos, 1), M = dim(ref, 0);
    if (dim(pos, 2) != 3 || dim(ref, 1) != P || dim(ref, 2) != 3 || dim(out, 0) != N || (M == 0 && N > 0)
        || (M > 0 && N % M))
        return fail(&bs, "max_distances: positions (N, P, 3), reference (M, P, 3) with M dividing N, out (N,)");
    int finite;
    Py_BEGIN_ALLOW_THREADS
    finite = mr_max_distances(pos->buf, ref->buf, N, M, P, out->buf);
    Py_END_ALLOW_THREADS
    release(&bs);
    return PyBool_FromLong(finite);
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(columns_doc, "columns_to_quat(kind, features, columns, axes, joints, out) -> status\n--\n\n"
                          "out[:, joints[r]] = the quaternion of features[:, columns[r]] (motionrep.model.rotations):\n"
                          "kind 0 quaternion, 1 rotation vector, 2 Euler radians, 3 Euler degrees, 4 6D; features\n"
                          "(T, C) and out (T, J, 4) float32 or float64, columns (R, width) int64 (Euler: -1 ends\n"
                          "early), axes (R, 3) int64 or None, joints (R,) int64.  Returns 0, 2 (a quaternion of zero\n"
                          "length) or 3 (a degenerate 6D encoding).");

static PyObject *py_columns_to_quat(PyObject *self, PyObject *args)
{
    int kind;
    PyObject *ofeat, *ocols, *oaxes, *ojoints, *oout;
    if (!PyArg_ParseTuple(args, "iOOOOO", &kind, &ofeat, &ocols, &oaxes, &ojoints, &oout))
        return NULL;
    if (kind < MR_QUAT || kind > MR_ORTHO6D) {
        PyErr_SetString(PyExc_ValueError, "columns_to_quat: unknown kind");
        return NULL;
    }
    int euler = kind == MR_EULER || kind == MR_EULER_DEGREES;
    buffers bs = {.n = 0};
    Py_buffer *feat, *cols, *axes = NULL, *joints, *out;
    if (!(feat = get(&bs, ofeat, "features", 'r', 2, 0)) || !(cols = get(&bs, ocols, "columns", 'q', 2, 0))
        || (euler && !(axes = get(&bs, oaxes, "axes", 'q', 2, 0))) || !(joints = get(&bs, ojoints, "joints", 'q', 1, 0))
        || !(out = get(&bs, oout, "out", 'r', 3, 1))) {
        release(&bs);
        return NULL;
    }
    int64_t T = dim(feat, 0), C = dim(feat, 1), R = dim(joints, 0), J = dim(out, 1);
    int64_t width = kind == MR_QUAT ? 4 : kind == MR_ORTHO6D ? 6 : 3;
    if (dim(cols, 0) != R || dim(cols, 1) != width || (axes && (dim(axes, 0) != R || dim(axes, 1) != 3))
        || dim(out, 0) != T || dim(out, 2) != 4)
        return fail(&bs, "columns_to_quat: array shapes do not agree");
    const int64_t *c = cols->buf, *ax = axes ? axes->buf : NULL, *jo = joints->buf;
    for (int64_t r = 0; r < R; r++) {
        if (jo[r] < 0 || jo[r] >= J)
            return fail(&bs, "columns_to_quat: joints out of range");
        int ended = 0;
        for (int64_t k = 0; k < width; k++) {
            int64_t v = c[width * r + k];
            if (euler && (v < 0 || ended)) {
                if (v != -1 || k == 0)
                    return fail(&bs, "columns_to_quat: an Euler entry needs its first column, -1 only after");
                ended = 1;
                continue;
            }
            if (v < 0 || v >= C)
                return fail(&bs, "columns_to_quat: columns out of range");
            if (euler && (ax[3 * r + k] < 0 || ax[3 * r + k] > 2))
                return fail(&bs, "columns_to_quat: Euler axes must be 0, 1 or 2");
        }
    }
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = mr_columns_to_quat(kind, feat->buf, feat->itemsize == 4, T, C, c, ax, jo, R, out->buf,
                                out->itemsize == 4, J);
    Py_END_ALLOW_THREADS
    release(&bs);
    return PyLong_FromLong(status);
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(continuous_doc, "axis_angle_continuous(theta, axis, out)\n--\n\n"
                             "The continuity pass of rotation vectors (motionrep.model.rotations."
                             "axis_angle_make_continuous):\ntheta (F, N), axis and out (F, N, 3) float64, out in place.");

static PyObject *py_axis_angle_continuous(PyObject *self, PyObject *args)
{
    PyObject *otheta, *oaxis, *oout;
    if (!PyArg_ParseTuple(args, "OOO", &otheta, &oaxis, &oout))
        return NULL;
    buffers bs = {.n = 0};
    Py_buffer *theta, *axis, *out;
    if (!(theta = get(&bs, otheta, "theta", 'd', 2, 0)) || !(axis = get(&bs, oaxis, "axis", 'd', 3, 0))
        || !(out = get(&bs, oout, "out", 'd', 3, 1))) {
        release(&bs);
        return NULL;
    }
    int64_t F = dim(theta, 0), N = dim(theta, 1);
    if (dim(axis, 0) != F || dim(axis, 1) != N || dim(axis, 2) != 3 || dim(out, 0) != F || dim(out, 1) != N
        || dim(out, 2) != 3)
        return fail(&bs, "axis_angle_continuous: array shapes do not agree");
    Py_BEGIN_ALLOW_THREADS
    mr_axis_angle_continuous(theta->buf, axis->buf, out->buf, F, N);
    Py_END_ALLOW_THREADS
    release(&bs);
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------------------------------------------------ */
/* The (N, 4) float64 quaternions q and the (N, 3) float64 out of a conversion from quaternions (`what`): N, or -1
 * with the error set and the buffers released. */
static int64_t quat_rows(buffers *bs, PyObject *oq, PyObject *oout, const char *what, Py_buffer **q, Py_buffer **out)
{
    if (!(*q = get(bs, oq, "q", 'd', 2, 0)) || !(*out = get(bs, oout, "out", 'd', 2, 1))) {
        release(bs);
        return -1;
    }
    int64_t n = dim(*q, 0);
    if (dim(*q, 1) != 4 || dim(*out, 0) != n || dim(*out, 1) != 3) {
        release(bs);
        PyErr_Format(PyExc_ValueError, "%s: q must have shape (N, 4) and out (N, 3)", what);
        return -1;
    }
    return n;
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(rotvec_doc, "quat_to_axis_angle(q, out) -> index\n--\n\n"
                         "Rotation vectors of q (N, 4) float64 xyzw into out (N, 3) float64, as scipy's "
                         "Rotation.from_quat(q).as_rotvec():\n-1, or the index of the first quaternion of zero or "
                         "NaN length (out is then incomplete).");

static PyObject *py_quat_to_axis_angle(PyObject *self, PyObject *args)
{
    PyObject *oq, *oout;
    if (!PyArg_ParseTuple(args, "OO", &oq, &oout))
        return NULL;
    buffers bs = {.n = 0};
    Py_buffer *q, *out;
    int64_t n = quat_rows(&bs, oq, oout, "quat_to_axis_angle", &q, &out), zero;
    if (n < 0)
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    zero = mr_quat_to_axis_angle(q->buf, n, out->buf);
    Py_END_ALLOW_THREADS
    release(&bs);
    return PyLong_FromLongLong(zero);
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(euler_doc, "quat_to_euler(q, seq, degrees, out) -> index\n--\n\n"
                        "Euler angles of q (N, 4) float64 xyzw into out (N, 3) float64 for seq (3 axes of 'xyz' or "
                        "'XYZ',\nno axis twice in a row), as scipy's Rotation.from_quat(q).as_euler(seq, degrees): "
                        "-1, or the index of\nthe first quaternion of zero or NaN length (out is then incomplete).");

static PyObject *py_quat_to_euler(PyObject *self, PyObject *args)
{
    PyObject *oq, *oout;
    const char *seq;
    int degrees;
    if (!PyArg_ParseTuple(args, "OspO", &oq, &seq, &degrees, &oout))
        return NULL;
    int ok = strlen(seq) == 3;
    for (int e = 0; ok && e < 3; e++)
        ok = (seq[e] >= 'x' && seq[e] <= 'z' && seq[0] >= 'x') || (seq[e] >= 'X' && seq[e] <= 'Z' && seq[0] <= 'Z');
    if (!ok || seq[0] == seq[1] || seq[1] == seq[2]) {
        PyErr_SetString(PyExc_ValueError, "quat_to_euler: seq must be three axes of 'xyz' or of 'XYZ', no axis twice "
                                          "in a row");
        return NULL;
    }
    buffers bs = {.n = 0};
    Py_buffer *q, *out;
    int64_t n = quat_rows(&bs, oq, oout, "quat_to_euler", &q, &out), zero;
    if (n < 0)
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    zero = mr_quat_to_euler(q->buf, n, seq, degrees, out->buf);
    Py_END_ALLOW_THREADS
    release(&bs);
    return PyLong_FromLongLong(zero);
}

/* ------------------------------------------------------------------------------------------------------------ */
PyDoc_STRVAR(sincos_doc, "sincos(x) -> (sin x, cos x)\n--\n\n"
                         "The sine and cosine every conversion to quaternions uses (mr_rotconv.h), for a float x.");

static PyObject *py_sincos(PyObject *self, PyObject *arg)
{
    double x = PyFloat_AsDouble(arg), s, c;
    if (x == -1.0 && PyErr_Occurred())
        return NULL;
    mr_sincos(x, &s, &c);
    return Py_BuildValue("dd", s, c);
}

/* ------------------------------------------------------------------------------------------------------------ */
#define K_QUAT_KIND 0 /* motionrep.model.poseplan.QUAT */
/* The edits' arrays (ccore.h, mr_edits), checked so that no index the kernels follow leaves its array:
 * layout int64 = [F, J, E, D, N, world, parents (J), slot (J), site_parents (E), entry (J), lip_kind (D),
 * cstart (D + 1), sstart (D + 1), cjoints, csites]; geom float64 = [offsets (J, 3), site_offsets (E, 3),
 * lip (cstart[D] + sstart[D]): the factor of each column's bound per point it moves, as cjoints then csites];
 * state float64 = [X (D, F),
 * L (F, J, 4), GP (F, J, 4), T (F, N, 3), G (F, J, 4), W (F, J + E, 3), ref (F, J + E, 3), dist (F, J + E)].
 * Returns NULL, or the message of what is wrong. */
static const char *edits_setup(mr_edits *s, const Py_buffer *layout, const Py_buffer *plan_i, const Py_buffer *plan_f,
                               const Py_buffer *geom, const Py_buffer *state)
{
    const int64_t *l = layout->buf, nl = dim(layout, 0), *pi = plan_i->buf, np_ = dim(plan_i, 0);
    if (nl < 6)
        return "edits: layout too short";
    const int64_t F = l[0], J = l[1], E = l[2], D = l[3], N = l[4];
    if (F < 0 || J < 1 || E < 0 || D < 0 || N < 1 || F > ((int64_t)1 << 40) || J > 65536 || E > 65536
        || D > ((int64_t)1 << 20) || N > J)
        return "edits: counts out of range";
    int64_t fixed = 6 + 3 * J + E + D + 2 * (D + 1);
    if (nl < fixed)
        return "edits: layout too short";
    const int64_t *parents = l + 6, *slot = parents + J, *sp = slot + J, *entry = sp + E, *lip_kind = entry + J;
    const int64_t *cstart = lip_kind + D;
    const int64_t *sstart = cstart + D + 1;
    if (cstart[0] != 0 || sstart[0] != 0)
        return "edits: column lists must start at 0";
    for (int64_t c = 0; c < D; c++)
        if (cstart[c + 1] < cstart[c] || sstart[c + 1] < sstart[c])
            return "edits: column lists must not decrease";
    if (cstart[D] > 2 * J * (D + 1) || sstart[D] > E * (D + 1) || nl != fixed + cstart[D] + sstart[D])
        return "edits: layout size does not match its lists";
    const int64_t *cjoints = sstart + D + 1, *csites = cjoints + cstart[D];
    for (int64_t k = 0; k < cstart[D]; k++)
        if (cjoints[k] < 0 || cjoints[k] >= 2 * J)
            return "edits: joints out of range";
    for (int64_t k = 0; k < sstart[D]; k++)
        if (csites[k] < 0 || csites[k] >= E)
            return "edits: end sites out of range";
    if (parents[0] != -1 || slot[0] != 0)
        return "edits: joint 0 must be the root, in translation slot 0";
    for (int64_t j = 1; j < J; j++)
        if (parents[j] < 0 || parents[j] >= j)
            return "edits: parents must come before their children";
    for (int64_t j = 0; j < J; j++)
        if (slot[j] < -1 || slot[j] >= N)
            return "edits: translation slots out of range";
    for (int64_t e = 0; e < E; e++)
        if (sp[e] < 0 || sp[e] >= J)
            return "edits: end-site parents out of range";
    if (np_ < 12 || pi[1] != J || pi[2] != N)
        return "edits: the plan does not fit the skeleton";
    const int64_t R = pi[0];
    if (R < 0 || R > J)
        return "edits: plan entries out of range";
    const int64_t need[7][2] = {{4, R}, {5, 6 * R}, {6, 3 * R}, {7, R}, {8, J}, {9, pi[3]}, {10, 3 * N}};
    for (int k = 0; k < 7; k++)
        if (need[k][1] < 0 || pi[need[k][0]] < 12 || pi[need[k][0]] > np_ - need[k][1])
            return "edits: the plan's parts are out of range";
    for (int64_t r = 0; r < R; r++) {
        if (pi[pi[4] + r] < 0 || pi[pi[4] + r] > 6 || pi[pi[7] + r] < 0 || pi[pi[7] + r] >= J)
            return "edits: a plan entry out of range";
        for (int k = 0; k < 6; k++)
            if (pi[pi[5] + 6 * r + k] < -1 || pi[pi[5] + 6 * r + k] >= D)
                return "edits: a plan column out of range";
        for (int k = 0; k < 3; k++)
            if (pi[pi[6] + 3 * r + k] < -1 || pi[pi[6] + 3 * r + k] > 2)
                return "edits: a plan axis out of range";
        static const int width[7] = {4, 3, 1, 1, 6, 4, 0};
        for (int k = 0; k < width[pi[pi[4] + r]]; k++)
            if (pi[pi[5] + 6 * r + k] < 0)
                return "edits: a plan entry lacks a column";
    }
    for (int64_t k = 0; k < 3 * N; k++)
        if (pi[pi[10] + k] < -1 || pi[pi[10] + k] >= D)
            return "edits: a translation column out of range";
    for (int64_t j = 0; j < J; j++)
        if (entry[j] < -1 || entry[j] >= R || (entry[j] >= 0 && pi[pi[7] + entry[j]] != j))
            return "edits: entries do not match the plan";
    for (int64_t c = 0; c < D; c++)
        if (lip_kind[c] < 0 || lip_kind[c] >= 2 + R
            || (lip_kind[c] >= 2 && pi[pi[4] + lip_kind[c] - 2] != K_QUAT_KIND))
            return "edits: a column's bound kind out of range";
    if (dim(plan_f, 0) < 3 * N || dim(geom, 0) != 3 * (J + E) + cstart[D] + sstart[D])
        return "edits: plan values or geometry of the wrong size";
    const int64_t P = J + E, sizes[8] = {D * F, F * J * 4, F * J * 4, F * N * 3, F * J * 4, F * P * 3, F * P * 3, F * P};
    int64_t total = 0;
    for (int k = 0; k < 8; k++)
        total += sizes[k];
    if (dim(state, 0) != total)
        return "edits: state of the wrong size";
    double *st = state->buf;
    const double *g = geom->buf;
    *s = (mr_edits){.F = F, .J = J, .E = E, .D = D, .N = N, .world = pi[11] != 0, .plan_i = pi, .plan_f = plan_f->buf,
                    .parents = parents, .slot = slot, .site_parents = sp, .entry = entry, .lip_kind = lip_kind,
                    .cstart = cstart, .cjoints = cjoints, .sstart = sstart, .csites = csites, .offsets = g,
                    .site_offsets = g + 3 * J, .lip = g + 3 * (J + E)};
    s->X = st;
    s->L = s->X + sizes[0];
    s->GP = s->L + sizes[1];
    s->T = s->GP + sizes[2];
    s->G = s->T + sizes[3];
    s->W = s->G + sizes[4];
    s->ref = s->W + sizes[5];
    s->dist = (double *)s->ref + sizes[6];
    return NULL;
}

PyDoc_STRVAR(edits_doc, "edits(layout, plan_i, plan_f, geom, state, edits, deltas, bound, commit, accepted, leads=None,"
                        " starts=None, scales=None) -> count\n"
                        "--\n\n"
                        "motionrep.pipeline.edits: with edits None, the state's poses, FK and distances from its\n"
                        "features (returns 0, or 1: a distance not finite, 2: a quaternion of zero length, 3: a\n"
                        "degenerate 6D encoding).  Else each edit (column, first, count) of edits (m, 3) int64 in\n"
                        "turn, its deltas the next count values of deltas: accepted[e] = 1 (uint8) if every point it\n"
                        "moves stays within bound in every frame it touches, and with commit it is applied; returns\n"
                        "the number accepted.  leads (m,) int64 or None: each edit's frame (from its first) to check\n"
                        "first, -1 for the frame of the largest change; set where an edit fails to the frame it failed.\n"
                        "starts (m,) int64 and scales (m,) float64: edit e's values are deltas[starts[e] + i] * scales[e]\n"
                        "(deltas a pool the edits share) instead of the next count values of deltas.");

static PyObject *py_edits(PyObject *self, PyObject *args)
{
    PyObject *o[5], *oedits, *odeltas, *oacc, *oleads = Py_None, *ostarts = Py_None, *oscales = Py_None;
    double bound;
    int commit;
    if (!PyArg_ParseTuple(args, "OOOOOOOdpO|OOO", &o[0], &o[1], &o[2], &o[3], &o[4], &oedits, &odeltas, &bound,
                          &commit, &oacc, &oleads, &ostarts, &oscales))
        return NULL;
    if ((ostarts == Py_None) != (oscales == Py_None))
        return PyErr_Format(PyExc_ValueError, "edits: starts and scales go together");
    buffers bs = {.n = 0};
    Py_buffer *b[5], *edits = NULL, *deltas = NULL, *acc = NULL, *leads = NULL, *starts = NULL, *scales = NULL;
    const char *names[5] = {"layout", "plan_i", "plan_f", "geom", "state"};
    const char kinds[5] = {'q', 'q', 'd', 'd', 'd'};
    for (int k = 0; k < 5; k++)
        if (!(b[k] = get(&bs, o[k], names[k], kinds[k], 1, k == 4))) {
            release(&bs);
            return NULL;
        }
    if (oedits != Py_None
        && (!(edits = get(&bs, oedits, "edits", 'q', 2, 0)) || !(deltas = get(&bs, odeltas, "deltas", 'd', 1, 0))
            || !(acc = get(&bs, oacc, "accepted", 'B', 1, 1))
            || (oleads != Py_None && !(leads = get(&bs, oleads, "leads", 'q', 1, 1)))
            || (ostarts != Py_None && (!(starts = get(&bs, ostarts, "starts", 'q', 1, 0))
                                       || !(scales = get(&bs, oscales, "scales", 'd', 1, 0)))))) {
        release(&bs);
        return NULL;
    }
    mr_edits s;
    const char *wrong = edits_setup(&s, b[0], b[1], b[2], b[3], b[4]);
    if (wrong)
        return fail(&bs, wrong);
    int64_t result;
    if (!edits) {
        Py_BEGIN_ALLOW_THREADS
        result = mr_edits_init(&s);
        Py_END_ALLOW_THREADS
    } else {
        const int64_t m = dim(edits, 0), *e = edits->buf;
        if (dim(edits, 1) != 3 || dim(acc, 0) != m || (leads && dim(leads, 0) != m)
            || (starts && (dim(starts, 0) != m || dim(scales, 0) != m)))
            return fail(&bs, "edits: edits must be (m, 3), accepted, leads, starts and scales (m,)");
        const int64_t *st = starts ? starts->buf : NULL;
        int64_t total = 0;
        for (int64_t k = 0; k < m; k++) {
            if (e[3 * k] < 0 || e[3 * k] >= s.D || e[3 * k + 1] < 0 || e[3 * k + 2] < 0 || e[3 * k + 2] > s.F
                || e[3 * k + 1] > s.F - e[3 * k + 2])
                return fail(&bs, "edits: an edit outside the features");
            if (st && (st[k] < 0 || st[k] > dim(deltas, 0) - e[3 * k + 2]))
                return fail(&bs, "edits: an edit's values outside deltas");
            total += e[3 * k + 2];
        }
        if (!st && dim(deltas, 0) != total)
            return fail(&bs, "edits: deltas must hold every edit's values");
        Py_BEGIN_ALLOW_THREADS
        result = mr_edits_apply(&s, e, m, deltas->buf, bound, commit, acc->buf, leads ? leads->buf : NULL, st,
                                scales ? scales->buf : NULL);
        Py_END_ALLOW_THREADS
    }
    release(&bs);
    if (result < 0)
        return PyErr_NoMemory();
    return PyLong_FromLongLong(result);
}

/* ------------------------------------------------------------------------------------------------------------ */
/* every value of an int64 buffer in [low, high) */
static int within(const Py_buffer *b, int64_t low, int64_t high)
{
    const int64_t *v = b->buf;
    for (Py_ssize_t k = 0; k < b->len / 8; k++)
        if (v[k] < low || v[k] >= high)
            return 0;
    return 1;
}

PyDoc_STRVAR(chain_pose_doc, "chain_pose(decoded, kinds, rcols, joints, parents, tcols, tvals, rot, pos, frames=None) "
                             "-> bad\n--\n\n"
                             "One depth's joints posed (motionrep.pipeline.chain): decoded (F, D), kinds (n,) int64 "
                             "(0: a quaternion in\nrcols[i], 1: a rotation vector in its first 3, -1: the identity), "
                             "rcols (n, 4) int64, joints, parents (n,) int64\n(-1: the root depth), tcols (n, 3) int64 "
                             "(-1: tvals), tvals (n, 3); rot (J, F, 4) and pos (J, F, 3) written in place.\nWith frames "
                             "(m,) int64 (distinct frames), only those frames.  Returns the number of quaternions of "
                             "zero or\nnon-finite length.");

static PyObject *py_chain_pose(PyObject *self, PyObject *args)
{
    PyObject *o[10];
    o[9] = Py_None;
    if (!PyArg_ParseTuple(args, "OOOOOOOOO|O", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8], &o[9]))
        return NULL;
    buffers bs = {.n = 0};
    Py_buffer *x, *kinds, *rcols, *js, *par, *tc, *tv, *rot, *pos, *fr = NULL;
    if (!(x = get(&bs, o[0], "decoded", 'd', 2, 0)) || !(kinds = get(&bs, o[1], "kinds", 'q', 1, 0))
        || !(rcols = get(&bs, o[2], "rcols", 'q', 2, 0)) || !(js = get(&bs, o[3], "joints", 'q', 1, 0))
        || !(par = get(&bs, o[4], "parents", 'q', 1, 0)) || !(tc = get(&bs, o[5], "tcols", 'q', 2, 0))
        || !(tv = get(&bs, o[6], "tvals", 'd', 2, 0)) || !(rot = get(&bs, o[7], "rot", 'd', 3, 1))
        || !(pos = get(&bs, o[8], "pos", 'd', 3, 1))
        || (o[9] != Py_None && !(fr = get(&bs, o[9], "frames", 'q', 1, 0)))) {
        release(&bs);
        return NULL;
    }
    mr_chain_pose_args a = {.F = dim(x, 0), .D = dim(x, 1), .n = dim(js, 0), .m = fr ? dim(fr, 0) : dim(x, 0),
                            .decoded = x->buf, .tvals = tv->buf, .kinds = kinds->buf, .rcols = rcols->buf,
                            .joints = js->buf, .parents = par->buf, .tcols = tc->buf, .frames = fr ? fr->buf : NULL,
                            .rot = rot->buf, .pos = pos->buf};
    int64_t J = dim(rot, 0);
    if ((fr && !within(fr, 0, a.F)) || dim(kinds, 0) != a.n || dim(rcols, 0) != a.n || dim(rcols, 1) != 4
        || dim(par, 0) != a.n || dim(tc, 0) != a.n || dim(tc, 1) != 3 || dim(tv, 0) != a.n || dim(tv, 1) != 3
        || dim(rot, 1) != a.F || dim(rot, 2) != 4 || dim(pos, 0) != J || dim(pos, 1) != a.F || dim(pos, 2) != 3
        || !within(js, 0, J) || !within(par, -1, J) || !within(tc, -1, a.D) || !within(kinds, -1, 2))
        return fail(&bs, "chain_pose: shapes or indices out of range");
    const int64_t *k = kinds->buf, *c = rcols->buf;
    for (int64_t i = 0; i < a.n; i++)
        for (int w = 0; w < (k[i] == 0 ? 4 : k[i] == 1 ? 3 : 0); w++)
            if (c[4 * i + w] < 0 || c[4 * i + w] >= a.D)
                return fail(&bs, "chain_pose: rcols outside decoded's columns");
    int64_t bad;
    Py_BEGIN_ALLOW_THREADS
    bad = mr_chain_pose(&a);
    Py_END_ALLOW_THREADS
    release(&bs);
    return PyLong_FromLongLong(bad);
}

PyDoc_STRVAR(chain_targets_doc,
             "chain_targets(rot, pos, parents, true_rot, lever, local_offset, true_pos, lever_vec, lever_len, kind, "
             "at, truth, out, frames=None) -> index\n--\n\n"
             "One depth's closed-loop targets (motionrep.pipeline.chain) into out (F, C): rot (J, F, 4), pos (J, F, "
             "3), parents,\nlever, kind (n,) int64, true_rot, truth (n, F, 4), local_offset, true_pos, lever_vec (M, "
             "F, 3), lever_len (M, F), at (n, 4)\nint64: -1, or i F + f of a zero-length rotation (out incomplete). With "
             "frames (m,) int64, only those frames of out.");

static PyObject *py_chain_targets(PyObject *self, PyObject *args)
{
    PyObject *o[14];
    o[13] = Py_None;
    if (!PyArg_ParseTuple(args, "OOOOOOOOOOOOO|O", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8],
                          &o[9], &o[10], &o[11], &o[12], &o[13]))
        return NULL;
    buffers bs = {.n = 0};
    Py_buffer *rot, *pos, *par, *trot, *lev, *loff, *tpos, *lvec, *llen, *kind, *at, *truth, *out, *fr = NULL;
    if (!(rot = get(&bs, o[0], "rot", 'd', 3, 0)) || !(pos = get(&bs, o[1], "pos", 'd', 3, 0))
        || !(par = get(&bs, o[2], "parents", 'q', 1, 0)) || !(trot = get(&bs, o[3], "true_rot", 'd', 3, 0))
        || !(lev = get(&bs, o[4], "lever", 'q', 1, 0)) || !(loff = get(&bs, o[5], "local_offset", 'd', 3, 0))
        || !(tpos = get(&bs, o[6], "true_pos", 'd', 3, 0)) || !(lvec = get(&bs, o[7], "lever_vec", 'd', 3, 0))
        || !(llen = get(&bs, o[8], "lever_len", 'd', 2, 0)) || !(kind = get(&bs, o[9], "kind", 'q', 1, 0))
        || !(at = get(&bs, o[10], "at", 'q', 2, 0)) || !(truth = get(&bs, o[11], "truth", 'd', 3, 0))
        || !(out = get(&bs, o[12], "out", 'd', 2, 1))
        || (o[13] != Py_None && !(fr = get(&bs, o[13], "frames", 'q', 1, 0)))) {
        release(&bs);
        return NULL;
    }
    mr_chain_targets_args a = {.F = dim(out, 0), .n = dim(par, 0), .C = dim(out, 1), .rot = rot->buf,
                               .pos = pos->buf, .true_rot = trot->buf, .local_offset = loff->buf, .true_pos = tpos->buf,
                               .lever_vec = lvec->buf, .lever_len = llen->buf, .truth = truth->buf,
                               .parents = par->buf, .lever = lev->buf, .kind = kind->buf, .at = at->buf,
                               .out = out->buf, .m = fr ? dim(fr, 0) : dim(out, 0), .frames = fr ? fr->buf : NULL};
    int64_t J = dim(rot, 0), M = dim(loff, 0), F = a.F, n = a.n;
    int shapes = dim(rot, 1) == F && dim(rot, 2) == 4 && dim(pos, 0) == J && dim(pos, 1) == F && dim(pos, 2) == 3
                 && dim(trot, 0) == n && dim(trot, 1) == F && dim(trot, 2) == 4 && dim(lev, 0) == n
                 && dim(loff, 1) == F && dim(loff, 2) == 3 && dim(tpos, 0) == M && dim(tpos, 1) == F
                 && dim(tpos, 2) == 3 && dim(lvec, 0) == M && dim(lvec, 1) == F && dim(lvec, 2) == 3
                 && dim(llen, 0) == M && dim(llen, 1) == F && dim(kind, 0) == n && dim(at, 0) == n && dim(at, 1) == 4
                 && dim(truth, 0) == n && dim(truth, 1) == F && dim(truth, 2) == 4;
    if (!shapes || (fr && !within(fr, 0, F)) || !within(par, 0, J) || !within(lev, -1, M) || !within(kind, 0, 2))
        return fail(&bs, "chain_targets: shapes or indices out of range");
    const int64_t *k = kind->buf, *c = at->buf;
    for (int64_t i = 0; i < n; i++)
        for (int w = 0; w < 4; w++)
            if (c[4 * i + w] < (w == 3 && k[i] ? -1 : 0) || c[4 * i + w] >= a.C)
                return fail(&bs, "chain_targets: at outside out's columns");
    int64_t result;
    Py_BEGIN_ALLOW_THREADS
    result = mr_chain_targets(&a);
    Py_END_ALLOW_THREADS
    release(&bs);
    return PyLong_FromLongLong(result);
}

static PyMethodDef methods[] = {
    {"scan", py_scan, METH_VARARGS, scan_doc},
    {"format_shortest", py_format_shortest, METH_VARARGS, format_doc},
    {"fk", py_fk, METH_VARARGS, fk_doc},
    {"max_distances", py_max_distances, METH_VARARGS, distances_doc},
    {"columns_to_quat", py_columns_to_quat, METH_VARARGS, columns_doc},
    {"axis_angle_continuous", py_axis_angle_continuous, METH_VARARGS, continuous_doc},
    {"quat_to_axis_angle", py_quat_to_axis_angle, METH_VARARGS, rotvec_doc},
    {"quat_to_euler", py_quat_to_euler, METH_VARARGS, euler_doc},
    {"sincos", py_sincos, METH_O, sincos_doc},
    {"edits", py_edits, METH_VARARGS, edits_doc},
    {"chain_pose", py_chain_pose, METH_VARARGS, chain_pose_doc},
    {"chain_targets", py_chain_targets, METH_VARARGS, chain_targets_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "motionrep._ccore",
    "motionrep's compiled core (C, built at install time): the BVH number scan and writer, forward kinematics,\n"
    "rotation conversions.  Private: called by motionrep.io and motionrep.model, which check the arguments.",
    -1, methods,
};

int mr_simd = MR_SIMD_BASELINE;

PyMODINIT_FUNC PyInit__ccore(void)
{
#if MR_HAVE_AVX2
    __builtin_cpu_init();
    const char *baseline = getenv("MOTIONREP_CCORE_BASELINE");
    if (__builtin_cpu_supports("avx2") && !(baseline && *baseline && *baseline != '0'))
        mr_simd = MR_SIMD_AVX2;
#endif
    PyObject *m = PyModule_Create(&module);
    if (m && PyModule_AddStringConstant(m, "simd", mr_simd == MR_SIMD_AVX2 ? "avx2" : "baseline") < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
