/* ffdkit._ffd.Deformer: libffd's generic deformer (ffd_deformer, ffd.h
 * "Deformers") over numpy arrays. A deformer is not thread-safe: each
 * handle has a lock, held by every call that touches it, and the long calls
 * (create, bind, evaluate, jacobian, solve, command, linear map,
 * sensitivities and their products) release the
 * GIL while they hold it. */
#include "ffdpy.h"

#include <stdlib.h>
#include <string.h>

/* Takes d's lock; while another thread holds it, waits with the GIL released. */
static void enter(ffdpy_Deformer *d)
{
    if (!PyThread_acquire_lock(d->lock, NOWAIT_LOCK)) {
        Py_BEGIN_ALLOW_THREADS
        PyThread_acquire_lock(d->lock, WAIT_LOCK);
        Py_END_ALLOW_THREADS
    }
}

static void leave(ffdpy_Deformer *d) { PyThread_release_lock(d->lock); }

ffdpy_Deformer *ffdpy_deformer_alloc(PyTypeObject *cls)
{
    ffdpy_Deformer *self = (ffdpy_Deformer *)cls->tp_alloc(cls, 0);
    if (!self)
        return NULL;
    self->lock = PyThread_allocate_lock();
    if (!self->lock) {
        Py_DECREF(self);
        PyErr_NoMemory();
        return NULL;
    }
    return self;
}

static PyObject *Deformer_new(PyTypeObject *cls, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"rig", "target", "limits", NULL};
    PyObject *rig_obj, *target, *limits_obj = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O!O|O:Deformer", kw, &ffdpy_RigType, &rig_obj, &target,
                                     &limits_obj))
        return NULL;
    ffd_limits limits;
    int have_limits;
    if (ffdpy_limits(limits_obj, &limits, &have_limits) < 0)
        return NULL;
    const ffd_mesh *mesh;
    ffd_mesh *owned;
    PyObject *keep;
    if (ffdpy_mesh_or_points(target, "points", &mesh, &owned, &keep) < 0)
        return NULL;
    ffdpy_Deformer *self = ffdpy_deformer_alloc(cls);
    if (!self) {
        ffd_mesh_destroy(owned);
        Py_XDECREF(keep);
        return NULL;
    }
    ffd_rig *rig = ((ffdpy_Rig *)rig_obj)->rig;
    Py_INCREF(rig_obj);
    ffd_error err = {{0}};
    ffd_status st;
    ffd_deformer *d = NULL;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_deformer_create(rig, mesh, have_limits ? &limits : NULL, &d, &err);
    ffd_mesh_destroy(owned);
    Py_END_ALLOW_THREADS
    Py_DECREF(rig_obj);
    Py_XDECREF(keep);
    if (st) {
        Py_DECREF(self);
        return ffdpy_raise(st, &err, NULL);
    }
    self->d = d;
    return (PyObject *)self;
}

static int Deformer_traverse(ffdpy_Deformer *self, visitproc visit, void *arg)
{
    Py_VISIT(self->dict);
    return 0;
}

static int Deformer_clear(ffdpy_Deformer *self)
{
    Py_CLEAR(self->dict);
    return 0;
}

static void Deformer_dealloc(ffdpy_Deformer *self)
{
    PyObject_GC_UnTrack(self);
    if (self->weakrefs)
        PyObject_ClearWeakRefs((PyObject *)self);
    Deformer_clear(self);
    ffd_deformer_destroy(self->d);
    if (self->lock)
        PyThread_free_lock(self->lock);
    /* a heap subclass's type reference is released by subtype_dealloc */
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int ready(ffdpy_Deformer *self)
{
    if (!self->d) {
        PyErr_SetString(PyExc_RuntimeError, "the deformer was not created");
        return 0;
    }
    return 1;
}

static PyObject *Deformer_bind(ffdpy_Deformer *self, PyObject *arg)
{
    if (!ready(self))
        return NULL;
    PyArrayObject *p = ffdpy_points(arg, "points");
    if (!p)
        return NULL;
    ffd_error err = {{0}};
    ffd_status st;
    enter(self);
    Py_BEGIN_ALLOW_THREADS
    st = ffd_deformer_bind(self->d, PyArray_DATA(p), (size_t)PyArray_DIM(p, 0), &err);
    Py_END_ALLOW_THREADS
    leave(self);
    Py_DECREF(p);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    Py_RETURN_NONE;
}

/* evaluate (jac 0) or jacobian (jac 1) into out or a new array */
static PyObject *eval_into(ffdpy_Deformer *self, PyObject *args, PyObject *kwds, int jac)
{
    static char *kw[] = {"out", NULL};
    PyObject *out = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, jac ? "|O:jacobian" : "|O:evaluate", kw, &out) ||
        !ready(self))
        return NULL;
    enter(self);
    npy_intp dims[3] = {(npy_intp)ffd_deformer_point_count(self->d), 3, 3};
    int ndim = jac ? 3 : 2;
    if (out != Py_None && ffdpy_check_out(out, ndim, dims) < 0) {
        leave(self);
        return NULL;
    }
    PyObject *result = out != Py_None ? Py_NewRef(out) : PyArray_SimpleNew(ndim, dims, NPY_DOUBLE);
    if (!result) {
        leave(self);
        return NULL;
    }
    double *dst = PyArray_DATA((PyArrayObject *)result);
    ffd_error err = {{0}};
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    st = jac ? ffd_deformer_jacobian(self->d, dst, &err) : ffd_deformer_eval(self->d, dst, &err);
    Py_END_ALLOW_THREADS
    leave(self);
    if (st) {
        Py_DECREF(result);
        return ffdpy_raise(st, &err, NULL);
    }
    return result;
}

