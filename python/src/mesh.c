/* ffdkit._ffd.Mesh: an ffd_mesh with numpy views of its arrays. The views'
 * base is the mesh's store (_MeshStore, which owns the ffd_mesh), so a view
 * keeps the memory it shows alive; an in-place change that may reallocate
 * the mesh (a rig applied) works on a copy when views are alive. */
#include "ffdpy.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

/* ---------- _MeshStore ---------- */

static void store_dealloc(ffdpy_MeshStore *s)
{
    ffd_mesh_destroy(s->mesh);
    Py_TYPE(s)->tp_free((PyObject *)s);
}

PyTypeObject ffdpy_MeshStoreType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "ffdkit._ffd._MeshStore",
    .tp_basicsize = sizeof(ffdpy_MeshStore),
    .tp_dealloc = (destructor)store_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Owns one ffd_mesh; the base of Mesh's array views.",
};

static ffdpy_MeshStore *store_new(ffd_mesh *mesh)
{
    ffdpy_MeshStore *s = PyObject_New(ffdpy_MeshStore, &ffdpy_MeshStoreType);
    if (!s) {
        ffd_mesh_destroy(mesh);
        return NULL;
    }
    s->mesh = mesh;
    return s;
}

/* ---------- formats ---------- */

static const char *const format_names[] = {NULL,  "obj", "ply", "off", "stl", "gltf",
                                           "vtk", "vtu", "msh", "su2", "xyz", "npy"};
#define FORMAT_LIST "obj, ply, off, stl, gltf, glb, vtk, vtu, msh, su2, xyz, csv, npy"

/* format: None or a name ("obj", "ply", "off", "stl", "gltf", "glb"); *encoding
 * becomes BINARY_LE for "glb". */
static int parse_format(PyObject *obj, ffd_format *format, ffd_encoding *encoding)
{
    *format = FFD_FORMAT_AUTO;
    if (!obj || obj == Py_None)
        return 0;
    const char *name = PyUnicode_Check(obj) ? PyUnicode_AsUTF8(obj) : NULL;
    if (!name) {
        PyErr_Clear();
        PyErr_SetString(PyExc_TypeError, "format: expected None or a format name (" FORMAT_LIST ")");
        return -1;
    }
    if (!strcmp(name, "csv")) {
        *format = FFD_FORMAT_XYZ;
        return 0;
    }
    for (int f = FFD_FORMAT_OBJ; f <= FFD_FORMAT_NPY; f++) {
        if (!strcmp(name, format_names[f])) {
            *format = (ffd_format)f;
            return 0;
        }
    }
    if (!strcmp(name, "glb")) {
        *format = FFD_FORMAT_GLTF;
        if (encoding)
            *encoding = FFD_ENCODING_BINARY_LE;
        return 0;
    }
    PyErr_Format(PyExc_ValueError, "format: unknown format %R (" FORMAT_LIST ")", obj);
    return -1;
}

static int parse_encoding(PyObject *obj, ffd_encoding *encoding)
{
    if (!obj || obj == Py_None)
        return 0;
    const char *name = PyUnicode_Check(obj) ? PyUnicode_AsUTF8(obj) : NULL;
    if (name && !strcmp(name, "ascii"))
        *encoding = FFD_ENCODING_ASCII;
    else if (name && (!strcmp(name, "binary") || !strcmp(name, "binary_little_endian")))
        *encoding = FFD_ENCODING_BINARY_LE;
    else if (name && !strcmp(name, "binary_big_endian"))
        *encoding = FFD_ENCODING_BINARY_BE;
    else if (name && !strcmp(name, "base64"))
        *encoding = FFD_ENCODING_BASE64;
    else if (name && !strcmp(name, "raw"))
        *encoding = FFD_ENCODING_RAW;
    else {
        PyErr_Clear();
        PyErr_Format(PyExc_ValueError,
                     "encoding: expected None, 'ascii', 'binary', 'binary_little_endian', "
                     "'binary_big_endian', 'base64' or 'raw', got %R", obj);
        return -1;
    }
    return 0;
}

/* ---------- Mesh ---------- */

static PyObject *mesh_wrap(PyTypeObject *cls, ffd_mesh *mesh)
{
    ffdpy_MeshStore *store = store_new(mesh);
    if (!store)
        return NULL;
    ffdpy_Mesh *m = (ffdpy_Mesh *)cls->tp_alloc(cls, 0);
    if (!m) {
        Py_DECREF(store);
        return NULL;
    }
    m->store = store;
    return (PyObject *)m;
}

