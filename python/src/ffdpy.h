/* ffdkit._ffd: the CPython + NumPy C API layer over libffd (docs/python.md).
 * One file per Python type (mesh.c, rig.c, deformer.c), distributed.c the
 * distributed runs (an ffd_comm over a Python object: no MPI here); module.c
 * holds the module, the exception classes and the array conversions they
 * share. */
#ifndef FFDPY_H
#define FFDPY_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL ffdpy_ARRAY_API
#ifndef FFDPY_MODULE_C
#define NO_IMPORT_ARRAY
#endif
#include <numpy/arrayobject.h>
#include <pythread.h>

#include "ffd.h"

/* Raises the ffdkit.Error subclass of st with err's message (or what when
 * err has none); returns NULL for `return ffdpy_raise(...)`. */
PyObject *ffdpy_raise(ffd_status st, const ffd_error *err, const char *what);

/* The status whose ffdkit.Error subclass exc is an instance of; FFD_OK for
 * any other exception (ffdkit.Error itself included). */
ffd_status ffdpy_status_of(PyObject *exc);

/* An (N, 3) float64 C-contiguous array for obj: obj itself (a new
 * reference, no copy) when it already is one, else converted once.
 * TypeError for non-numeric data, ValueError naming `name` and the shape
 * for a shape that is not (N, 3). NULL with the exception set. */
PyArrayObject *ffdpy_points(PyObject *obj, const char *name);
/* A float64 C-contiguous array of exactly `ndim` dims with shape dims
 * (converted once), for deltas/targets; same errors as ffdpy_points. */
PyArrayObject *ffdpy_doubles(PyObject *obj, const char *name, int ndim, const npy_intp *dims);
/* Checks out= (C-contiguous, aligned, writeable float64 of shape ndim/dims);
 * ValueError naming what is wrong. Returns 0 or -1. */
int ffdpy_check_out(PyObject *out, int ndim, const npy_intp *dims);
/* A uint32 C-contiguous copy of an index sequence or array (1-D); TypeError
 * for non-integers, ValueError for a negative or too large id. */
PyArrayObject *ffdpy_ids(PyObject *obj, const char *name);
/* Fills limits from None or a dict {"max_memory", "max_work", "unlimited"}. */
int ffdpy_limits(PyObject *obj, ffd_limits *limits, int *given);

/* ---- the types ---- */
typedef struct {
    PyObject_HEAD
    ffd_mesh *mesh; /* owned */
} ffdpy_MeshStore;

typedef struct {
    PyObject_HEAD
    ffdpy_MeshStore *store; /* the ffd_mesh; views' base is the store */
    int changing; /* 1 while a call with the GIL released changes the mesh */
    PyObject *weakrefs;
} ffdpy_Mesh;

typedef struct {
    PyObject_HEAD
    ffd_rig *rig; /* owned */
    PyObject *weakrefs;
} ffdpy_Rig;

typedef struct {
    PyObject_HEAD
    ffd_deformer *d; /* owned */
    PyThread_type_lock lock; /* one thread at a time in d */
    PyObject *dict;
    PyObject *weakrefs;
} ffdpy_Deformer;

extern PyTypeObject ffdpy_MeshStoreType, ffdpy_MeshType, ffdpy_RigType, ffdpy_DeformerType;

/* A new ffd_mesh of the (N, 3) points without faces (for point sets given
 * where a mesh is expected), or the mesh itself (borrowed) for a Mesh.
 * *owned receives the created mesh to destroy, NULL for a Mesh; *keep a
 * reference to release after the call (the Mesh's store, kept alive while
 * the GIL is released). RuntimeError while another thread changes the Mesh. */
int ffdpy_mesh_or_points(PyObject *obj, const char *name, const ffd_mesh **mesh, ffd_mesh **owned,
                         PyObject **keep);
/* The ffd_mesh of a Mesh object, to change in place: replaces the Mesh's
 * store by a copy first when views of the current one are alive (so that
 * an operation that reallocates the mesh never leaves a view dangling). */
/* Sets m->changing (RuntimeError when another thread already changes it);
 * pair with ffdpy_mesh_end_change. */
ffd_mesh *ffdpy_mesh_for_change(ffdpy_Mesh *m);
void ffdpy_mesh_end_change(ffdpy_Mesh *m);

/* A Deformer of cls (ffdpy_DeformerType or a subclass) with its lock and
 * no ffd_deformer yet (d NULL, to be set by the caller); NULL with the
 * exception set. */
ffdpy_Deformer *ffdpy_deformer_alloc(PyTypeObject *cls);
/* A rig report as a dict ("details" is the method's JSON text, which the
 * Python layer decodes); NULL with the exception set. */
PyObject *ffdpy_report_dict(const ffd_rig_report *rep);

int ffdpy_init_mesh(PyObject *module);
int ffdpy_init_rig(PyObject *module);
int ffdpy_init_deformer(PyObject *module);
int ffdpy_init_distributed(PyObject *module);

#endif
