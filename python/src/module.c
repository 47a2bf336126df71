/* ffdkit._ffd: the module, its exception classes (one per ffd_status) and
 * the conversions from Python objects to the library's arrays. */
#define FFDPY_MODULE_C
#include "ffdpy.h"

#include <string.h>

/* ---------- exceptions ---------- */

/* Error and its subclasses, indexed by ffd_status (index 0: Error itself). */
static PyObject *error_classes[FFD_ERR_UNSUPPORTED + 1];

PyObject *ffdpy_raise(ffd_status st, const ffd_error *err, const char *what)
{
    if (st <= FFD_OK || st > FFD_ERR_UNSUPPORTED)
        st = 0;
    PyObject *cls = error_classes[st] ? error_classes[st] : error_classes[0];
    const char *msg = err && err->message[0] ? err->message : (what ? what : ffd_status_string(st));
    PyObject *text = PyUnicode_DecodeUTF8(msg, (Py_ssize_t)strlen(msg), "replace");
    if (!text)
        return NULL;
    PyObject *exc = PyObject_CallOneArg(cls, text);
    Py_DECREF(text);
    if (!exc)
        return NULL;
    PyObject *status = PyUnicode_FromString(ffd_status_string(st ? st : FFD_ERR_INVALID));
    if (!status || PyObject_SetAttrString(exc, "status", status) < 0) {
        Py_XDECREF(status);
        Py_DECREF(exc);
        return NULL;
    }
    Py_DECREF(status);
    PyErr_SetObject(cls, exc);
    Py_DECREF(exc);
    return NULL;
}

ffd_status ffdpy_status_of(PyObject *exc)
{
    for (int st = FFD_ERR_UNSUPPORTED; st > FFD_OK; st--)
        if (error_classes[st] && PyObject_TypeCheck(exc, (PyTypeObject *)error_classes[st]))
            return (ffd_status)st;
    return FFD_OK;
}

/* ---------- arrays ---------- */

static int numeric_kind(PyArray_Descr *d)
{
    return d->kind == 'f' || d->kind == 'i' || d->kind == 'u' || d->kind == 'b';
}

static PyObject *shape_text(PyArrayObject *a)
{
    PyObject *shape = PyObject_GetAttrString((PyObject *)a, "shape");
    if (!shape)
        return NULL;
    PyObject *s = PyObject_Repr(shape);
    Py_DECREF(shape);
    return s;
}

/* Converts obj to an ndarray (no copy for an ndarray), checking its kind. */
static PyArrayObject *numeric_array(PyObject *obj, const char *name)
{
    if (obj == Py_None) {
        PyErr_Format(PyExc_TypeError, "%s: expected an array of numbers, got None", name);
        return NULL;
    }
    PyArrayObject *a = (PyArrayObject *)PyArray_FROM_O(obj);
    if (!a) {
        if (PyErr_ExceptionMatches(PyExc_ValueError)) {
            /* ragged nested sequences */
            PyErr_Clear();
            PyErr_Format(PyExc_ValueError, "%s: expected an (N, 3) array, got a ragged sequence", name);
        }
        return NULL;
    }
    if (!numeric_kind(PyArray_DESCR(a))) {
        PyErr_Format(PyExc_TypeError, "%s: expected numbers, got an array of dtype %R", name,
                     (PyObject *)PyArray_DESCR(a));
        Py_DECREF(a);
        return NULL;
    }
    return a;
}

static PyArrayObject *as_doubles(PyArrayObject *a)
{
    PyArray_Descr *dt = PyArray_DescrFromType(NPY_DOUBLE);
    /* no copy when a is already aligned, native, C-contiguous float64 */
    return (PyArrayObject *)PyArray_FromArray(a, dt, NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED |
                                                         NPY_ARRAY_FORCECAST);
}

/* The shape dims names as Python writes it, "(N, 3)" or "(5,)" (a negative
 * dim is any length, "N"), into want. */
static void shape_wanted(char *want, size_t size, int ndim, const npy_intp *dims)
{
    snprintf(want, size, "(");
    for (int i = 0; i < ndim; i++) {
        size_t n = strlen(want);
        if (dims[i] < 0)
            snprintf(want + n, size - n, "%s%s", i ? ", " : "", "N");
        else
            snprintf(want + n, size - n, "%s%ld", i ? ", " : "", (long)dims[i]);
    }
    strncat(want, ndim == 1 ? ",)" : ")", size - strlen(want) - 1);
}

PyArrayObject *ffdpy_doubles(PyObject *obj, const char *name, int ndim, const npy_intp *dims)
{
    PyArrayObject *a = numeric_array(obj, name);
    if (!a)
        return NULL;
    int ok = PyArray_NDIM(a) == ndim;
    for (int i = 0; ok && i < ndim; i++)
        ok = dims[i] < 0 || PyArray_DIM(a, i) == dims[i];
    if (!ok) {
        PyObject *s = shape_text(a);
        if (s) {
            char want[96];
            shape_wanted(want, sizeof want, ndim, dims);
            PyErr_Format(PyExc_ValueError, "%s: expected an %s array, got shape %U", name,
                         want, s);
        }
        Py_XDECREF(s);
        Py_DECREF(a);
        return NULL;
    }
    PyArrayObject *d = as_doubles(a);
    Py_DECREF(a);
    return d;
}

