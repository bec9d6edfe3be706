/* motionrep._cplan: the pose plan (plan.c) and the runtime decoder's loop, for Python.
 *
 *   Plan(plan_i, plan_f)                       a packed PosePlan, checked once
 *   Plan.run(X, count, check_finite, rot, root, moved) -> status
 *   Runtime(plan, sampler, width, block, pose=None, constant=None)   a clip opened for sampling: the codec's C
 *                                              sampler (a capsule, see motionrep/sampler.h), the plan or None, the
 *                                              class of a pose, the features constant over the clip (NaN: not)
 *   Runtime.poses(u, rot, root, moved[, per_second]) -> status   every block of times, codec then plan, without
 *                                              Python (with per_second: u in seconds, normalised block by block)
 *   Runtime.pose_new(t, per_second, f32, P) -> arrays or status    one time in seconds, checked and clamped here,
 *                                                                    into fresh numpy arrays
 *   Runtime.features(u, X) -> status                 the codec alone into a feature-major X (D, >= T)
 *
 * A status is 0, a plan status (1 features not finite, 2 a zero quaternion, 3 a degenerate 6D encoding) or 100 +
 * the sampler's own non-zero code.  Arrays travel through the buffer protocol; shapes are checked here, so no call
 * reads or writes out of bounds whatever Python passes. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <math.h>
#include <stdlib.h>

#include "motionrep/mrkernels.h"
#include "motionrep/pybuf.h"
#include "motionrep/sampler.h"
#include "plan.h"

/* ---- Plan ------------------------------------------------------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    mr_plan plan;
    Py_buffer bi, bf;
    double *scratch;
    int64_t *checked;  /* plan.checked */
} PlanObject;

/* The columns the entries of `p` (less those marked in `skip`, if any) and its translations read, each once, in
 * order: the list mr_plan_run's finiteness check goes through (malloc'ed; NULL when out of memory). */
static int64_t *read_columns(const mr_plan *p, const unsigned char *skip, int64_t *count)
{
    int64_t top = 0;
    for (int64_t k = 0; k < 6 * p->R; k++)
        top = p->cols[k] + 1 > top ? p->cols[k] + 1 : top;
    for (int64_t k = 0; k < 3 * p->N; k++)
        top = p->tcols[k] + 1 > top ? p->tcols[k] + 1 : top;
    unsigned char *mark = calloc((size_t)(top ? top : 1), 1);
    int64_t *out = malloc((size_t)(top ? top : 1) * sizeof(int64_t)), n = 0;
    if (!mark || !out) {
        free(mark);
        free(out);
        return NULL;
    }
    for (int64_t k = 0; k < 6 * p->R; k++)
        if (p->cols[k] >= 0 && !(skip && skip[k / 6]))
            mark[p->cols[k]] = 1;
    for (int64_t k = 0; k < 3 * p->N; k++)
        if (p->tcols[k] >= 0)
            mark[p->tcols[k]] = 1;
    for (int64_t c = 0; c < top; c++)
        if (mark[c])
            out[n++] = c;
    free(mark);
    *count = n;
    return out;
}