static PyObject *Deformer_evaluate(ffdpy_Deformer *self, PyObject *args, PyObject *kwds)
{
    return eval_into(self, args, kwds, 0);
}

static PyObject *Deformer_jacobian(ffdpy_Deformer *self, PyObject *args, PyObject *kwds)
{
    return eval_into(self, args, kwds, 1);
}

static PyObject *Deformer_get_controls(ffdpy_Deformer *self, PyObject *noargs)
{
    if (!ready(self))
        return NULL;
    enter(self);
    npy_intp dims[2] = {(npy_intp)ffd_deformer_control_count(self->d), 3};
    PyObject *a = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (a)
        ffd_deformer_controls(self->d, PyArray_DATA((PyArrayObject *)a));
    leave(self);
    return a;
}

/* set (move 0) or move (move 1) controls ids (None: all) to/by values */
static PyObject *change_controls(ffdpy_Deformer *self, PyObject *args, int move)
{
    PyObject *ids_obj, *values_obj;
    if (!PyArg_ParseTuple(args, move ? "OO:move" : "OO:set_controls", &ids_obj, &values_obj) || !ready(self))
        return NULL;
    const char *vname = move ? "deltas" : "positions";
    PyArrayObject *ids = NULL;
    npy_intp dims[2] = {-1, 3};
    if (ids_obj != Py_None) {
        if (!(ids = ffdpy_ids(ids_obj, "ids")))
            return NULL;
        dims[0] = PyArray_DIM(ids, 0);
    } else {
        dims[0] = (npy_intp)ffd_deformer_control_count(self->d);
    }
    PyArrayObject *v = NULL;
    {
        /* one id with a single (3,) value is accepted as (1, 3) */
        PyArrayObject *raw = (PyArrayObject *)PyArray_FROM_O(values_obj);
        if (raw && PyArray_NDIM(raw) == 1 && dims[0] == 1) {
            npy_intp d1[1] = {3};
            PyArrayObject *one = ffdpy_doubles((PyObject *)raw, vname, 1, d1);
            if (one) {
                PyArray_Dims shape = {dims, 2};
                v = (PyArrayObject *)PyArray_Newshape(one, &shape, NPY_CORDER);
                Py_DECREF(one);
            }
        } else if (raw) {
            v = ffdpy_doubles((PyObject *)raw, vname, 2, dims);
        }
        Py_XDECREF(raw);
    }
    if (!v) {
        Py_XDECREF(ids);
        return NULL;
    }
    ffd_error err = {{0}};
    enter(self);
    const uint32_t *id = ids ? PyArray_DATA(ids) : NULL;
    size_t k = (size_t)dims[0];
    ffd_status st;
    if (!ids && k != ffd_deformer_control_count(self->d)) {
        st = FFD_ERR_INVALID; /* the count changed in between (another thread's refinement) */
        snprintf(err.message, sizeof err.message, "%s: %zu rows for %zu controls", vname, k,
                 ffd_deformer_control_count(self->d));
    } else {
        st = move ? ffd_deformer_move_controls(self->d, id, k, PyArray_DATA(v), &err)
                  : ffd_deformer_set_controls(self->d, id, k, PyArray_DATA(v), &err);
    }
    leave(self);
    Py_XDECREF(ids);
    Py_DECREF(v);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    Py_RETURN_NONE;
}

static PyObject *Deformer_set_controls(ffdpy_Deformer *self, PyObject *args)
{
    return change_controls(self, args, 0);
}

static PyObject *Deformer_move(ffdpy_Deformer *self, PyObject *args) { return change_controls(self, args, 1); }

