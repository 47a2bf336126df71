/* ffdkit._ffd's distributed runs (ffd.h "Distributed runs", docs/python.md
 * "MPI (mpi4py)"): an ffd_comm whose two callbacks call a Python object, the
 * reducer, so that this module links no MPI; ffdkit/mpi.py makes the reducer
 * of an mpi4py communicator. The library's collective call runs with the GIL
 * released and each callback takes it back (PyGILState_Ensure). An
 * exception a callback raises fails the callback (the library then fails
 * with FFD_ERR_IO) and is what the call raises.
 *
 * Every rank first agrees (ffd_comm_agree) on its own arguments: a rank
 * whose points, ids or mesh are refused before the collective call would
 * otherwise leave the others waiting in it; so a local error is every
 * rank's error, "rank R: <message>". */
#include "ffdpy.h"

#include <math.h>
#include <string.h>

typedef struct {
    PyObject *allreduce; /* the reducer's bound methods (owned) */
    PyObject *allgatherv;
    PyObject *exc_type, *exc_value, *exc_tb; /* the first exception a callback raised */
    int size;
} pycomm;

static const char *const op_names[] = {"sum", "min", "max", "or"};

/* Keeps the pending exception as the call's (the first one wins). */
static void keep_exception(pycomm *c)
{
    if (!c->exc_type)
        PyErr_Fetch(&c->exc_type, &c->exc_value, &c->exc_tb);
    else
        PyErr_Clear();
}

/* A 1-D array of n items of type over data: the library's memory, valid
 * during the callback only. */
static PyObject *wrap(void *data, size_t n, int type, int writeable)
{
    npy_intp dim = (npy_intp)n;
    return PyArray_New(&PyArray_Type, 1, &dim, type, NULL, n ? data : NULL, 0,
                       writeable ? NPY_ARRAY_CARRAY : NPY_ARRAY_CARRAY_RO, NULL);
}

/* 0 when the callback let go of the array a, else a RuntimeError: the array
 * would outlive the memory it shows. */
static int let_go(PyObject *a, const char *what)
{
    if (Py_REFCNT(a) == 1)
        return 0;
    PyErr_Format(PyExc_RuntimeError,
                 "reducer.%s kept a reference to its buffer (the library's memory, valid only "
                 "during the call)",
                 what);
    return -1;
}

static int cb_allreduce(void *user, void *data, size_t count, ffd_reduce_type type,
                        ffd_reduce_op op)
{
    pycomm *c = user;
    PyGILState_STATE g = PyGILState_Ensure();
    int rc = -1;
    if (op < FFD_REDUCE_SUM || op > FFD_REDUCE_OR) {
        PyErr_Format(PyExc_ValueError, "allreduce: unknown operation %d", (int)op);
    } else {
        PyObject *a = wrap(data, count, type == FFD_REDUCE_UINT64 ? NPY_UINT64 : NPY_DOUBLE, 1);
        PyObject *r = a ? PyObject_CallFunction(c->allreduce, "Os", a, op_names[op]) : NULL;
        if (r) {
            Py_DECREF(r);
            rc = let_go(a, "allreduce");
        }
        Py_XDECREF(a);
    }
    if (rc)
        keep_exception(c);
    PyGILState_Release(g);
    return rc;
}

static int cb_allgatherv(void *user, const void *mine, size_t bytes, void *all, const size_t *sizes)
{
    pycomm *c = user;
    PyGILState_STATE g = PyGILState_Ensure();
    int rc = -1;
    size_t total = 0;
    PyObject *counts = PyTuple_New(c->size);
    for (int r = 0; counts && r < c->size; r++) {
        PyObject *v = PyLong_FromSize_t(sizes[r]);
        if (!v) {
            Py_CLEAR(counts);
            break;
        }
        PyTuple_SET_ITEM(counts, r, v);
        total += sizes[r];
    }
    PyObject *a = counts ? wrap((void *)mine, bytes, NPY_UINT8, 0) : NULL;
    PyObject *b = a ? wrap(all, total, NPY_UINT8, 1) : NULL;
    PyObject *r = b ? PyObject_CallFunction(c->allgatherv, "OOO", a, b, counts) : NULL;
    if (r) {
        Py_DECREF(r);
        rc = let_go(a, "allgatherv") || let_go(b, "allgatherv") ? -1 : 0;
    }
    Py_XDECREF(a);
    Py_XDECREF(b);
    Py_XDECREF(counts);
    if (rc)
        keep_exception(c);
    PyGILState_Release(g);
    return rc;
}