static void Plan_dealloc(PlanObject *self)
{
    if (self->bi.obj)
        PyBuffer_Release(&self->bi);
    if (self->bf.obj)
        PyBuffer_Release(&self->bf);
    free(self->scratch);
    free(self->checked);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int Plan_init(PlanObject *self, PyObject *args, PyObject *kw)
{
    PyObject *oi, *of;
    static char *names[] = {"plan_i", "plan_f", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OO", names, &oi, &of))
        return -1;
    if (self->bi.obj) {
        PyErr_SetString(PyExc_TypeError, "Plan is initialised once");
        return -1;
    }
    Py_ssize_t any[1] = {-1};
    if (mr_get_buffer(oi, &self->bi, 'q', 1, any, 0, "plan_i") < 0)
        return -1;
    if (mr_get_buffer(of, &self->bf, 'd', 1, any, 0, "plan_f") < 0) {
        PyBuffer_Release(&self->bi);
        return -1;
    }
    if (mr_plan_parse(self->bi.buf, (size_t)self->bi.shape[0], self->bf.buf, (size_t)self->bf.shape[0],
                      &self->plan) < 0) {
        PyErr_SetString(PyExc_ValueError, "the packed pose plan does not hold together");
        return -1;
    }
    size_t n = mr_plan_scratch(&self->plan);
    if ((n && !(self->scratch = malloc(n * sizeof(double))))
        || !(self->checked = read_columns(&self->plan, NULL, &self->plan.nchecked))) {
        PyErr_NoMemory();
        return -1;
    }
    self->plan.checked = self->checked;
    return 0;
}

/* the outputs of `count` poses of `plan`: rotations (float32 or float64), root and moved translations */
typedef struct {
    Py_buffer rot, root, moved;
    int f32;
} Outputs;

static void release_outputs(Outputs *o)
{
    if (o->rot.obj)
        PyBuffer_Release(&o->rot);
    if (o->root.obj)
        PyBuffer_Release(&o->root);
    if (o->moved.obj)
        PyBuffer_Release(&o->moved);
}

static int get_outputs(const mr_plan *p, Py_ssize_t count, PyObject *rot, PyObject *root, PyObject *moved,
                       Outputs *o)
{
    memset(o, 0, sizeof *o);
    Py_ssize_t srot[3] = {count, (Py_ssize_t)p->J, 4};
    if (PyObject_GetBuffer(rot, &o->rot, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) < 0) {
        PyErr_Clear();
        PyErr_SetString(PyExc_ValueError, "rotations must be a C-contiguous writable array");
        return -1;
    }
    o->f32 = mr_format_is(&o->rot, 'f');
    int ok = (o->f32 || mr_format_is(&o->rot, 'd')) && o->rot.ndim == 3;
    for (int k = 0; ok && k < 3; k++)
        ok = o->rot.shape[k] == srot[k];
    if (!ok) {
        release_outputs(o);
        PyErr_Format(PyExc_ValueError, "rotations must be float32 or float64 of shape (%zd, %zd, 4)", count,
                     (Py_ssize_t)p->J);
        return -1;
    }
    if (p->N > 0) {
        Py_ssize_t sroot[2] = {count, 3}, smoved[3] = {count, (Py_ssize_t)p->N - 1, 3};
        if (mr_get_buffer(root, &o->root, 'd', 2, sroot, 1, "root_translation") < 0
            || mr_get_buffer(moved, &o->moved, 'd', 3, smoved, 1, "joint_translations") < 0) {
            release_outputs(o);
            return -1;
        }
    }
    return 0;
}

static PyObject *Plan_run(PlanObject *self, PyObject *args)
{
    PyObject *ox, *rot, *root, *moved;
    Py_ssize_t count;
    int check_finite;
    if (!PyArg_ParseTuple(args, "OnpOOO", &ox, &count, &check_finite, &rot, &root, &moved))
        return NULL;
    const mr_plan *p = &self->plan;
    Py_buffer bx;
    Py_ssize_t any2[2] = {-1, -1};
    if (count < 0) {
        PyErr_SetString(PyExc_ValueError, "count must be >= 0");
        return NULL;
    }
    if (mr_get_buffer(ox, &bx, 'd', 2, any2, 0, "features") < 0)
        return NULL;
    if (bx.shape[0] < p->rows || bx.shape[1] < count) {
        PyBuffer_Release(&bx);
        PyErr_Format(PyExc_ValueError, "features must have shape (>= %zd, >= %zd)", (Py_ssize_t)p->rows, count);
        return NULL;
    }
    Outputs o;
    if (get_outputs(p, count, rot, root, moved, &o) < 0) {
        PyBuffer_Release(&bx);
        return NULL;
    }
    int status;
    mr_stream sm = {0};
    if (count >= MR_PLAN_STREAM && !o.f32 && !(sm.stage = malloc(sizeof(double) * 2 * MR_PLAN_SUB * 4 * (size_t)p->J))) {
        release_outputs(&o);
        PyBuffer_Release(&bx);
        return PyErr_NoMemory();
    }
    Py_BEGIN_ALLOW_THREADS
    status = mr_plan_run(p, bx.buf, bx.shape[1], count, check_finite, o.rot.buf, o.f32, o.root.buf, o.moved.buf,
                         self->scratch, sm.stage ? &sm : NULL);
    if (sm.stage)
        mr_plan_flush(&sm);
    Py_END_ALLOW_THREADS
    free(sm.stage);
    release_outputs(&o);
    PyBuffer_Release(&bx);
    return PyLong_FromLong(status);
}

static PyMethodDef Plan_methods[] = {
    {"run", (PyCFunction)Plan_run, METH_VARARGS,
     "run(X, count, check_finite, rot, root, moved) -> status: the plan over the first count columns of the "
     "feature-major float64 X (D, >= count)."},
    {NULL, NULL, 0, NULL}};

static PyTypeObject PlanType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "motionrep._cplan.Plan",
    .tp_basicsize = sizeof(PlanObject),
    .tp_dealloc = (destructor)Plan_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Plan(plan_i, plan_f): a packed pose plan (motionrep.model.poseplan.PosePlan.packed), checked once.",
    .tp_methods = Plan_methods,
    .tp_init = (initproc)Plan_init,
    .tp_new = PyType_GenericNew,
};

/* ---- Runtime --------------------------------------------------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    PlanObject *plan;       /* or NULL: the codec alone (features) */
    mr_plan run;            /* the plan as this clip runs it: with its constant entries (mr_plan.isconst) */
    unsigned char *isconst;
    double *constq;
    int64_t *checked;       /* run.checked: the plan's columns less those of its constant entries */
    PyObject *capsule;      /* keeps the sampler's owner alive */
    const mr_sampler *sampler;
    Py_ssize_t width, block;
    double *X;              /* one block's features, feature-major (width, block) */
    double *U;              /* one block's normalised times (Runtime.poses with per_second) */
    double *stage;          /* two sub-blocks' rotations, streamed out for large batches (mr_stream) */
    PyTypeObject *pose;     /* or NULL: the class pose_new makes (its three fields set as object.__setattr__ does) */
} RuntimeObject;