static PyObject *Deformer_reset(ffdpy_Deformer *self, PyObject *noargs)
{
    if (!ready(self))
        return NULL;
    ffd_error err = {{0}};
    enter(self);
    ffd_status st = ffd_deformer_reset(self->d, &err);
    leave(self);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    Py_RETURN_NONE;
}

/* report (rig 0) or rig (rig 1) as JSON text */
static PyObject *json_text(ffdpy_Deformer *self, int rig)
{
    if (!ready(self))
        return NULL;
    char *json = NULL;
    size_t size = 0;
    ffd_error err = {{0}};
    enter(self);
    ffd_status st = rig ? ffd_deformer_rig(self->d, &json, &size, &err)
                        : ffd_deformer_report(self->d, &json, &size, &err);
    leave(self);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    PyObject *s = PyUnicode_DecodeUTF8(json, (Py_ssize_t)size, "replace");
    ffd_free(json);
    return s;
}

static PyObject *Deformer_report_json(ffdpy_Deformer *self, PyObject *noargs) { return json_text(self, 0); }
static PyObject *Deformer_rig_json(ffdpy_Deformer *self, PyObject *noargs) { return json_text(self, 1); }

static PyObject *Deformer_command_json(ffdpy_Deformer *self, PyObject *args)
{
    const char *op, *body = NULL;
    Py_ssize_t size = 0;
    if (!PyArg_ParseTuple(args, "s|z#:command", &op, &body, &size) || !ready(self))
        return NULL;
    /* op and body point into args' strings, alive for the whole call */
    ffd_error err = {{0}};
    ffd_status st;
    enter(self);
    Py_BEGIN_ALLOW_THREADS
    st = ffd_deformer_command(self->d, op, body, body ? (size_t)size : 0, &err);
    Py_END_ALLOW_THREADS
    leave(self);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    Py_RETURN_NONE;
}

/* ---------- direct manipulation and the linear map ---------- */

/* Direct manipulation (Hsu et al. 1992, eq. 2-7, ffd_manip_solve) of the
 * bound points rows towards targets: the controls move by dV. Returns
 * (residuals (k,), reached (k, 3), rank, max_residual, variables_used). */