static int busy(ffdpy_Mesh *m)
{
    if (m->changing) {
        PyErr_SetString(PyExc_RuntimeError, "the mesh is being changed by another thread");
        return 1;
    }
    return 0;
}

ffd_mesh *ffdpy_mesh_for_change(ffdpy_Mesh *m)
{
    if (busy(m))
        return NULL;
    if (Py_REFCNT(m->store) > 1) {
        /* views (or a call in another thread) hold the store: change a copy */
        const ffd_mesh *old = m->store->mesh;
        ffd_mesh *copy = NULL;
        ffd_error err = {{0}};
        ffd_status st;
        ffd_format f = ffd_mesh_source_format(old);
        if (f == FFD_FORMAT_AUTO) {
            st = ffd_mesh_create(ffd_mesh_positions(old), ffd_mesh_vertex_count(old),
                                 ffd_mesh_face_offsets(old), ffd_mesh_face_indices(old),
                                 ffd_mesh_face_count(old), &copy, &err);
        } else {
            ffd_write_options wo = {f, FFD_ENCODING_SAME, 0};
            unsigned char *data = NULL;
            size_t size = 0;
            st = ffd_mesh_write_memory(old, &wo, &data, &size, &err);
            if (!st)
                st = ffd_mesh_read_memory(data, size, f, NULL, &copy, &err);
            ffd_free(data);
        }
        if (st) {
            ffdpy_raise(st, &err, NULL);
            return NULL;
        }
        ffdpy_MeshStore *s = store_new(copy);
        if (!s)
            return NULL;
        Py_SETREF(m->store, s);
    }
    m->changing = 1;
    return m->store->mesh;
}

void ffdpy_mesh_end_change(ffdpy_Mesh *m) { m->changing = 0; }

int ffdpy_mesh_or_points(PyObject *obj, const char *name, const ffd_mesh **mesh, ffd_mesh **owned,
                         PyObject **keep)
{
    *mesh = NULL;
    *owned = NULL;
    *keep = NULL;
    if (PyObject_TypeCheck(obj, &ffdpy_MeshType)) {
        ffdpy_Mesh *m = (ffdpy_Mesh *)obj;
        if (busy(m))
            return -1;
        *mesh = m->store->mesh;
        *keep = Py_NewRef((PyObject *)m->store);
        return 0;
    }
    PyArrayObject *p = ffdpy_points(obj, name);
    if (!p)
        return -1;
    ffd_error err = {{0}};
    ffd_status st = ffd_mesh_create(PyArray_DATA(p), (size_t)PyArray_DIM(p, 0), NULL, NULL, 0, owned, &err);
    Py_DECREF(p);
    if (st) {
        ffdpy_raise(st, &err, NULL);
        return -1;
    }
    *mesh = *owned;
    return 0;
}