/* The ffd_comm over reducer: its rank and size (ints, 0 <= rank < size)
 * and its allreduce and allgatherv methods. TypeError or ValueError. */
static int comm_init(PyObject *reducer, pycomm *c, ffd_comm *comm)
{
    memset(c, 0, sizeof *c);
    memset(comm, 0, sizeof *comm);
    static const char protocol[] =
        "reducer: expected an object with rank, size, allreduce(array, op) and "
        "allgatherv(mine, out, sizes) (ffdkit.mpi makes one of an mpi4py communicator)";
    long rank = -1, size = -1;
    PyObject *v = PyObject_GetAttrString(reducer, "rank");
    if (v) {
        rank = PyLong_AsLong(v);
        Py_DECREF(v);
    }
    v = PyErr_Occurred() ? NULL : PyObject_GetAttrString(reducer, "size");
    if (v) {
        size = PyLong_AsLong(v);
        Py_DECREF(v);
    }
    if (!PyErr_Occurred()) {
        c->allreduce = PyObject_GetAttrString(reducer, "allreduce");
        c->allgatherv = c->allreduce ? PyObject_GetAttrString(reducer, "allgatherv") : NULL;
    }
    if (PyErr_Occurred() || !PyCallable_Check(c->allreduce) || !PyCallable_Check(c->allgatherv)) {
        PyErr_Clear();
        Py_CLEAR(c->allreduce);
        Py_CLEAR(c->allgatherv);
        PyErr_SetString(PyExc_TypeError, protocol);
        return -1;
    }
    if (size < 1 || size > 0x7fffffff || rank < 0 || rank >= size) {
        Py_CLEAR(c->allreduce);
        Py_CLEAR(c->allgatherv);
        PyErr_Format(PyExc_ValueError, "reducer: rank %ld of size %ld (expected 0 <= rank < size)",
                     rank, size);
        return -1;
    }
    c->size = (int)size;
    comm->rank = (int)rank;
    comm->size = (int)size;
    comm->allreduce = cb_allreduce;
    comm->allgatherv = cb_allgatherv;
    comm->user = c;
    return 0;
}

static void comm_release(pycomm *c)
{
    Py_CLEAR(c->allreduce);
    Py_CLEAR(c->allgatherv);
    Py_CLEAR(c->exc_type);
    Py_CLEAR(c->exc_value);
    Py_CLEAR(c->exc_tb);
}

/* After a collective call (the GIL held): 1 with a callback's exception
 * raised again, else 0. */
static int callback_failed(pycomm *c)
{
    if (!c->exc_type)
        return 0;
    PyErr_Restore(c->exc_type, c->exc_value, c->exc_tb);
    c->exc_type = c->exc_value = c->exc_tb = NULL;
    return 1;
}

/* The global ids of n vertices: NULL (*ids NULL) for None, else a uint64
 * C-contiguous array (no copy when obj already is one). Raises TypeError or
 * ValueError; returns -1 then. */
static int global_ids_array(PyObject *obj, size_t n, PyArrayObject **ids)
{
    *ids = NULL;
    if (obj == Py_None)
        return 0;
    PyArrayObject *a = (PyArrayObject *)PyArray_FROM_O(obj);
    if (!a)
        return -1;
    char kind = PyArray_DESCR(a)->kind;
    if (!(kind == 'i' || kind == 'u' || (kind == 'f' && PyArray_SIZE(a) == 0))) {
        PyErr_Format(PyExc_TypeError, "global_ids: expected integer ids, got dtype %R",
                     (PyObject *)PyArray_DESCR(a));
        Py_DECREF(a);
        return -1;
    }
    if (PyArray_NDIM(a) != 1 || (size_t)PyArray_DIM(a, 0) != n) {
        PyObject *shape = PyObject_GetAttrString((PyObject *)a, "shape");
        if (shape)
            PyErr_Format(PyExc_ValueError, "global_ids: expected %zu ids (one per point), got shape %R",
                         n, shape);
        Py_XDECREF(shape);
        Py_DECREF(a);
        return -1;
    }
    if (kind == 'i') {
        PyArrayObject *s = (PyArrayObject *)PyArray_FromArray(
            a, PyArray_DescrFromType(NPY_INT64), NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED | NPY_ARRAY_FORCECAST);
        Py_DECREF(a);
        if (!s)
            return -1;
        const int64_t *v = PyArray_DATA(s);
        for (size_t i = 0; i < n; i++) {
            if (v[i] < 0) {
                PyErr_Format(PyExc_ValueError, "global_ids[%zu]: id %lld is negative", i, (long long)v[i]);
                Py_DECREF(s);
                return -1;
            }
        }
        a = s;
    }
    *ids = (PyArrayObject *)PyArray_FromArray(a, PyArray_DescrFromType(NPY_UINT64),
                                              NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED |
                                                  NPY_ARRAY_FORCECAST);
    Py_DECREF(a);
    return *ids ? 0 : -1;
}