static PyObject *Deformer_solve(ffdpy_Deformer *self, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"points", "targets", "rcond", NULL};
    PyObject *rows_obj, *targets_obj;
    double rcond = 1e-10;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OO|d:solve", kw, &rows_obj, &targets_obj, &rcond) ||
        !ready(self))
        return NULL;
    if (!(rcond >= 0.0 && rcond < 1.0)) {
        PyErr_Format(PyExc_ValueError, "rcond: expected a number in [0, 1), got %g", rcond);
        return NULL;
    }
    PyArrayObject *rows = ffdpy_ids(rows_obj, "points");
    if (!rows)
        return NULL;
    npy_intp k = PyArray_DIM(rows, 0);
    npy_intp tdims[2] = {k, 3};
    PyArrayObject *targets = NULL;
    {
        PyArrayObject *raw = (PyArrayObject *)PyArray_FROM_O(targets_obj);
        if (raw && PyArray_NDIM(raw) == 1 && k == 1) {
            npy_intp d1[1] = {3};
            PyArrayObject *one = ffdpy_doubles((PyObject *)raw, "targets", 1, d1);
            if (one) {
                PyArray_Dims shape = {tdims, 2};
                targets = (PyArrayObject *)PyArray_Newshape(one, &shape, NPY_CORDER);
                Py_DECREF(one);
            }
        } else if (raw) {
            targets = ffdpy_doubles((PyObject *)raw, "targets", 2, tdims);
        }
        Py_XDECREF(raw);
    }
    if (!targets) {
        Py_DECREF(rows);
        return NULL;
    }
    PyObject *residuals = PyArray_SimpleNew(1, tdims, NPY_DOUBLE);
    PyObject *reached = PyArray_SimpleNew(2, tdims, NPY_DOUBLE);
    if (!residuals || !reached) {
        Py_XDECREF(residuals);
        Py_XDECREF(reached);
        Py_DECREF(rows);
        Py_DECREF(targets);
        return NULL;
    }
    const uint32_t *row_ids = PyArray_DATA(rows);
    const double *tgt = PyArray_DATA(targets);
    double *res = PyArray_DATA((PyArrayObject *)residuals);
    double *reach = PyArray_DATA((PyArrayObject *)reached);
    ffd_manip_result mr = {0};
    ffd_error err = {{0}};
    ffd_status st = FFD_OK;
    enter(self);
    Py_BEGIN_ALLOW_THREADS
    ffd_deformer *d = self->d;
    size_t M = ffd_deformer_point_count(d);
    ffd_linear_map map;
    double *all = NULL, *current = NULL, *delta = NULL, *w = NULL;
    size_t *r = NULL;
    uint32_t *cols = NULL;
    for (npy_intp i = 0; i < k && !st; i++) {
        if (row_ids[i] >= M) {
            snprintf(err.message, sizeof err.message, "points[%ld]: point %u out of range (%zu bound points)",
                     (long)i, row_ids[i], M);
            st = FFD_ERR_RANGE;
        }
    }
    if (!st)
        st = ffd_deformer_linear_map(d, &map, &err);
    if (!st) {
        all = malloc((M ? M : 1) * 3 * sizeof *all);
        current = malloc(((size_t)k ? (size_t)k : 1) * 3 * sizeof *current);
        r = malloc(((size_t)k ? (size_t)k : 1) * sizeof *r);
        delta = calloc(map.variable_count ? map.variable_count : 1, 3 * sizeof *delta);
        cols = malloc((map.max_row_nnz ? map.max_row_nnz : 1) * sizeof *cols);
        w = malloc((map.max_row_nnz ? map.max_row_nnz : 1) * sizeof *w);
        if (!all || !current || !r || !delta || !cols || !w) {
            snprintf(err.message, sizeof err.message, "solve: out of memory");
            st = FFD_ERR_NOMEM;
        }
    }
    if (!st)
        st = ffd_deformer_eval(d, all, &err);
    if (!st) {
        for (npy_intp i = 0; i < k; i++) {
            r[i] = row_ids[i];
            memcpy(current + 3 * i, all + 3 * (size_t)row_ids[i], 3 * sizeof(double));
        }
        ffd_manip_options mo = {.rcond = rcond};
        st = ffd_manip_solve(&map, r, (size_t)k, current, tgt, &mo, delta, res, &mr, &err);
    }
    if (!st) {
        /* reached = current + B S dV, from the map before it goes stale */
        for (npy_intp i = 0; i < k; i++) {
            double x[3] = {current[3 * i], current[3 * i + 1], current[3 * i + 2]};
            size_t nnz = map.row(map.self, r[i], cols, w);
            for (size_t e = 0; e < nnz; e++) {
                uint32_t v = map.tie ? map.tie[cols[e]] : cols[e];
                if (v == FFD_TIE_FIXED)
                    continue;
                for (int c = 0; c < 3; c++)
                    x[c] += w[e] * delta[3 * (size_t)v + c];
            }
            memcpy(reach + 3 * i, x, sizeof x);
        }
        /* variable j is control j for a deformer's map (ffd_deformer_linear_map) */
        st = ffd_deformer_move_controls(d, NULL, map.variable_count, delta, &err);
    }
    free(all);
    free(current);
    free(r);
    free(delta);
    free(cols);
    free(w);
    Py_END_ALLOW_THREADS
    leave(self);
    Py_DECREF(rows);
    Py_DECREF(targets);
    if (st) {
        Py_DECREF(residuals);
        Py_DECREF(reached);
        return ffdpy_raise(st, &err, NULL);
    }
    return Py_BuildValue("(NNndn)", residuals, reached, (Py_ssize_t)mr.rank, mr.max_residual,
                         (Py_ssize_t)mr.variables_used);
}

/* The rows of ffd_deformer_linear_map in CSR form with columns mapped
 * through the tie to control ids (fixed slots dropped; duplicates left for
 * the caller to sum): (indptr int64 (M+1,), indices int64, data float64, M, C). */