static void Runtime_dealloc(RuntimeObject *self)
{
    Py_XDECREF(self->plan);
    Py_XDECREF(self->capsule);
    Py_XDECREF(self->pose);
    free(self->X);
    free(self->U);
    free(self->isconst);
    free(self->constq);
    free(self->checked);
    free(self->stage);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* The entries of the plan whose columns are all constant over the clip (constant[c] finite; NaN: not constant),
 * and their quaternions: those entries alone run on the constants as one pose (the same conversions, so the values
 * every pose would get, since a feature the codec reports constant samples to that value at every time).  Nothing
 * is marked when one of them is no valid rotation (a zero quaternion, a degenerate 6D encoding: the status every
 * batch must then report) or for world plans.  0, or -1 with an exception set. */
static int constant_entries(RuntimeObject *self, const double *constant, Py_ssize_t width)
{
    static const int widths[7] = {4, 3, 3, 3, 6, 4, 0};
    const mr_plan *p = &self->plan->plan;
    if (p->world || p->R == 0)
        return 0;
    size_t R = (size_t)p->R, J = (size_t)(p->J ? p->J : 1);
    double *X1 = malloc(((size_t)width ? (size_t)width : 1) * sizeof(double)), *rot = malloc(J * 4 * sizeof(double));
    int64_t *part = malloc(R * (1 + 6 + 3 + 1) * sizeof(int64_t));  /* the constant entries: kinds, cols, axes, joints */
    self->isconst = calloc(R, 1);
    self->constq = calloc(R * 4, sizeof(double));
    int ok = X1 && rot && part && self->isconst && self->constq;
    if (ok) {
        for (Py_ssize_t d = 0; d < width; d++)
            X1[d] = fabs(constant[d]) < INFINITY ? constant[d] : 0.0;
        mr_plan sub = *p;  /* the constant entries alone, no translations */
        int64_t *kinds = part, *cols = part + R, *axes = cols + 6 * R, *joints = axes + 3 * R, n = 0;
        for (size_t r = 0; r < R; r++) {
            int64_t kind = p->kinds[r];
            int all = kind != MR_WORLD_QUAT && kind != MR_WORLD_IDENTITY;
            for (int k = 0; all && k < widths[kind]; k++) {
                int64_t c = p->cols[6 * r + k];
                all = c < 0 ? (kind == MR_EULER || kind == MR_EULER_DEGREES) : fabs(constant[c]) < INFINITY;
            }
            self->isconst[r] = (unsigned char)all;
            if (!all)
                continue;
            kinds[n] = kind;
            joints[n] = p->joints[r];
            memcpy(cols + 6 * n, p->cols + 6 * r, 6 * sizeof(int64_t));
            memcpy(axes + 3 * n, p->axes + 3 * r, 3 * sizeof(int64_t));
            n++;
        }
        sub.R = n;
        sub.N = sub.M = 0;
        sub.kinds = kinds;
        sub.cols = cols;
        sub.axes = axes;
        sub.joints = joints;
        if (n && mr_plan_run(&sub, X1, 1, 1, 0, rot, 0, NULL, NULL, NULL, NULL) == MR_PLAN_OK) {
            for (size_t r = 0; r < R; r++)
                if (self->isconst[r])
                    memcpy(self->constq + 4 * r, rot + 4 * p->joints[r], 4 * sizeof(double));
            self->run.isconst = self->isconst;
            self->run.constq = self->constq;
            ok = (self->checked = read_columns(p, self->isconst, &self->run.nchecked)) != NULL;
            self->run.checked = self->checked;
        }
    }
    free(X1);
    free(rot);
    free(part);
    if (!ok) {
        PyErr_NoMemory();
        return -1;
    }
    return 0;
}

static int Runtime_init(RuntimeObject *self, PyObject *args, PyObject *kw)
{
    PyObject *plan, *capsule, *pose = Py_None, *oconst = Py_None;
    Py_ssize_t width, block;
    static char *names[] = {"plan", "sampler", "width", "block", "pose", "constant", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OOnn|OO", names, &plan, &capsule, &width, &block, &pose, &oconst))
        return -1;
    if (pose != Py_None && !PyType_Check(pose)) {
        PyErr_SetString(PyExc_TypeError, "pose must be a class or None");
        return -1;
    }
    if (self->capsule) {
        PyErr_SetString(PyExc_TypeError, "Runtime is initialised once");
        return -1;
    }
    if (plan != Py_None && !PyObject_TypeCheck(plan, &PlanType)) {
        PyErr_SetString(PyExc_TypeError, "plan must be a motionrep._cplan.Plan or None");
        return -1;
    }
    const mr_sampler *s = PyCapsule_GetPointer(capsule, MR_SAMPLER_CAPSULE);
    if (!s)
        return -1;
    if (s->abi != MR_SAMPLER_ABI || (Py_ssize_t)s->width != width || width < 0 || block < 1 || block > (1 << 20)) {
        PyErr_SetString(PyExc_ValueError, "the sampler does not fit (ABI, width or block size)");
        return -1;
    }
    if (s->block > (size_t)block && s->block <= (1 << 20))  /* the codec prefers larger blocks */
        block = (Py_ssize_t)s->block;
    if (plan != Py_None && ((PlanObject *)plan)->plan.rows > width) {
        PyErr_SetString(PyExc_ValueError, "the plan reads more features than the codec decodes");
        return -1;
    }
    if (!(self->X = malloc(((size_t)width ? (size_t)width : 1) * (size_t)block * sizeof(double)))
        || !(self->U = malloc((size_t)block * sizeof(double)))) {
        PyErr_NoMemory();
        return -1;
    }
    self->sampler = s;
    self->width = width;
    if (pose != Py_None) {
        Py_INCREF(pose);
        self->pose = (PyTypeObject *)pose;
    }
    self->block = block;
    Py_INCREF(capsule);
    self->capsule = capsule;
    if (plan != Py_None) {
        Py_INCREF(plan);
        self->plan = (PlanObject *)plan;
        self->run = self->plan->plan;
        if (oconst != Py_None) {
            Py_buffer bc;
            Py_ssize_t sc[1] = {width};
            if (mr_get_buffer(oconst, &bc, 'd', 1, sc, 0, "constant") < 0)
                return -1;
            int e = constant_entries(self, bc.buf, width);
            PyBuffer_Release(&bc);
            if (e < 0)
                return -1;
        }
        if (!(self->stage = malloc(sizeof(double) * 2 * MR_PLAN_SUB * 4 * (size_t)(self->plan->plan.J ? self->plan->plan.J : 1)))) {
            PyErr_NoMemory();
            return -1;
        }
    }
    return 0;
}

/* every block of the `count` times u: the codec into X, then the plan into the outputs (rotations float32 or
 * float64, root and moved translations).  With per_second >= 0, u holds finite seconds, each block's made the
 * normalised times numpy.clip(t * per_second, 0.0, 1.0) gives (the same values, without arrays of them all). */
static int run_blocks(RuntimeObject *self, const double *u, Py_ssize_t count, void *rot, int f32, double *root,
                      double *moved, double per_second)
{
    const mr_plan *p = &self->run;
    const mr_sampler *s = self->sampler;
    size_t rstride = (size_t)p->J * 4 * (f32 ? sizeof(float) : sizeof(double));
    mr_stream sm = {self->stage, 0, NULL, NULL, 0, 0}, *stream = count >= MR_PLAN_STREAM ? &sm : NULL;
    int status = 0;
    for (Py_ssize_t a = 0; a < count && !status; a += self->block) {
        Py_ssize_t m = count - a < self->block ? count - a : self->block;
        const double *times = u + a;
        if (per_second >= 0.0) {
            for (Py_ssize_t i = 0; i < m; i++) {
                double v = u[a + i] * per_second;
                v = v > 0.0 ? v : 0.0;  /* numpy's clip: its maximum then minimum (-0.0 becomes 0.0) */
                self->U[i] = v < 1.0 ? v : 1.0;
            }
            times = self->U;
        }
        int e = s->sample(s->state, times, (size_t)m, self->X, (size_t)self->block);
        status = e ? 100 + e
                   : mr_plan_run(p, self->X, self->block, m, 1, (char *)rot + a * rstride, f32,
                                 p->N > 0 ? root + 3 * a : NULL, p->N > 1 ? moved + 3 * (p->N - 1) * a : NULL,
                                 self->plan->scratch, stream);
    }
    if (stream)  /* the last rows waiting (an error: written all the same, as every status writes everything) */
        mr_plan_flush(stream);
    return status;
}

static PyObject *Runtime_poses(RuntimeObject *self, PyObject *args)
{
    PyObject *ou, *rot, *root, *moved;
    double per_second = -1.0;  /* none: u are normalised times */
    PyObject *ops = Py_None;
    if (!PyArg_ParseTuple(args, "OOOO|O", &ou, &rot, &root, &moved, &ops))
        return NULL;
    if (ops != Py_None) {
        per_second = PyFloat_AsDouble(ops);
        if (per_second == -1.0 && PyErr_Occurred())
            return NULL;
        if (!(per_second >= 0.0 && per_second < INFINITY)) {
            PyErr_SetString(PyExc_ValueError, "per_second must be finite and >= 0");
            return NULL;
        }
    }
    if (!self->plan) {
        PyErr_SetString(PyExc_TypeError, "this Runtime has no plan");
        return NULL;
    }
    Py_buffer bu;
    Py_ssize_t any[1] = {-1};
    if (mr_get_buffer(ou, &bu, 'd', 1, any, 0, "times") < 0)
        return NULL;
    Outputs o;
    if (get_outputs(&self->plan->plan, bu.shape[0], rot, root, moved, &o) < 0) {
        PyBuffer_Release(&bu);
        return NULL;
    }
    int status;
    if (bu.shape[0] > 16) {
        Py_BEGIN_ALLOW_THREADS
        status = run_blocks(self, bu.buf, bu.shape[0], o.rot.buf, o.f32, o.root.buf, o.moved.buf, per_second);
        Py_END_ALLOW_THREADS
    } else {
        status = run_blocks(self, bu.buf, bu.shape[0], o.rot.buf, o.f32, o.root.buf, o.moved.buf, per_second);
    }
    release_outputs(&o);
    PyBuffer_Release(&bu);
    return PyLong_FromLong(status);
}

/* the fields of the pose class, interned at import */
static PyObject *FIELDS[3];

/* pose_new(t, per_second, f32, P) -> (rotations, root_translation, joint_translations) or a status: the pose at t
 * seconds (a number; t * per_second clamped to [0, 1]) in fresh numpy arrays, (J, 4) float32 or float64, (3,),
 * (P, 3); status 201: t is not a number, 202: not finite (t * per_second), else a run_blocks status */
static PyObject *Runtime_pose_new(RuntimeObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "pose_new(t, per_second, f32, P)");
        return NULL;
    }
    if (!self->plan) {
        PyErr_SetString(PyExc_TypeError, "this Runtime has no plan");
        return NULL;
    }
    const mr_plan *p = &self->plan->plan;
    double t = PyFloat_AsDouble(args[0]);
    if (t == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        return PyLong_FromLong(201);
    }
    double per_second = PyFloat_AsDouble(args[1]);
    int f32 = PyObject_IsTrue(args[2]);
    Py_ssize_t P = PyLong_AsSsize_t(args[3]);
    if ((per_second == -1.0 || P == -1) && PyErr_Occurred())
        return NULL;
    if (f32 < 0 || P < 0 || (p->N > 0 && P != p->N - 1)) {
        PyErr_SetString(PyExc_ValueError, "pose_new: P must be the plan's translated joints");
        return NULL;
    }
    double u = t * per_second;
    if (!(fabs(u) < INFINITY))
        return PyLong_FromLong(202);
    u = MR_PYMIN(MR_PYMAX(u, 0.0), 1.0);
    npy_intp drot[2] = {(npy_intp)p->J, 4}, droot[1] = {3}, dmoved[2] = {(npy_intp)P, 3};
    PyObject *rot = PyArray_SimpleNew(2, drot, f32 ? NPY_FLOAT32 : NPY_FLOAT64);
    PyObject *root = p->N > 0 ? PyArray_SimpleNew(1, droot, NPY_FLOAT64) : PyArray_ZEROS(1, droot, NPY_FLOAT64, 0);
    PyObject *moved = p->N > 1 ? PyArray_SimpleNew(2, dmoved, NPY_FLOAT64) : PyArray_ZEROS(2, dmoved, NPY_FLOAT64, 0);
    PyObject *out = rot && root && moved ? PyTuple_New(3) : NULL;
    if (!out) {
        Py_XDECREF(rot);
        Py_XDECREF(root);
        Py_XDECREF(moved);
        return NULL;
    }
    PyTuple_SET_ITEM(out, 0, rot);
    PyTuple_SET_ITEM(out, 1, root);
    PyTuple_SET_ITEM(out, 2, moved);
    int status = run_blocks(self, &u, 1, PyArray_DATA((PyArrayObject *)rot), f32,
                            PyArray_DATA((PyArrayObject *)root), PyArray_DATA((PyArrayObject *)moved), -1.0);
    if (status) {
        Py_DECREF(out);
        return PyLong_FromLong(status);
    }
    if (!self->pose)
        return out;
    PyObject *pose = self->pose->tp_alloc(self->pose, 0);  /* as object.__new__(Pose) and object.__setattr__ */
    int bad = !pose;
    for (int k = 0; k < 3 && !bad; k++)
        bad = PyObject_GenericSetAttr(pose, FIELDS[k], PyTuple_GET_ITEM(out, k)) < 0;
    Py_DECREF(out);
    if (bad) {
        Py_XDECREF(pose);
        return NULL;
    }
    return pose;
}