/* Every rank learns of local (this rank's status, err its message; or a
 * Python exception pending on this rank, taken as FFD_ERR_INVALID with its
 * text). Returns 0 when every rank was fine; else -1 with the agreed error
 * raised on every rank ("rank R: ..."; on the failing rank its own
 * exception is the cause), or a callback's exception. */
static int agree(const ffd_comm *comm, pycomm *c, ffd_status local, ffd_error *err)
{
    PyObject *et = NULL, *ev = NULL, *etb = NULL;
    if (PyErr_Occurred()) {
        PyErr_Fetch(&et, &ev, &etb);
        PyErr_NormalizeException(&et, &ev, &etb);
        if (etb && ev)
            PyException_SetTraceback(ev, etb);
        PyObject *text = ev ? PyObject_Str(ev) : NULL;
        const char *t = text ? PyUnicode_AsUTF8(text) : NULL;
        if (!t)
            PyErr_Clear();
        /* an ffdkit.Error keeps its status and message; another exception
         * (TypeError, ValueError of an argument) is named */
        local = ev ? ffdpy_status_of(ev) : FFD_ERR_INVALID;
        if (local)
            snprintf(err->message, sizeof err->message, "%s", t ? t : "");
        else
            snprintf(err->message, sizeof err->message, "%s%s%s", ((PyTypeObject *)et)->tp_name,
                     t && t[0] ? ": " : "", t ? t : "");
        Py_XDECREF(text);
        if (!local)
            local = FFD_ERR_INVALID;
    }
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_comm_agree(comm, local, err);
    Py_END_ALLOW_THREADS
    if (callback_failed(c)) {
        Py_XDECREF(et);
        Py_XDECREF(ev);
        Py_XDECREF(etb);
        return -1;
    }
    if (!st) {
        Py_XDECREF(et);
        Py_XDECREF(ev);
        Py_XDECREF(etb);
        return 0;
    }
    ffdpy_raise(st, err, NULL);
    if (ev) {
        PyObject *t, *v, *tb;
        PyErr_Fetch(&t, &v, &tb);
        PyErr_NormalizeException(&t, &v, &tb);
        PyException_SetCause(v, ev); /* steals ev */
        ev = NULL;
        PyErr_Restore(t, v, tb);
    }
    Py_XDECREF(et);
    Py_XDECREF(ev);
    Py_XDECREF(etb);
    return -1;
}

/* ---------- apply ---------- */