static PyObject *Deformer_linear_map_csr(ffdpy_Deformer *self, PyObject *noargs)
{
    if (!ready(self))
        return NULL;
    ffd_error err = {{0}};
    ffd_status st;
    ffd_linear_map map;
    enter(self);
    st = ffd_deformer_linear_map(self->d, &map, &err);
    if (st) {
        leave(self);
        return ffdpy_raise(st, &err, NULL);
    }
    size_t M = map.point_count, C = map.variable_count;
    npy_intp np1 = (npy_intp)M + 1;
    PyObject *indptr = PyArray_SimpleNew(1, &np1, NPY_INT64);
    if (!indptr) {
        leave(self);
        return NULL;
    }
    int64_t *ptr = PyArray_DATA((PyArrayObject *)indptr);
    uint32_t *cols = malloc((map.max_row_nnz ? map.max_row_nnz : 1) * sizeof *cols);
    double *w = malloc((map.max_row_nnz ? map.max_row_nnz : 1) * sizeof *w);
    if (!cols || !w) {
        free(cols);
        free(w);
        leave(self);
        Py_DECREF(indptr);
        return PyErr_NoMemory();
    }
    /* pass 1: the entries per row */
    Py_BEGIN_ALLOW_THREADS
    ptr[0] = 0;
    for (size_t i = 0; i < M; i++) {
        size_t nnz = map.row(map.self, i, cols, w), kept = 0;
        for (size_t e = 0; e < nnz; e++)
            kept += !(map.tie && map.tie[cols[e]] == FFD_TIE_FIXED);
        ptr[i + 1] = ptr[i] + (int64_t)kept;
    }
    Py_END_ALLOW_THREADS
    npy_intp nnz_all = (npy_intp)ptr[M];
    PyObject *indices = PyArray_SimpleNew(1, &nnz_all, NPY_INT64);
    PyObject *data = PyArray_SimpleNew(1, &nnz_all, NPY_DOUBLE);
    if (indices && data) {
        int64_t *ind = PyArray_DATA((PyArrayObject *)indices);
        double *val = PyArray_DATA((PyArrayObject *)data);
        Py_BEGIN_ALLOW_THREADS
        for (size_t i = 0; i < M; i++) {
            size_t nnz = map.row(map.self, i, cols, w);
            int64_t at = ptr[i];
            for (size_t e = 0; e < nnz; e++) {
                uint32_t v = map.tie ? map.tie[cols[e]] : cols[e];
                if (v == FFD_TIE_FIXED)
                    continue;
                ind[at] = v;
                val[at] = w[e];
                at++;
            }
        }
        Py_END_ALLOW_THREADS
    }
    leave(self);
    free(cols);
    free(w);
    if (!indices || !data) {
        Py_DECREF(indptr);
        Py_XDECREF(indices);
        Py_XDECREF(data);
        return NULL;
    }
    return Py_BuildValue("(NNNnn)", indptr, indices, data, (Py_ssize_t)M, (Py_ssize_t)C);
}

/* W = dX/dP (ffd_deformer_sensitivities) in CSR form: (indptr int64
 * (M+1,), indices int64, data float64, M, C); the GIL released while the
 * library forms it. */
static PyObject *Deformer_sensitivities_csr(ffdpy_Deformer *self, PyObject *noargs)
{
    if (!ready(self))
        return NULL;
    ffd_error err = {{0}};
    ffd_status st;
    ffd_sparse W = {0};
    enter(self);
    Py_BEGIN_ALLOW_THREADS
    st = ffd_deformer_sensitivities(self->d, &W, &err);
    Py_END_ALLOW_THREADS
    leave(self);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    npy_intp np1 = (npy_intp)W.rows + 1, nnz = (npy_intp)W.nnz;
    PyObject *indptr = PyArray_SimpleNew(1, &np1, NPY_INT64);
    PyObject *indices = PyArray_SimpleNew(1, &nnz, NPY_INT64);
    PyObject *data = PyArray_SimpleNew(1, &nnz, NPY_DOUBLE);
    if (indptr && indices && data) {
        int64_t *ptr = PyArray_DATA((PyArrayObject *)indptr);
        int64_t *ind = PyArray_DATA((PyArrayObject *)indices);
        for (size_t i = 0; i <= W.rows; i++)
            ptr[i] = (int64_t)W.row_ptr[i];
        for (size_t k = 0; k < W.nnz; k++)
            ind[k] = W.col[k];
        if (W.nnz)
            memcpy(PyArray_DATA((PyArrayObject *)data), W.val, W.nnz * sizeof *W.val);
    }
    size_t M = W.rows, C = W.cols;
    ffd_sparse_free(&W);
    if (!indptr || !indices || !data) {
        Py_XDECREF(indptr);
        Py_XDECREF(indices);
        Py_XDECREF(data);
        return NULL;
    }
    return Py_BuildValue("(NNNnn)", indptr, indices, data, (Py_ssize_t)M, (Py_ssize_t)C);
}

/* W v (transpose 0: v is (C, 3), the result (M, 3)) or W^T w (transpose 1:
 * w is (M, 3), the result (C, 3)), into out or a new array; the GIL
 * released during the product. */