/* faces: None, an (F, k) integer array, or a sequence of index sequences. */
static int parse_faces(PyObject *faces, size_t vertex_count, uint32_t **offsets, uint32_t **indices,
                       size_t *face_count)
{
    *offsets = NULL;
    *indices = NULL;
    *face_count = 0;
    if (faces == Py_None)
        return 0;
    PyObject *seq = PyArray_Check(faces) ? NULL : PySequence_Fast(faces, "faces: expected an (F, k) "
                                                                         "array or a list of index sequences");
    if (!seq && !PyArray_Check(faces))
        return -1;
    Py_ssize_t F = seq ? PySequence_Fast_GET_SIZE(seq) : (PyArray_NDIM((PyArrayObject *)faces) >= 1 ?
                                                               PyArray_DIM((PyArrayObject *)faces, 0) : -1);
    if (F < 0) {
        PyErr_SetString(PyExc_ValueError, "faces: expected an (F, k) array or a list of index sequences");
        return -1;
    }
    PyArrayObject **rows = PyMem_Calloc((size_t)F + 1, sizeof *rows);
    uint32_t *off = PyMem_Malloc(((size_t)F + 1) * sizeof *off);
    int rc = -1;
    size_t total = 0;
    if (!rows || !off) {
        PyErr_NoMemory();
        goto done;
    }
    if (!seq) {
        PyArrayObject *a = (PyArrayObject *)faces;
        if (PyArray_NDIM(a) != 2) {
            PyErr_SetString(PyExc_ValueError, "faces: expected an (F, k) array");
            goto done;
        }
    }
    off[0] = 0;
    for (Py_ssize_t f = 0; f < F; f++) {
        PyObject *item = seq ? Py_NewRef(PySequence_Fast_GET_ITEM(seq, f))
                             : PySequence_GetItem(faces, f);
        if (!item)
            goto done;
        char name[48];
        snprintf(name, sizeof name, "faces[%ld]", (long)f);
        rows[f] = ffdpy_ids(item, name);
        Py_DECREF(item);
        if (!rows[f])
            goto done;
        total += (size_t)PyArray_DIM(rows[f], 0);
        if (total > UINT32_MAX) {
            PyErr_SetString(PyExc_ValueError, "faces: more than 2^32 - 1 corners");
            goto done;
        }
        off[f + 1] = (uint32_t)total;
    }
    uint32_t *idx = PyMem_Malloc((total ? total : 1) * sizeof *idx);
    if (!idx) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t f = 0; f < F; f++) {
        const uint32_t *r = PyArray_DATA(rows[f]);
        for (npy_intp c = 0; c < PyArray_DIM(rows[f], 0); c++) {
            if (r[c] >= vertex_count) {
                PyErr_Format(PyExc_IndexError, "faces[%ld][%ld]: vertex %lu out of range (%lu vertices)",
                             (long)f, (long)c, (unsigned long)r[c], (unsigned long)vertex_count);
                PyMem_Free(idx);
                goto done;
            }
            idx[off[f] + c] = r[c];
        }
    }
    *offsets = off;
    off = NULL;
    *indices = idx;
    *face_count = (size_t)F;
    rc = 0;
done:
    if (rows)
        for (Py_ssize_t f = 0; f < F; f++)
            Py_XDECREF(rows[f]);
    PyMem_Free(rows);
    PyMem_Free(off);
    Py_XDECREF(seq);
    return rc;
}

/* Mesh(points, cells=(types uint8, offsets uint64, indices uint32)): the
 * compiled form; ffdkit.Mesh converts meshio-style cell blocks to it. */
static PyObject *mesh_from_cells(PyTypeObject *cls, PyObject *points, PyObject *faces,
                                 PyObject *cells)
{
    if (faces != Py_None) {
        PyErr_SetString(PyExc_ValueError, "Mesh: give faces or cells, not both (the faces of a "
                                          "mesh with cells are derived from them)");
        return NULL;
    }
    PyObject *t = NULL, *o = NULL, *x = NULL;
    if (!PyArg_ParseTuple(cells, "OOO:cells", &t, &o, &x))
        return NULL;
    PyArrayObject *p = ffdpy_points(points, "points");
    PyArrayObject *types = (PyArrayObject *)PyArray_FROMANY(t, NPY_UINT8, 1, 1, NPY_ARRAY_IN_ARRAY);
    PyArrayObject *off = types ? (PyArrayObject *)PyArray_FROMANY(o, NPY_UINT64, 1, 1, NPY_ARRAY_IN_ARRAY) : NULL;
    PyArrayObject *idx = off ? (PyArrayObject *)PyArray_FROMANY(x, NPY_UINT32, 1, 1, NPY_ARRAY_IN_ARRAY) : NULL;
    PyObject *result = NULL;
    if (p && types && off && idx) {
        size_t nc = (size_t)PyArray_DIM(types, 0);
        if ((size_t)PyArray_DIM(off, 0) != nc + 1) {
            PyErr_Format(PyExc_ValueError, "cells: offsets must have %zu entries (cells + 1), not %zd",
                         nc + 1, (Py_ssize_t)PyArray_DIM(off, 0));
        } else if (((const uint64_t *)PyArray_DATA(off))[nc] > (uint64_t)PyArray_DIM(idx, 0)) {
            PyErr_SetString(PyExc_ValueError, "cells: offsets run past the end of the indices");
        } else {
            ffd_mesh *mesh = NULL;
            ffd_error err = {{0}};
            ffd_status st = ffd_mesh_create_cells(PyArray_DATA(p), (size_t)PyArray_DIM(p, 0),
                                                  PyArray_DATA(types), PyArray_DATA(off),
                                                  PyArray_DATA(idx), nc, &mesh, &err);
            result = st ? ffdpy_raise(st, &err, NULL) : mesh_wrap(cls, mesh);
        }
    }
    Py_XDECREF(p);
    Py_XDECREF(types);
    Py_XDECREF(off);
    Py_XDECREF(idx);
    return result;
}