static PyObject *Runtime_features(RuntimeObject *self, PyObject *args)
{
    PyObject *ou, *ox;
    if (!PyArg_ParseTuple(args, "OO", &ou, &ox))
        return NULL;
    Py_buffer bu, bx;
    Py_ssize_t any[1] = {-1}, sx[2] = {self->width, -1};
    if (mr_get_buffer(ou, &bu, 'd', 1, any, 0, "times") < 0)
        return NULL;
    if (mr_get_buffer(ox, &bx, 'd', 2, sx, 1, "out") < 0) {
        PyBuffer_Release(&bu);
        return NULL;
    }
    if (bx.shape[1] < bu.shape[0]) {
        PyBuffer_Release(&bu);
        PyBuffer_Release(&bx);
        PyErr_SetString(PyExc_ValueError, "out has fewer columns than times");
        return NULL;
    }
    int e;
    const mr_sampler *s = self->sampler;
    Py_BEGIN_ALLOW_THREADS
    e = s->sample(s->state, bu.buf, (size_t)bu.shape[0], bx.buf, (size_t)bx.shape[1]);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&bu);
    PyBuffer_Release(&bx);
    return PyLong_FromLong(e ? 100 + e : 0);
}

static PyMethodDef Runtime_methods[] = {
    {"poses", (PyCFunction)Runtime_poses, METH_VARARGS,
     "poses(u, rot, root, moved[, per_second]) -> status: the poses at normalised times u (T,) float64, or, with "
     "per_second (a number >= 0), at u seconds (finite; normalised as numpy.clip(u * per_second, 0.0, 1.0))."},
    {"pose_new", (PyCFunction)(void (*)(void))Runtime_pose_new, METH_FASTCALL,
     "pose_new(t, per_second, f32, P) -> a pose (the Runtime's pose class, else a tuple of its three arrays) or a "
     "status: one pose at t seconds in fresh arrays (201: t is no number, 202: not finite)."},
    {"features", (PyCFunction)Runtime_features, METH_VARARGS,
     "features(u, X) -> status: the codec's features at u (T,) into the feature-major X (D, >= T)."},
    {NULL, NULL, 0, NULL}};