static PyObject *sensitivity_product(ffdpy_Deformer *self, PyObject *args, PyObject *kwds,
                                     int transpose)
{
    static char *kw[] = {"v", "out", NULL};
    static char *kw_t[] = {"w", "out", NULL};
    PyObject *in = NULL, *out = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds,
                                     transpose ? "O|O:sensitivity_transpose_product"
                                               : "O|O:sensitivity_product",
                                     transpose ? kw_t : kw, &in, &out) ||
        !ready(self))
        return NULL;
    enter(self);
    size_t M = ffd_deformer_point_count(self->d), C = ffd_deformer_control_count(self->d);
    npy_intp in_dims[2] = {(npy_intp)(transpose ? M : C), 3};
    npy_intp out_dims[2] = {(npy_intp)(transpose ? C : M), 3};
    PyArrayObject *x = ffdpy_doubles(in, transpose ? "w" : "v", 2, in_dims);
    if (!x || (out != Py_None && ffdpy_check_out(out, 2, out_dims) < 0)) {
        leave(self);
        Py_XDECREF(x);
        return NULL;
    }
    PyObject *result = out != Py_None ? Py_NewRef(out) : PyArray_SimpleNew(2, out_dims, NPY_DOUBLE);
    if (!result) {
        leave(self);
        Py_DECREF(x);
        return NULL;
    }
    double *dst = PyArray_DATA((PyArrayObject *)result);
    const double *src = PyArray_DATA(x);
    ffd_error err = {{0}};
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    st = transpose ? ffd_deformer_sensitivity_transpose_product(self->d, src, dst, &err)
                   : ffd_deformer_sensitivity_product(self->d, src, dst, &err);
    Py_END_ALLOW_THREADS
    leave(self);
    Py_DECREF(x);
    if (st) {
        Py_DECREF(result);
        return ffdpy_raise(st, &err, NULL);
    }
    return result;
}

static PyObject *Deformer_sensitivity_product(ffdpy_Deformer *self, PyObject *args, PyObject *kwds)
{
    return sensitivity_product(self, args, kwds, 0);
}

static PyObject *Deformer_sensitivity_transpose_product(ffdpy_Deformer *self, PyObject *args,
                                                        PyObject *kwds)
{
    return sensitivity_product(self, args, kwds, 1);
}

/* PB-FFD frame sensitivities (ffd_pbffd_frame_sensitivities) of the
 * deformer's pbffd handle at level: (indptr int64 (3M+1,), indices int64,
 * data float64, 3M, 6E). The handle's own points must be the bound points
 * (the deformer was not bound to other points). */
static PyObject *Deformer_pbffd_frame_sensitivities_csr(ffdpy_Deformer *self, PyObject *args)
{
    Py_ssize_t level;
    if (!PyArg_ParseTuple(args, "n:_pbffd_frame_sensitivities_csr", &level) || !ready(self))
        return NULL;
    if (level < 0) {
        PyErr_Format(PyExc_ValueError, "level %zd: expected >= 0", level);
        return NULL;
    }
    enter(self);
    const ffd_pbffd *pb = ffd_deformer_handle(self->d, "pbffd");
    if (!pb || ffd_pbffd_point_count(pb) != ffd_deformer_point_count(self->d)) {
        leave(self);
        PyErr_SetString(PyExc_ValueError,
                        pb ? "frame sensitivities are of the mesh's own vertices: this deformer was "
                             "bound to other points"
                           : "frame sensitivities: not a PB-FFD deformer");
        return NULL;
    }
    ffd_sparse W = {0};
    ffd_error err = {{0}};
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_pbffd_frame_sensitivities(pb, (size_t)level, &W, &err);
    Py_END_ALLOW_THREADS
    leave(self);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    npy_intp np1 = (npy_intp)W.rows + 1, nnz = (npy_intp)W.nnz;
    PyObject *indptr = PyArray_SimpleNew(1, &np1, NPY_INT64);
    PyObject *indices = PyArray_SimpleNew(1, &nnz, NPY_INT64);
    PyObject *data = PyArray_SimpleNew(1, &nnz, NPY_DOUBLE);
    if (!indptr || !indices || !data) {
        Py_XDECREF(indptr);
        Py_XDECREF(indices);
        Py_XDECREF(data);
        ffd_sparse_free(&W);
        return NULL;
    }
    int64_t *ptr = PyArray_DATA((PyArrayObject *)indptr), *ind = PyArray_DATA((PyArrayObject *)indices);
    for (size_t r = 0; r <= W.rows; r++)
        ptr[r] = (int64_t)W.row_ptr[r];
    for (size_t k = 0; k < W.nnz; k++)
        ind[k] = W.col[k];
    if (W.nnz)
        memcpy(PyArray_DATA((PyArrayObject *)data), W.val, W.nnz * sizeof(double));
    PyObject *res = Py_BuildValue("(NNNnn)", indptr, indices, data, (Py_ssize_t)W.rows,
                                  (Py_ssize_t)W.cols);
    ffd_sparse_free(&W);
    return res;
}

/* T-spline ARAP drag sensitivities at fixed rotations
 * (ffd_tsv_arap_sensitivity_product / _transpose_product) for a drag of
 * handles begun from the current lattice (identity rotations; nothing
 * changes): transpose 0: values (k, 3) -> (M, 3); 1: values (M, 3) -> (k, 3). */