static PyObject *Mesh_new(PyTypeObject *cls, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"points", "faces", "cells", NULL};
    PyObject *points, *faces = Py_None, *cells = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O|OO:Mesh", kw, &points, &faces, &cells))
        return NULL;
    if (cells != Py_None)
        return mesh_from_cells(cls, points, faces, cells);
    PyArrayObject *p = ffdpy_points(points, "points");
    if (!p)
        return NULL;
    uint32_t *off, *idx;
    size_t F;
    if (parse_faces(faces, (size_t)PyArray_DIM(p, 0), &off, &idx, &F) < 0) {
        Py_DECREF(p);
        return NULL;
    }
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    ffd_status st = ffd_mesh_create(PyArray_DATA(p), (size_t)PyArray_DIM(p, 0), off, idx, F, &mesh, &err);
    Py_DECREF(p);
    PyMem_Free(off);
    PyMem_Free(idx);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    return mesh_wrap(cls, mesh);
}

static void Mesh_dealloc(ffdpy_Mesh *m)
{
    if (m->weakrefs)
        PyObject_ClearWeakRefs((PyObject *)m);
    Py_XDECREF(m->store);
    Py_TYPE(m)->tp_free((PyObject *)m);
}

/* Reads a whole file with the GIL released: FFD_ERR_IO naming path. */
static ffd_status slurp(const char *path, unsigned char **data, size_t *size, ffd_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err->message, sizeof err->message, "%s: %s", path, strerror(errno));
        return FFD_ERR_IO;
    }
    size_t cap = 1 << 16, n = 0;
    unsigned char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        unsigned char *b = realloc(buf, cap * 2);
        if (!b) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = b;
        cap *= 2;
    }
    int bad = ferror(f);
    fclose(f);
    if (!buf) {
        snprintf(err->message, sizeof err->message, "%s: out of memory", path);
        return FFD_ERR_NOMEM;
    }
    if (bad) {
        free(buf);
        snprintf(err->message, sizeof err->message, "%s: read error", path);
        return FFD_ERR_IO;
    }
    *data = buf;
    *size = n;
    return FFD_OK;
}

static PyObject *Mesh_read(PyTypeObject *cls, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"path", "format", NULL};
    PyObject *path_obj, *fmt_obj = Py_None, *path_bytes = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O|O:read", kw, &path_obj, &fmt_obj))
        return NULL;
    ffd_format format;
    ffd_encoding enc = FFD_ENCODING_SAME;
    if (parse_format(fmt_obj, &format, &enc) < 0 || !PyUnicode_FSConverter(path_obj, &path_bytes))
        return NULL;
    const char *path = PyBytes_AS_STRING(path_bytes);
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    if (format == FFD_FORMAT_AUTO) {
        st = ffd_mesh_read(path, &mesh, &err);
    } else {
        unsigned char *data = NULL;
        size_t size = 0;
        st = slurp(path, &data, &size, &err);
        if (!st)
            st = ffd_mesh_read_memory(data, size, format, path, &mesh, &err);
        free(data);
    }
    Py_END_ALLOW_THREADS
    Py_DECREF(path_bytes);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    return mesh_wrap(cls, mesh);
}

static PyObject *Mesh_from_bytes(PyTypeObject *cls, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"data", "format", "name", NULL};
    Py_buffer buf;
    PyObject *fmt_obj;
    const char *name = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "y*O|z:from_bytes", kw, &buf, &fmt_obj, &name))
        return NULL;
    ffd_format format;
    if (parse_format(fmt_obj, &format, NULL) < 0 || format == FFD_FORMAT_AUTO) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "format: required (obj, ply, off, stl, gltf, glb)");
        PyBuffer_Release(&buf);
        return NULL;
    }
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_mesh_read_memory(buf.buf, (size_t)buf.len, format, name, &mesh, &err);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&buf);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    return mesh_wrap(cls, mesh);
}

