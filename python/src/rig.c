/* ffdkit._ffd.Rig: a parsed rig (ffd_rig) and its application to points
 * or a Mesh (ffd_rig_apply_limited, GIL released). */
#include "ffdpy.h"

#include <string.h>

#include "deformer/method.h"
#include "rig/rig.h"

static PyObject *rig_wrap(PyTypeObject *cls, ffd_rig *rig)
{
    ffdpy_Rig *r = (ffdpy_Rig *)cls->tp_alloc(cls, 0);
    if (!r) {
        ffd_rig_destroy(rig);
        return NULL;
    }
    r->rig = rig;
    return (PyObject *)r;
}

static void Rig_dealloc(ffdpy_Rig *r)
{
    if (r->weakrefs)
        PyObject_ClearWeakRefs((PyObject *)r);
    ffd_rig_destroy(r->rig);
    Py_TYPE(r)->tp_free((PyObject *)r);
}

static PyObject *Rig_new(PyTypeObject *cls, PyObject *args, PyObject *kwds)
{
    PyErr_SetString(PyExc_TypeError, "use Rig.load(path | dict | JSON text)");
    return NULL;
}

static PyObject *Rig_read(PyTypeObject *cls, PyObject *args)
{
    PyObject *path_obj, *path_bytes = NULL;
    if (!PyArg_ParseTuple(args, "O:read", &path_obj) || !PyUnicode_FSConverter(path_obj, &path_bytes))
        return NULL;
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_rig_read(PyBytes_AS_STRING(path_bytes), &rig, &err);
    Py_END_ALLOW_THREADS
    Py_DECREF(path_bytes);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    return rig_wrap(cls, rig);
}

static PyObject *parse(PyTypeObject *cls, PyObject *args, int prm)
{
    const char *text, *name = NULL;
    Py_ssize_t size;
    if (!PyArg_ParseTuple(args, "s#|z:parse", &text, &size, &name))
        return NULL;
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    ffd_status st = prm ? ffd_rig_parse_prm(text, (size_t)size, name, &rig, &err)
                        : ffd_rig_parse_json(text, (size_t)size, name, &rig, &err);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    return rig_wrap(cls, rig);
}

static PyObject *Rig_parse_json(PyTypeObject *cls, PyObject *args) { return parse(cls, args, 0); }
static PyObject *Rig_parse_prm(PyTypeObject *cls, PyObject *args) { return parse(cls, args, 1); }

static PyObject *Rig_get_method(ffdpy_Rig *r, void *c)
{
    return PyUnicode_FromString(r->rig->method ? r->rig->method->name : "lattice");
}

static PyObject *Rig_get_name(ffdpy_Rig *r, void *c)
{
    if (!r->rig->name)
        Py_RETURN_NONE;
    return PyUnicode_DecodeFSDefault(r->rig->name);
}

static PyObject *doubles_array(const double *v, size_t rows, int cols)
{
    npy_intp dims[2] = {(npy_intp)rows, cols};
    PyObject *a = PyArray_SimpleNew(cols ? 2 : 1, dims, NPY_DOUBLE);
    if (a && rows)
        memcpy(PyArray_DATA((PyArrayObject *)a), v, rows * (cols ? (size_t)cols : 1) * sizeof(double));
    return a;
}

PyObject *ffdpy_report_dict(const ffd_rig_report *rep)
{
    PyObject *residuals = doubles_array(rep->residuals, rep->constraint_count, 0);
    PyObject *reached = doubles_array(rep->reached, rep->constraint_count, 3);
    PyObject *controls = doubles_array(rep->control_points, rep->control_count, 3);
    PyObject *d = NULL;
    if (residuals && reached && controls)
        d = Py_BuildValue("{s:s,s:n,s:O,s:O,s:n,s:d,s:n,s:{s:d,s:d,s:d},s:O,s:(III),s:s,s:s,s:z}",
                          "method", rep->method ? rep->method : "", "constraint_count",
                          (Py_ssize_t)rep->constraint_count, "residuals", residuals, "reached", reached,
                          "rank", (Py_ssize_t)rep->rank, "max_residual", rep->max_residual,
                          "outside_count", (Py_ssize_t)rep->outside_count, "timings", "bind",
                          rep->timings.bind, "solve", rep->timings.solve, "evaluate",
                          rep->timings.evaluate, "control_points", controls, "resolution",
                          rep->resolution[0], rep->resolution[1], rep->resolution[2], "control_label",
                          rep->control_label ? rep->control_label : "", "notes",
                          rep->notes ? rep->notes : "", "details", rep->details);
    Py_XDECREF(residuals);
    Py_XDECREF(reached);
    Py_XDECREF(controls);
    return d;
}