static PyObject *Deformer_tspline_arap_product(ffdpy_Deformer *self, PyObject *args)
{
    PyObject *ids_obj, *values_obj;
    int transpose, soft;
    if (!PyArg_ParseTuple(args, "OOpp:_tspline_arap_product", &ids_obj, &values_obj, &transpose,
                          &soft) ||
        !ready(self))
        return NULL;
    PyArrayObject *ids = ffdpy_ids(ids_obj, "handles");
    if (!ids)
        return NULL;
    size_t k = (size_t)PyArray_SIZE(ids);
    enter(self);
    ffd_tsv *t = ffd_deformer_handle(self->d, "tspline");
    size_t n = ffd_deformer_point_count(self->d);
    if (!t || ffd_tsv_point_count(t) != n) {
        leave(self);
        Py_DECREF(ids);
        PyErr_SetString(PyExc_ValueError,
                        t ? "ARAP sensitivities are of the mesh's own vertices: this deformer was "
                            "bound to other points"
                          : "ARAP sensitivities: not a T-spline deformer");
        return NULL;
    }
    leave(self);
    npy_intp in_dims[2] = {(npy_intp)(transpose ? n : k), 3};
    PyArrayObject *values = ffdpy_doubles(values_obj, transpose ? "w" : "v", 2, in_dims);
    if (!values) {
        Py_DECREF(ids);
        return NULL;
    }
    npy_intp out_dims[2] = {(npy_intp)(transpose ? k : n), 3};
    PyObject *out = PyArray_SimpleNew(2, out_dims, NPY_DOUBLE);
    if (!out) {
        Py_DECREF(ids);
        Py_DECREF(values);
        return NULL;
    }
    const uint32_t *h = PyArray_DATA(ids);
    const double *in = PyArray_DATA(values);
    double *o = PyArray_DATA((PyArrayObject *)out);
    ffd_error err = {{0}};
    ffd_status st;
    enter(self);
    Py_BEGIN_ALLOW_THREADS
    ffd_tsv_arap_options opt = {0};
    opt.soft = soft;
    ffd_tsv_arap *a = NULL;
    st = ffd_tsv_arap_begin(t, h, k, &opt, &a, &err);
    if (!st)
        st = transpose ? ffd_tsv_arap_sensitivity_transpose_product(a, in, o, &err)
                       : ffd_tsv_arap_sensitivity_product(a, in, o, &err);
    ffd_tsv_arap_destroy(a);
    Py_END_ALLOW_THREADS
    leave(self);
    Py_DECREF(ids);
    Py_DECREF(values);
    if (st) {
        Py_DECREF(out);
        return ffdpy_raise(st, &err, NULL);
    }
    return out;
}

static PyObject *Deformer_get_method(ffdpy_Deformer *self, void *c)
{
    if (!ready(self))
        return NULL;
    return PyUnicode_FromString(ffd_deformer_method(self->d));
}

static PyObject *Deformer_get_point_count(ffdpy_Deformer *self, void *c)
{
    if (!ready(self))
        return NULL;
    enter(self);
    size_t n = ffd_deformer_point_count(self->d);
    leave(self);
    return PyLong_FromSize_t(n);
}

static PyObject *Deformer_get_control_count(ffdpy_Deformer *self, void *c)
{
    if (!ready(self))
        return NULL;
    enter(self);
    size_t n = ffd_deformer_control_count(self->d);
    leave(self);
    return PyLong_FromSize_t(n);
}