static PyObject *Mesh_write(ffdpy_Mesh *m, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"path", "format", "encoding", "compress", NULL};
    PyObject *path_obj, *fmt_obj = Py_None, *enc_obj = Py_None, *path_bytes = NULL;
    int compress = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O|OOp:write", kw, &path_obj, &fmt_obj, &enc_obj,
                                     &compress))
        return NULL;
    ffd_write_options wo = {FFD_FORMAT_AUTO, FFD_ENCODING_SAME, compress};
    if (parse_format(fmt_obj, &wo.format, &wo.encoding) < 0 || parse_encoding(enc_obj, &wo.encoding) < 0 ||
        busy(m) || !PyUnicode_FSConverter(path_obj, &path_bytes))
        return NULL;
    ffdpy_MeshStore *store = (ffdpy_MeshStore *)Py_NewRef(m->store);
    ffd_error err = {{0}};
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_mesh_write(store->mesh, PyBytes_AS_STRING(path_bytes), &wo, &err);
    Py_END_ALLOW_THREADS
    Py_DECREF(store);
    Py_DECREF(path_bytes);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    Py_RETURN_NONE;
}

static PyObject *Mesh_to_bytes(ffdpy_Mesh *m, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"format", "encoding", "compress", NULL};
    PyObject *fmt_obj = Py_None, *enc_obj = Py_None;
    int compress = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "|OOp:to_bytes", kw, &fmt_obj, &enc_obj, &compress))
        return NULL;
    ffd_write_options wo = {FFD_FORMAT_AUTO, FFD_ENCODING_SAME, compress};
    if (parse_format(fmt_obj, &wo.format, &wo.encoding) < 0 || parse_encoding(enc_obj, &wo.encoding) < 0 ||
        busy(m))
        return NULL;
    if (wo.format == FFD_FORMAT_AUTO)
        wo.format = ffd_mesh_source_format(m->store->mesh);
    if (wo.format == FFD_FORMAT_AUTO) {
        PyErr_SetString(PyExc_ValueError, "format: required for a mesh made from arrays "
                                          "(" FORMAT_LIST ")");
        return NULL;
    }
    ffdpy_MeshStore *store = (ffdpy_MeshStore *)Py_NewRef(m->store);
    unsigned char *data = NULL;
    size_t size = 0;
    ffd_error err = {{0}};
    ffd_status st;
    Py_BEGIN_ALLOW_THREADS
    st = ffd_mesh_write_memory(store->mesh, &wo, &data, &size, &err);
    Py_END_ALLOW_THREADS
    Py_DECREF(store);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    PyObject *b = PyBytes_FromStringAndSize((const char *)data, (Py_ssize_t)size);
    ffd_free(data);
    return b;
}

/* A read-only view of n rows of `cols` items at data, based on the store. */
static PyObject *view(ffdpy_Mesh *m, const void *data, size_t n, int cols, int type)
{
    npy_intp dims[2] = {(npy_intp)n, cols};
    static const double empty_d[3];
    static const uint32_t empty_u[3];
    if (!data)
        data = type == NPY_DOUBLE ? (const void *)empty_d : (const void *)empty_u;
    PyObject *a = PyArray_New(&PyArray_Type, cols ? 2 : 1, dims, type, NULL, (void *)data, 0,
                              NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED, NULL);
    if (!a)
        return NULL;
    if (PyArray_SetBaseObject((PyArrayObject *)a, Py_NewRef((PyObject *)m->store)) < 0) {
        Py_DECREF(a);
        return NULL;
    }
    return a;
}

static PyObject *Mesh_get_points(ffdpy_Mesh *m, void *c)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    return view(m, ffd_mesh_positions(mesh), ffd_mesh_vertex_count(mesh), 3, NPY_DOUBLE);
}

static PyObject *Mesh_set_points(ffdpy_Mesh *m, PyObject *args, PyObject *kwds)
{
    static char *kw[] = {"points", "jacobians", NULL};
    PyObject *points, *jac_obj = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O|O:set_points", kw, &points, &jac_obj))
        return NULL;
    if (busy(m))
        return NULL;
    size_t n = ffd_mesh_vertex_count(m->store->mesh);
    PyArrayObject *p = ffdpy_points(points, "points");
    if (!p)
        return NULL;
    if ((size_t)PyArray_DIM(p, 0) != n) {
        PyErr_Format(PyExc_ValueError, "points: expected shape (%lu, 3), got (%ld, 3)", (unsigned long)n,
                     (long)PyArray_DIM(p, 0));
        Py_DECREF(p);
        return NULL;
    }
    PyArrayObject *J = NULL;
    if (jac_obj != Py_None) {
        npy_intp d3[3] = {(npy_intp)n, 3, 3};
        PyArrayObject *a = (PyArrayObject *)PyArray_FROM_O(jac_obj);
        int flat = a && PyArray_NDIM(a) == 2;
        Py_XDECREF(a);
        if (!a) {
            Py_DECREF(p);
            return NULL;
        }
        npy_intp d2[2] = {(npy_intp)n, 9};
        J = flat ? ffdpy_doubles(jac_obj, "jacobians", 2, d2) : ffdpy_doubles(jac_obj, "jacobians", 3, d3);
        if (!J) {
            Py_DECREF(p);
            return NULL;
        }
    }
    ffd_error err = {{0}};
    ffd_status st = ffd_mesh_set_positions(m->store->mesh, PyArray_DATA(p), J ? PyArray_DATA(J) : NULL, &err);
    Py_DECREF(p);
    Py_XDECREF(J);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    Py_RETURN_NONE;
}