PyArrayObject *ffdpy_points(PyObject *obj, const char *name)
{
    static const npy_intp n_by_3[2] = {-1, 3};
    return ffdpy_doubles(obj, name, 2, n_by_3);
}

int ffdpy_check_out(PyObject *out, int ndim, const npy_intp *dims)
{
    if (!PyArray_Check(out)) {
        PyErr_Format(PyExc_ValueError, "out: expected a numpy array, got %s", Py_TYPE(out)->tp_name);
        return -1;
    }
    PyArrayObject *a = (PyArrayObject *)out;
    if (PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(a)) {
        PyErr_Format(PyExc_ValueError, "out: expected dtype float64, got %R", (PyObject *)PyArray_DESCR(a));
        return -1;
    }
    int ok = PyArray_NDIM(a) == ndim;
    for (int i = 0; ok && i < ndim; i++)
        ok = PyArray_DIM(a, i) == dims[i];
    if (!ok) {
        PyObject *s = shape_text(a);
        if (s) {
            char want[96];
            shape_wanted(want, sizeof want, ndim, dims);
            PyErr_Format(PyExc_ValueError, "out: expected shape %s, got %U", want, s);
        }
        Py_XDECREF(s);
        return -1;
    }
    if (!PyArray_IS_C_CONTIGUOUS(a) || !PyArray_ISALIGNED(a)) {
        PyErr_SetString(PyExc_ValueError, "out: expected a C-contiguous, aligned array");
        return -1;
    }
    if (!PyArray_ISWRITEABLE(a)) {
        PyErr_SetString(PyExc_ValueError, "out: the array is read-only");
        return -1;
    }
    return 0;
}

PyArrayObject *ffdpy_ids(PyObject *obj, const char *name)
{
    if (obj == Py_None) {
        PyErr_Format(PyExc_TypeError, "%s: expected integer ids, got None", name);
        return NULL;
    }
    PyArrayObject *a = (PyArrayObject *)PyArray_FROM_O(obj);
    if (!a)
        return NULL;
    if (PyArray_NDIM(a) == 0) {
        /* one id */
        npy_intp one = 1;
        PyArray_Dims shape = {&one, 1};
        PyArrayObject *r = (PyArrayObject *)PyArray_Newshape(a, &shape, NPY_CORDER);
        Py_DECREF(a);
        if (!r)
            return NULL;
        a = r;
    }
    char kind = PyArray_DESCR(a)->kind;
    if (!(kind == 'i' || kind == 'u' || (kind == 'f' && PyArray_SIZE(a) == 0))) {
        PyErr_Format(PyExc_TypeError, "%s: expected integer ids, got dtype %R", name,
                     (PyObject *)PyArray_DESCR(a));
        Py_DECREF(a);
        return NULL;
    }
    if (PyArray_NDIM(a) != 1) {
        PyObject *s = shape_text(a);
        if (s)
            PyErr_Format(PyExc_ValueError, "%s: expected a 1-D sequence of ids, got shape %U", name, s);
        Py_XDECREF(s);
        Py_DECREF(a);
        return NULL;
    }
    PyArrayObject *i64 = (PyArrayObject *)PyArray_FromArray(a, PyArray_DescrFromType(NPY_INT64),
                                                            NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED |
                                                                NPY_ARRAY_FORCECAST);
    Py_DECREF(a);
    if (!i64)
        return NULL;
    npy_intp n = PyArray_DIM(i64, 0);
    PyArrayObject *u = (PyArrayObject *)PyArray_SimpleNew(1, &n, NPY_UINT32);
    if (!u) {
        Py_DECREF(i64);
        return NULL;
    }
    const int64_t *src = PyArray_DATA(i64);
    uint32_t *dst = PyArray_DATA(u);
    for (npy_intp i = 0; i < n; i++) {
        if (src[i] < 0 || src[i] >= (int64_t)UINT32_MAX) {
            PyErr_Format(PyExc_ValueError, "%s[%ld]: id %lld is out of range", name, (long)i,
                         (long long)src[i]);
            Py_DECREF(i64);
            Py_DECREF(u);
            return NULL;
        }
        dst[i] = (uint32_t)src[i];
    }
    Py_DECREF(i64);
    return u;
}