static PyTypeObject RuntimeType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "motionrep._cplan.Runtime",
    .tp_basicsize = sizeof(RuntimeObject),
    .tp_dealloc = (destructor)Runtime_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Runtime(plan, sampler, width, block, pose=None): a codec's C sampler and a pose plan, run block by block.",
    .tp_methods = Runtime_methods,
    .tp_init = (initproc)Runtime_init,
    .tp_new = PyType_GenericNew,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "motionrep._cplan",
    "The pose plan and the runtime decoder's loop in C (motionrep/_c/plan).", -1, NULL};

PyMODINIT_FUNC PyInit__cplan(void)
{
    import_array();
    static const char *fields[3] = {"rotations", "root_translation", "joint_translations"};
    for (int k = 0; k < 3; k++)
        if (!(FIELDS[k] = PyUnicode_InternFromString(fields[k])))
            return NULL;
    if (PyType_Ready(&PlanType) < 0 || PyType_Ready(&RuntimeType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (!m)
        return NULL;
    Py_INCREF(&PlanType);
    Py_INCREF(&RuntimeType);
    if (PyModule_AddObject(m, "Plan", (PyObject *)&PlanType) < 0
        || PyModule_AddObject(m, "Runtime", (PyObject *)&RuntimeType) < 0
        || PyModule_AddIntConstant(m, "SUB_BLOCK", MR_PLAN_SUB) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