static PyObject *apply_distributed(PyObject *module, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"rig", "target", "reducer", "global_ids", "out", "limits", NULL};
    PyObject *rig_obj, *target, *reducer, *ids_obj = Py_None, *out = Py_None, *limits_obj = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O!OO|OOO:apply_distributed", kw, &ffdpy_RigType,
                                     &rig_obj, &target, &reducer, &ids_obj, &out, &limits_obj))
        return NULL;
    pycomm c;
    ffd_comm comm;
    if (comm_init(reducer, &c, &comm) < 0)
        return NULL;
    ffd_error err = {{0}};
    ffd_status st = FFD_OK;
    ffd_limits limits;
    int have_limits = 0;
    PyArrayObject *ids = NULL, *p = NULL;
    PyObject *result = NULL, *ret = NULL;
    ffdpy_Mesh *m = NULL;
    ffd_mesh *mesh = NULL, *owned = NULL;
    Py_INCREF(rig_obj);
    const ffd_rig *rig = ((ffdpy_Rig *)rig_obj)->rig;

    /* this rank's arguments, agreed on below */
    if (ffdpy_limits(limits_obj, &limits, &have_limits) < 0)
        goto local_done;
    if (PyObject_TypeCheck(target, &ffdpy_MeshType)) {
        if (out != Py_None) {
            PyErr_SetString(PyExc_ValueError, "out: only for points; a Mesh is deformed in place");
            goto local_done;
        }
        ffdpy_Mesh *tm = (ffdpy_Mesh *)target;
        if (global_ids_array(ids_obj, ffd_mesh_vertex_count(tm->store->mesh), &ids) < 0)
            goto local_done;
        Py_INCREF(tm);
        if (!(mesh = ffdpy_mesh_for_change(tm))) {
            Py_DECREF(tm);
            goto local_done;
        }
        m = tm;
    } else {
        if (!(p = ffdpy_points(target, "points")))
            goto local_done;
        npy_intp dims[2] = {PyArray_DIM(p, 0), 3};
        if (out != Py_None && ffdpy_check_out(out, 2, dims) < 0)
            goto local_done;
        if (global_ids_array(ids_obj, (size_t)dims[0], &ids) < 0)
            goto local_done;
        result = out != Py_None ? Py_NewRef(out) : PyArray_SimpleNew(2, dims, NPY_DOUBLE);
        if (!result)
            goto local_done;
        const double *src = PyArray_DATA(p);
        for (npy_intp i = 0; i < 3 * dims[0]; i++) {
            if (!isfinite(src[i])) {
                snprintf(err.message, sizeof err.message, "points[%ld]: non-finite position (%g, %g, %g)",
                         (long)(i / 3), src[i - i % 3], src[i - i % 3 + 1], src[i - i % 3 + 2]);
                st = FFD_ERR_NONFINITE;
                goto local_done;
            }
        }
        Py_BEGIN_ALLOW_THREADS
        st = ffd_mesh_create(src, (size_t)dims[0], NULL, NULL, 0, &owned, &err);
        Py_END_ALLOW_THREADS
        mesh = owned;
    }
local_done:
    if (agree(&comm, &c, st, &err) < 0)
        goto done;

    ffd_partition part = {&comm, ids ? PyArray_DATA(ids) : NULL, have_limits ? &limits : NULL};
    ffd_rig_report rep;
    memset(&rep, 0, sizeof rep);
    size_t n = ffd_mesh_vertex_count(mesh);
    double *dst = result ? PyArray_DATA((PyArrayObject *)result) : NULL;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_rig_apply_distributed(rig, mesh, &part, &rep, &err);
    if (!st && dst && ffd_mesh_vertex_count(mesh) != n) {
        snprintf(err.message, sizeof err.message,
                 "the rig changes the number of points (%zu to %zu): apply it to a Mesh", n,
                 ffd_mesh_vertex_count(mesh));
        st = FFD_ERR_UNSUPPORTED;
    }
    if (!st && dst && n)
        memcpy(dst, ffd_mesh_positions(mesh), n * 3 * sizeof(double));
    Py_END_ALLOW_THREADS
    if (!callback_failed(&c)) {
        if (st)
            ffdpy_raise(st, &err, NULL);
        else
            ret = m ? ffdpy_report_dict(&rep) : Py_NewRef(result);
    }
    ffd_rig_report_free(&rep);
done:
    if (m) {
        ffdpy_mesh_end_change(m);
        Py_DECREF(m);
    }
    ffd_mesh_destroy(owned);
    Py_XDECREF(result);
    Py_XDECREF(p);
    Py_XDECREF(ids);
    Py_DECREF(rig_obj);
    comm_release(&c);
    return ret;
}

/* ---------- a deformer ---------- */

static PyObject *deformer_distributed(PyObject *module, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"cls", "rig", "target", "reducer", "global_ids", "limits", NULL};
    PyObject *cls_obj, *rig_obj, *target, *reducer, *ids_obj = Py_None, *limits_obj = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O!O!OO|OO:deformer_distributed", kw, &PyType_Type,
                                     &cls_obj, &ffdpy_RigType, &rig_obj, &target, &reducer, &ids_obj,
                                     &limits_obj))
        return NULL;
    PyTypeObject *cls = (PyTypeObject *)cls_obj;
    if (!PyType_IsSubtype(cls, &ffdpy_DeformerType)) {
        PyErr_Format(PyExc_TypeError, "cls: expected a Deformer class, got %s", cls->tp_name);
        return NULL;
    }
    pycomm c;
    ffd_comm comm;
    if (comm_init(reducer, &c, &comm) < 0)
        return NULL;
    ffd_error err = {{0}};
    ffd_status st = FFD_OK;
    ffd_limits limits;
    int have_limits = 0;
    PyArrayObject *ids = NULL;
    const ffd_mesh *mesh = NULL;
    ffd_mesh *owned = NULL;
    PyObject *keep = NULL;
    ffdpy_Deformer *self = NULL;
    PyObject *ret = NULL;
    Py_INCREF(rig_obj);
    const ffd_rig *rig = ((ffdpy_Rig *)rig_obj)->rig;

    if (ffdpy_limits(limits_obj, &limits, &have_limits) < 0 ||
        ffdpy_mesh_or_points(target, "points", &mesh, &owned, &keep) < 0 ||
        global_ids_array(ids_obj, ffd_mesh_vertex_count(mesh), &ids) < 0)
        goto local_done;
    self = ffdpy_deformer_alloc(cls);