static PyObject *Rig_apply(ffdpy_Rig *r, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"target", "out", "limits", NULL};
    PyObject *target, *out = Py_None, *limits_obj = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O|OO:apply", kw, &target, &out, &limits_obj))
        return NULL;
    ffd_limits limits;
    int have_limits;
    if (ffdpy_limits(limits_obj, &limits, &have_limits) < 0)
        return NULL;
    ffd_error err = {{0}};
    ffd_status st;
    Py_INCREF(r); /* the rig stays alive while the GIL is released */
    if (PyObject_TypeCheck(target, &ffdpy_MeshType)) {
        if (out != Py_None) {
            Py_DECREF(r);
            PyErr_SetString(PyExc_ValueError, "out: only for points; a Mesh is deformed in place");
            return NULL;
        }
        ffdpy_Mesh *m = (ffdpy_Mesh *)target;
        Py_INCREF(m);
        ffd_mesh *mesh = ffdpy_mesh_for_change(m);
        if (!mesh) {
            Py_DECREF(m);
            Py_DECREF(r);
            return NULL;
        }
        ffd_rig_report rep;
        memset(&rep, 0, sizeof rep);
        Py_BEGIN_ALLOW_THREADS
        st = ffd_rig_apply_limited(r->rig, mesh, have_limits ? &limits : NULL, &rep, &err);
        Py_END_ALLOW_THREADS
        ffdpy_mesh_end_change(m);
        Py_DECREF(m);
        Py_DECREF(r);
        PyObject *res = st ? ffdpy_raise(st, &err, NULL) : ffdpy_report_dict(&rep);
        ffd_rig_report_free(&rep);
        return res;
    }
    PyArrayObject *p = ffdpy_points(target, "points");
    if (!p) {
        Py_DECREF(r);
        return NULL;
    }
    npy_intp dims[2] = {PyArray_DIM(p, 0), 3};
    if (out != Py_None && ffdpy_check_out(out, 2, dims) < 0) {
        Py_DECREF(p);
        Py_DECREF(r);
        return NULL;
    }
    PyObject *result = out != Py_None ? Py_NewRef(out) : PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (!result) {
        Py_DECREF(p);
        Py_DECREF(r);
        return NULL;
    }
    size_t n = (size_t)dims[0];
    const double *src = PyArray_DATA(p);
    double *dst = PyArray_DATA((PyArrayObject *)result);
    Py_BEGIN_ALLOW_THREADS
    ffd_mesh *mesh = NULL;
    st = ffd_mesh_create(src, n, NULL, NULL, 0, &mesh, &err);
    if (!st)
        st = ffd_rig_apply_limited(r->rig, mesh, have_limits ? &limits : NULL, NULL, &err);
    if (!st && ffd_mesh_vertex_count(mesh) != n) {
        snprintf(err.message, sizeof err.message,
                 "%s: the rig changes the number of points (%zu to %zu): apply it to a Mesh",
                 r->rig->name ? r->rig->name : "rig", n, ffd_mesh_vertex_count(mesh));
        st = FFD_ERR_UNSUPPORTED;
    }
    if (!st && n)
        memcpy(dst, ffd_mesh_positions(mesh), n * 3 * sizeof(double));
    ffd_mesh_destroy(mesh);
    Py_END_ALLOW_THREADS
    Py_DECREF(p);
    Py_DECREF(r);
    if (st) {
        Py_DECREF(result);
        return ffdpy_raise(st, &err, NULL);
    }
    return result;
}

static PyMethodDef Rig_methods[] = {
    {"_read", (PyCFunction)Rig_read, METH_VARARGS | METH_CLASS,
     "_read(path) -> Rig\n\nReads a rig file (.prm: PyGeM parameters; JSON otherwise)."},
    {"_parse_json", (PyCFunction)Rig_parse_json, METH_VARARGS | METH_CLASS,
     "_parse_json(text, name=None) -> Rig\n\nParses rig JSON text; name names it in messages and "
     "resolves the files it refers to."},
    {"_parse_prm", (PyCFunction)Rig_parse_prm, METH_VARARGS | METH_CLASS,
     "_parse_prm(text, name=None) -> Rig\n\nParses PyGeM .prm text."},
    {"_apply", (PyCFunction)(void (*)(void))Rig_apply, METH_VARARGS | METH_KEYWORDS,
     "_apply(target, out=None, limits=None)\n\nApplies the rig (GIL released): to (N, 3) points, "
     "returning the deformed points (in out when given); to a Mesh, in place, returning the report "
     "as a dict whose 'details' is JSON text."},
    {NULL, NULL, 0, NULL}};

static PyGetSetDef Rig_getset[] = {
    {"method", (getter)Rig_get_method, NULL, "The method: 'lattice', 'pbffd', 'gffd' or 'tspline'.", NULL},
    {"name", (getter)Rig_get_name, NULL, "The name the rig was read or parsed under (None if none).", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

PyTypeObject ffdpy_RigType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "ffdkit._ffd.Rig",
    .tp_basicsize = sizeof(ffdpy_Rig),
    .tp_dealloc = (destructor)Rig_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE,
    .tp_doc = "A recorded deformation (libffd's ffd_rig). Made by Rig.load.",
    .tp_weaklistoffset = offsetof(ffdpy_Rig, weakrefs),
    .tp_methods = Rig_methods,
    .tp_getset = Rig_getset,
    .tp_new = Rig_new,
};

int ffdpy_init_rig(PyObject *module)
{
    if (PyType_Ready(&ffdpy_RigType) < 0)
        return -1;
    return PyModule_AddObjectRef(module, "Rig", (PyObject *)&ffdpy_RigType);
}