static int Mesh_assign_points(ffdpy_Mesh *m, PyObject *value, void *c)
{
    if (!value) {
        PyErr_SetString(PyExc_AttributeError, "points cannot be deleted");
        return -1;
    }
    PyObject *args = PyTuple_Pack(1, value);
    if (!args)
        return -1;
    PyObject *r = Mesh_set_points(m, args, NULL);
    Py_DECREF(args);
    if (!r)
        return -1;
    Py_DECREF(r);
    return 0;
}

static PyObject *Mesh_get_face_offsets(ffdpy_Mesh *m, void *c)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    static const uint32_t zero = 0;
    const uint32_t *off = ffd_mesh_face_offsets(mesh);
    return view(m, off ? off : &zero, ffd_mesh_face_count(mesh) + 1, 0, NPY_UINT32);
}

static PyObject *Mesh_get_face_indices(ffdpy_Mesh *m, void *c)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    const uint32_t *off = ffd_mesh_face_offsets(mesh);
    size_t n = off ? off[ffd_mesh_face_count(mesh)] : 0;
    return view(m, ffd_mesh_face_indices(mesh), n, 0, NPY_UINT32);
}

static PyObject *Mesh_get_normals(ffdpy_Mesh *m, void *c)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    return view(m, ffd_mesh_normals(mesh), ffd_mesh_normal_count(mesh), 3, NPY_DOUBLE);
}

static PyObject *Mesh_get_format(ffdpy_Mesh *m, void *c)
{
    ffd_format f = ffd_mesh_source_format(m->store->mesh);
    if (f <= FFD_FORMAT_AUTO || f > FFD_FORMAT_NPY)
        Py_RETURN_NONE;
    return PyUnicode_FromString(format_names[f]);
}

static PyObject *Mesh_get_cell_types(ffdpy_Mesh *m, void *c)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    static const uint8_t none = 0;
    const uint8_t *t = ffd_mesh_cell_types(mesh);
    return view(m, t ? t : &none, ffd_mesh_cell_count(mesh), 0, NPY_UINT8);
}

static PyObject *Mesh_get_cell_offsets(ffdpy_Mesh *m, void *c)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    static const uint64_t zero = 0;
    const uint64_t *o = ffd_mesh_cell_offsets(mesh);
    return view(m, o ? o : &zero, ffd_mesh_cell_count(mesh) + 1, 0, NPY_UINT64);
}

static PyObject *Mesh_get_cell_indices(ffdpy_Mesh *m, void *c)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    const uint64_t *o = ffd_mesh_cell_offsets(mesh);
    static const uint32_t none = 0;
    const uint32_t *x = ffd_mesh_cell_indices(mesh);
    return view(m, x ? x : &none, o ? (size_t)o[ffd_mesh_cell_count(mesh)] : 0, 0, NPY_UINT32);
}

static PyObject *Mesh_get_face_cells(ffdpy_Mesh *m, void *c)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    const uint32_t *fc = ffd_mesh_face_cells(mesh);
    if (!fc)
        Py_RETURN_NONE;
    return view(m, fc, ffd_mesh_face_count(mesh), 0, NPY_UINT32);
}

static PyObject *Mesh_get_is_volume(ffdpy_Mesh *m, void *c)
{
    return PyBool_FromLong(ffd_mesh_is_volume(m->store->mesh));
}