static PyMethodDef Deformer_methods[] = {
    {"bind", (PyCFunction)Deformer_bind, METH_O,
     "bind(points)\n\nBinds any (M, 3) points given at rest (GIL released); they deform exactly as the "
     "same points would as vertices of the mesh."},
    {"evaluate", (PyCFunction)(void (*)(void))Deformer_evaluate, METH_VARARGS | METH_KEYWORDS,
     "evaluate(out=None) -> ndarray (M, 3)\n\nThe deformed bound points (GIL released); out: a "
     "C-contiguous float64 (M, 3) array written in place and returned."},
    {"jacobian", (PyCFunction)(void (*)(void))Deformer_jacobian, METH_VARARGS | METH_KEYWORDS,
     "jacobian(out=None) -> ndarray (M, 3, 3)\n\nd(x')/d(x) at the bound points (GIL released)."},
    {"_get_controls", (PyCFunction)Deformer_get_controls, METH_NOARGS,
     "_get_controls() -> ndarray (C, 3)\n\nA copy of the control positions."},
    {"set_controls", (PyCFunction)Deformer_set_controls, METH_VARARGS,
     "set_controls(ids, positions)\n\nSets controls ids (None: all, in order) to positions (k, 3)."},
    {"move", (PyCFunction)Deformer_move, METH_VARARGS,
     "move(ids, deltas)\n\nMoves controls ids (None: all) by deltas (k, 3)."},
    {"reset", (PyCFunction)Deformer_reset, METH_NOARGS, "reset()\n\nEvery control back at rest."},
    {"_report_json", (PyCFunction)Deformer_report_json, METH_NOARGS, "The method's report as JSON text."},
    {"_rig_json", (PyCFunction)Deformer_rig_json, METH_NOARGS,
     "The deformer's state as rig JSON text (ffd_deformer_rig)."},
    {"_command_json", (PyCFunction)Deformer_command_json, METH_VARARGS,
     "_command_json(op, body=None)\n\nRuns the method's operation op with its JSON body text "
     "(GIL released)."},
    {"_solve", (PyCFunction)(void (*)(void))Deformer_solve, METH_VARARGS | METH_KEYWORDS,
     "_solve(points, targets, rcond=1e-10) -> (residuals, reached, rank, max_residual, "
     "variables_used)\n\nDirect manipulation of bound points towards targets (GIL released)."},
    {"_sensitivities_csr", (PyCFunction)Deformer_sensitivities_csr, METH_NOARGS,
     "W = dX/dP in CSR form: (indptr, indices, data, M, C)."},
    {"sensitivity_product", (PyCFunction)(void (*)(void))Deformer_sensitivity_product,
     METH_VARARGS | METH_KEYWORDS,
     "sensitivity_product(v, out=None) -> (M, 3)\n\nW @ v for v (C, 3): the change of the bound "
     "points' deformed positions\nfor a change v of the controls (dX/dP = W (x) I3), without "
     "forming W.\nUnsupportedError for a method without a linear map (GFFD)."},
    {"sensitivity_transpose_product",
     (PyCFunction)(void (*)(void))Deformer_sensitivity_transpose_product,
     METH_VARARGS | METH_KEYWORDS,
     "sensitivity_transpose_product(w, out=None) -> (C, 3)\n\nW.T @ w for w (M, 3): the adjoint "
     "product dJ/dP = (dX/dP)^T dJ/dX,\nwithout forming W. UnsupportedError for GFFD."},
    {"_linear_map_csr", (PyCFunction)Deformer_linear_map_csr, METH_NOARGS,
     "_linear_map_csr() -> (indptr, indices, data, M, C)\n\nThe linear map's rows by control id "
     "(duplicates not summed)."},
    {"_pbffd_frame_sensitivities_csr", (PyCFunction)Deformer_pbffd_frame_sensitivities_csr,
     METH_VARARGS,
     "_pbffd_frame_sensitivities_csr(level) -> (indptr, indices, data, rows, cols)\n\nPB-FFD frame "
     "sensitivities (ffd_pbffd_frame_sensitivities)."},
    {"_tspline_arap_product", (PyCFunction)Deformer_tspline_arap_product, METH_VARARGS,
     "_tspline_arap_product(handles, values, transpose, soft) -> ndarray\n\nT-spline ARAP drag "
     "sensitivity products at fixed rotations (ffd_tsv_arap_sensitivity_product)."},
    {NULL, NULL, 0, NULL}};

static PyGetSetDef Deformer_getset[] = {
    {"method", (getter)Deformer_get_method, NULL, "The method's name: 'lattice', 'pbffd', 'gffd', 'tspline'.",
     NULL},
    {"point_count", (getter)Deformer_get_point_count, NULL, "The number of bound points M.", NULL},
    {"control_count", (getter)Deformer_get_control_count, NULL, "The number of controls C.", NULL},
    {"__dict__", PyObject_GenericGetDict, PyObject_GenericSetDict, NULL, NULL},
    {NULL, NULL, NULL, NULL, NULL}};

PyTypeObject ffdpy_DeformerType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "ffdkit._ffd.Deformer",
    .tp_basicsize = sizeof(ffdpy_Deformer),
    .tp_dealloc = (destructor)Deformer_dealloc,
    .tp_traverse = (traverseproc)Deformer_traverse,
    .tp_clear = (inquiry)Deformer_clear,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_doc = "Deformer(rig, target, limits=None)\n\nThe rig's deformer (ffd_deformer_create) for target "
              "(a Mesh, or (N, 3) points), its bound points target's vertices.",
    .tp_dictoffset = offsetof(ffdpy_Deformer, dict),
    .tp_weaklistoffset = offsetof(ffdpy_Deformer, weakrefs),
    .tp_methods = Deformer_methods,
    .tp_getset = Deformer_getset,
    .tp_new = Deformer_new,
};

int ffdpy_init_deformer(PyObject *module)
{
    if (PyType_Ready(&ffdpy_DeformerType) < 0)
        return -1;
    return PyModule_AddObjectRef(module, "Deformer", (PyObject *)&ffdpy_DeformerType);
}