int ffdpy_limits(PyObject *obj, ffd_limits *limits, int *given)
{
    memset(limits, 0, sizeof *limits);
    *given = 0;
    if (!obj || obj == Py_None)
        return 0;
    if (!PyDict_Check(obj)) {
        PyErr_SetString(PyExc_TypeError,
                        "limits: expected None or a dict with max_memory, max_work, unlimited");
        return -1;
    }
    PyObject *key, *value;
    Py_ssize_t pos = 0;
    while (PyDict_Next(obj, &pos, &key, &value)) {
        const char *k = PyUnicode_Check(key) ? PyUnicode_AsUTF8(key) : NULL;
        if (!k) {
            PyErr_Clear();
            PyErr_SetString(PyExc_ValueError, "limits: keys are max_memory, max_work, unlimited");
            return -1;
        }
        if (!strcmp(k, "max_memory")) {
            size_t v = PyLong_AsSize_t(value);
            if (v == (size_t)-1 && PyErr_Occurred())
                return -1;
            limits->max_memory = v;
        } else if (!strcmp(k, "max_work")) {
            double v = PyFloat_AsDouble(value);
            if (v == -1.0 && PyErr_Occurred())
                return -1;
            limits->max_work = v;
        } else if (!strcmp(k, "unlimited")) {
            int v = PyObject_IsTrue(value);
            if (v < 0)
                return -1;
            limits->unlimited = v;
        } else {
            PyErr_Format(PyExc_ValueError,
                         "limits: unknown key %R (keys: max_memory, max_work, unlimited)", key);
            return -1;
        }
    }
    *given = 1;
    return 0;
}

/* ---------- the module ---------- */

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, "ffdkit._ffd",
    "The compiled core of ffdkit: libffd's meshes, rigs and deformers over numpy arrays.\n"
    "Use the ffdkit package; this module's types are its bases.",
    -1, NULL, NULL, NULL, NULL, NULL};

/* Error subclasses: the status, the class name, the Python base besides Error. */
static int add_errors(PyObject *m)
{
    static const struct {
        ffd_status st;
        const char *name;
        const char *doc;
    } table[] = {
        {FFD_ERR_IO, "ffdkit.FileError", "A file could not be opened, read, written or renamed."},
        {FFD_ERR_PARSE, "ffdkit.ParseError", "Malformed input (the message names the file and line, byte or key)."},
        {FFD_ERR_INVALID, "ffdkit.InvalidError", "An argument or rig value is invalid."},
        {FFD_ERR_RANGE, "ffdkit.RangeError", "An index is out of range."},
        {FFD_ERR_NONFINITE, "ffdkit.NonFiniteError", "NaN or Inf where a finite number is required."},
        {FFD_ERR_NOMEM, "ffdkit.NoMemoryError", "An allocation failed or a size overflowed."},
        {FFD_ERR_NUMERIC, "ffdkit.NumericError", "A numerical routine failed."},
        {FFD_ERR_UNSUPPORTED, "ffdkit.UnsupportedError", "A valid request the method or build cannot do."},
    };
    PyObject *bases_py[] = {PyExc_OSError,     PyExc_ValueError, PyExc_ValueError,
                            PyExc_IndexError,  PyExc_ValueError, PyExc_MemoryError,
                            PyExc_ArithmeticError, PyExc_NotImplementedError};
    error_classes[0] = PyErr_NewExceptionWithDoc(
        "ffdkit.Error",
        "An error the library reported. .status is the library's status name (\"parse error\", ...);\n"
        "str(e) is the library's message, which names the file and line, byte offset or key.",
        PyExc_Exception, NULL);
    if (!error_classes[0] || PyModule_AddObjectRef(m, "Error", error_classes[0]) < 0)
        return -1;
    for (size_t i = 0; i < sizeof table / sizeof *table; i++) {
        PyObject *bases = PyTuple_Pack(2, error_classes[0], bases_py[i]);
        if (!bases)
            return -1;
        PyObject *cls = PyErr_NewExceptionWithDoc(table[i].name, table[i].doc, bases, NULL);
        Py_DECREF(bases);
        if (!cls)
            return -1;
        error_classes[table[i].st] = cls;
        if (PyModule_AddObjectRef(m, strchr(table[i].name, '.') + 1, cls) < 0)
            return -1;
    }
    return 0;
}

PyMODINIT_FUNC PyInit__ffd(void);
PyMODINIT_FUNC PyInit__ffd(void)
{
    import_array();
    PyObject *m = PyModule_Create(&moduledef);
    if (!m)
        return NULL;
    if (add_errors(m) < 0 || ffdpy_init_mesh(m) < 0 || ffdpy_init_rig(m) < 0 ||
        ffdpy_init_deformer(m) < 0 || ffdpy_init_distributed(m) < 0 ||
        PyModule_AddIntConstant(m, "VERSION_MAJOR", FFD_VERSION_MAJOR) < 0 ||
        PyModule_AddIntConstant(m, "VERSION_MINOR", FFD_VERSION_MINOR) < 0 ||
        PyModule_AddIntConstant(m, "VERSION_PATCH", FFD_VERSION_PATCH) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