/* [(name, association, values (count, components) float64 copy), ...] */
static PyObject *Mesh_fields(ffdpy_Mesh *m, PyObject *noargs)
{
    if (busy(m))
        return NULL;
    const ffd_mesh *mesh = m->store->mesh;
    size_t n = ffd_mesh_field_count(mesh);
    PyObject *list = PyList_New((Py_ssize_t)n);
    for (size_t i = 0; list && i < n; i++) {
        ffd_field_info f;
        ffd_error err = {{0}};
        ffd_status st = ffd_mesh_field_get(mesh, i, &f, &err);
        if (st) {
            Py_DECREF(list);
            return ffdpy_raise(st, &err, NULL);
        }
        npy_intp dims[2] = {(npy_intp)f.count, (npy_intp)f.components};
        PyObject *a = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
        if (!a) {
            Py_DECREF(list);
            return NULL;
        }
        if (f.count)
            memcpy(PyArray_DATA((PyArrayObject *)a), f.values,
                   f.count * f.components * sizeof(double));
        PyObject *item = Py_BuildValue("(ssN)", f.name,
                                       f.association == FFD_FIELD_POINT ? "point" : "cell", a);
        if (!item) {
            Py_DECREF(list);
            return NULL;
        }
        PyList_SET_ITEM(list, (Py_ssize_t)i, item);
    }
    return list;
}

static PyObject *Mesh_get_vertex_count(ffdpy_Mesh *m, void *c)
{
    return PyLong_FromSize_t(ffd_mesh_vertex_count(m->store->mesh));
}

static PyObject *Mesh_get_face_count(ffdpy_Mesh *m, void *c)
{
    return PyLong_FromSize_t(ffd_mesh_face_count(m->store->mesh));
}

static PyObject *Mesh_info(ffdpy_Mesh *m, PyObject *noargs)
{
    if (busy(m))
        return NULL;
    ffd_mesh_info info;
    ffd_error err = {{0}};
    ffd_status st = ffd_mesh_compute_info(m->store->mesh, &info, &err);
    if (st)
        return ffdpy_raise(st, &err, NULL);
    return Py_BuildValue("{s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:O,s:(ddd),s:(ddd)}",
                         "vertex_count", (Py_ssize_t)info.vertex_count, "face_count",
                         (Py_ssize_t)info.face_count, "corner_count", (Py_ssize_t)info.corner_count,
                         "welded_vertex_count", (Py_ssize_t)info.welded_vertex_count, "edge_count",
                         (Py_ssize_t)info.edge_count, "boundary_edge_count",
                         (Py_ssize_t)info.boundary_edge_count, "nonmanifold_edge_count",
                         (Py_ssize_t)info.nonmanifold_edge_count, "normal_count",
                         (Py_ssize_t)info.normal_count, "texcoord_count", (Py_ssize_t)info.texcoord_count,
                         "closed", info.closed ? Py_True : Py_False, "bbox_min", info.bbox_min[0],
                         info.bbox_min[1], info.bbox_min[2], "bbox_max", info.bbox_max[0], info.bbox_max[1],
                         info.bbox_max[2]);
}

static PyMethodDef Mesh_methods[] = {
    {"read", (PyCFunction)(void (*)(void))Mesh_read, METH_VARARGS | METH_KEYWORDS | METH_CLASS,
     "read(path, format=None) -> Mesh\n\nReads a mesh file (OBJ, PLY, OFF, STL, glTF/GLB) with the GIL "
     "released; format overrides the extension."},
    {"from_bytes", (PyCFunction)(void (*)(void))Mesh_from_bytes, METH_VARARGS | METH_KEYWORDS | METH_CLASS,
     "from_bytes(data, format, name=None) -> Mesh\n\nReads a mesh from a bytes-like object; name names it "
     "in error messages."},
    {"write", (PyCFunction)(void (*)(void))Mesh_write, METH_VARARGS | METH_KEYWORDS,
     "write(path, format=None, encoding=None)\n\nWrites the mesh atomically (GIL released); in its own "
     "format every byte of an untouched value is kept."},
    {"to_bytes", (PyCFunction)(void (*)(void))Mesh_to_bytes, METH_VARARGS | METH_KEYWORDS,
     "to_bytes(format=None, encoding=None) -> bytes\n\nThe file the mesh would write, in memory "
     "(format: the source's when None)."},
    {"set_points", (PyCFunction)(void (*)(void))Mesh_set_points, METH_VARARGS | METH_KEYWORDS,
     "set_points(points, jacobians=None)\n\nReplaces the positions ((N, 3), finite). Normals and "
     "tangents follow: carried by jacobians ((N, 3, 3) or (N, 9), d(x')/d(x) per vertex) when given, "
     "else recomputed from the faces (ffd_mesh_set_positions)."},
    {"_fields", (PyCFunction)Mesh_fields, METH_NOARGS,
     "_fields() -> [(name, 'point' | 'cell', values (count, components))]: the file's point and "
     "cell data (copies)."},
    {"info", (PyCFunction)Mesh_info, METH_NOARGS,
     "info() -> dict\n\nCounts, bounding box and edge topology (ffd_mesh_compute_info)."},
    {NULL, NULL, 0, NULL}};