local_done:
    if (agree(&comm, &c, st, &err) < 0)
        goto done;

    ffd_partition part = {&comm, ids ? PyArray_DATA(ids) : NULL, have_limits ? &limits : NULL};
    ffd_deformer *d = NULL;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_deformer_create_distributed(rig, mesh, &part, &d, &err);
    Py_END_ALLOW_THREADS
    if (callback_failed(&c)) {
        ffd_deformer_destroy(d);
    } else if (st) {
        ffdpy_raise(st, &err, NULL);
    } else {
        self->d = d;
        ret = (PyObject *)self;
        self = NULL;
    }
done:
    Py_XDECREF(self);
    ffd_mesh_destroy(owned);
    Py_XDECREF(keep);
    Py_XDECREF(ids);
    Py_DECREF(rig_obj);
    comm_release(&c);
    return ret;
}

/* ---------- agreeing ---------- */

static PyObject *agree_py(PyObject *module, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"reducer", "error", NULL};
    PyObject *reducer, *error = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O|O:agree", kw, &reducer, &error))
        return NULL;
    if (error != Py_None && !PyExceptionInstance_Check(error)) {
        PyErr_Format(PyExc_TypeError, "error: expected None or an exception, got %s",
                     Py_TYPE(error)->tp_name);
        return NULL;
    }
    pycomm c;
    ffd_comm comm;
    if (comm_init(reducer, &c, &comm) < 0)
        return NULL;
    ffd_error err = {{0}};
    if (error != Py_None)
        PyErr_SetObject((PyObject *)Py_TYPE(error), error);
    int rc = agree(&comm, &c, FFD_OK, &err);
    comm_release(&c);
    if (rc < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyMethodDef distributed_methods[] = {
    {"agree", (PyCFunction)(void (*)(void))agree_py, METH_VARARGS | METH_KEYWORDS,
     "agree(reducer, error=None)\n\nffd_comm_agree, collectively: error is this rank's exception "
     "(None: none). Returns None when no rank had one; else raises on every rank the lowest "
     "failing rank's error as an ffdkit.Error (its status kept for an ffdkit.Error, else "
     "InvalidError) with the message \"rank R: <message>\"; on that rank its own exception is "
     "the cause."},
    {"apply_distributed", (PyCFunction)(void (*)(void))apply_distributed, METH_VARARGS | METH_KEYWORDS,
     "apply_distributed(rig, target, reducer, global_ids=None, out=None, limits=None)\n\n"
     "ffd_rig_apply_distributed: the rig applied to this rank's piece of a distributed mesh, "
     "collectively (every rank calls it). target: (N, 3) points (returns the deformed points, in "
     "out when given) or a Mesh (deformed in place; returns the report as a dict). reducer: rank, "
     "size, allreduce(array, op) reducing a float64 or uint64 array in place over every rank (op: "
     "'sum', 'min', 'max', 'or'), allgatherv(mine, out, sizes) writing every rank's uint8 bytes, "
     "in rank order, into out (sizes: each rank's byte count); the arrays are the library's "
     "memory, valid during the call only. global_ids: the points' ids in the whole mesh (None: "
     "rank-major). GIL released; callbacks take it."},
    {"deformer_distributed", (PyCFunction)(void (*)(void))deformer_distributed,
     METH_VARARGS | METH_KEYWORDS,
     "deformer_distributed(cls, rig, target, reducer, global_ids=None, limits=None) -> cls\n\n"
     "ffd_deformer_create_distributed: a Deformer of class cls (a Deformer subclass) bound to this "
     "rank's points (a Mesh or (N, 3) points), collectively; reducer and global_ids as "
     "apply_distributed."},
    {NULL, NULL, 0, NULL}};

int ffdpy_init_distributed(PyObject *module) { return PyModule_AddFunctions(module, distributed_methods); }