static PyGetSetDef Mesh_getset[] = {
    {"points", (getter)Mesh_get_points, (setter)Mesh_assign_points,
     "(N, 3) float64 read-only view of the positions (its base keeps the mesh's memory alive). "
     "Assigning sets them (normals recomputed from the faces; use set_points to carry them by "
     "Jacobians).",
     NULL},
    {"face_offsets", (getter)Mesh_get_face_offsets, NULL,
     "(F + 1,) uint32 read-only view: face f has the corners face_indices[face_offsets[f]:face_offsets[f+1]].",
     NULL},
    {"face_indices", (getter)Mesh_get_face_indices, NULL, "uint32 read-only view of every face's vertex ids.",
     NULL},
    {"normals", (getter)Mesh_get_normals, NULL, "(K, 3) float64 read-only view of the file's normals.", NULL},
    {"format", (getter)Mesh_get_format, NULL,
     "The source format ('obj', 'ply', 'off', 'stl', 'gltf'), None for a mesh made from arrays.", NULL},
    {"cell_types", (getter)Mesh_get_cell_types, NULL,
     "(C,) uint8 read-only view: each cell's VTK type (empty for a mesh without cells).", NULL},
    {"cell_offsets", (getter)Mesh_get_cell_offsets, NULL,
     "(C + 1,) uint64 read-only view: cell c has the nodes cell_indices[cell_offsets[c]:cell_offsets[c+1]].",
     NULL},
    {"cell_indices", (getter)Mesh_get_cell_indices, NULL, "uint32 read-only view of every cell's node ids.",
     NULL},
    {"face_cells", (getter)Mesh_get_face_cells, NULL,
     "(F,) uint32 read-only view: the cell each face belongs to (None without cells).", NULL},
    {"is_volume", (getter)Mesh_get_is_volume, NULL,
     "True when the mesh has a 3D cell (its faces are then its boundary surface).", NULL},
    {"vertex_count", (getter)Mesh_get_vertex_count, NULL, "The number of vertices.", NULL},
    {"face_count", (getter)Mesh_get_face_count, NULL, "The number of faces.", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

PyTypeObject ffdpy_MeshType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "ffdkit._ffd.Mesh",
    .tp_basicsize = sizeof(ffdpy_Mesh),
    .tp_dealloc = (destructor)Mesh_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE,
    .tp_doc = "Mesh(points, faces=None)\n\nA polygon mesh (libffd's ffd_mesh): points (N, 3); faces an "
              "(F, k) integer array or a list of index sequences.",
    .tp_weaklistoffset = offsetof(ffdpy_Mesh, weakrefs),
    .tp_methods = Mesh_methods,
    .tp_getset = Mesh_getset,
    .tp_new = Mesh_new,
};

int ffdpy_init_mesh(PyObject *module)
{
    if (PyType_Ready(&ffdpy_MeshStoreType) < 0 || PyType_Ready(&ffdpy_MeshType) < 0)
        return -1;
    if (PyModule_AddObjectRef(module, "Mesh", (PyObject *)&ffdpy_MeshType) < 0 ||
        PyModule_AddObjectRef(module, "_MeshStore", (PyObject *)&ffdpy_MeshStoreType) < 0)
        return -1;
    /* CELL_TYPES: {name: VTK id} for every cell type the library reads */
    PyObject *types = PyDict_New();
    if (!types)
        return -1;
    for (unsigned id = 0; id < 256; id++) {
        const char *name = ffd_cell_type_name(id);
        PyObject *v = name ? PyLong_FromUnsignedLong(id) : NULL;
        if (name && (!v || PyDict_SetItemString(types, name, v) < 0)) {
            Py_XDECREF(v);
            Py_DECREF(types);
            return -1;
        }
        Py_XDECREF(v);
    }
    int rc = PyModule_AddObjectRef(module, "CELL_TYPES", types);
    Py_DECREF(types);
    return rc;
}
