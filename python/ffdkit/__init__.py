"""ffdkit: free-form deformation of 3D meshes and point sets over numpy arrays.

The compiled core (ffdkit._ffd, the CPython + NumPy C API over libffd) does the
work with the GIL released; this package gives it its Pythonic shape:

    import ffdkit
    mesh = ffdkit.read_mesh("bunny.obj")
    rig = ffdkit.Rig.load("bend.json")
    rig.apply(mesh)                      # in place; returns the report
    ffdkit.write_mesh(mesh, "bent.obj")  # lossless: untouched bytes are kept

    d = rig.deformer(points)             # any (N, 3) float64 points
    d.controls[3] += (0, 0.1, 0)         # written through to the deformer
    moved = d.evaluate()

docs/python.md is the manual.
"""
import importlib.util as _importlib_util

from . import _ffd
from ._ffd import (
    Error,
    FileError,
    InvalidError,
    NoMemoryError,
    NonFiniteError,
    NumericError,
    ParseError,
    RangeError,
    UnsupportedError,
)
from ._mesh import CELL_TYPES, Mesh, read_mesh, write_mesh
from ._rig import Rig
from ._deformer import ControlsView, Deformer, SolveResult
from .meshio_interop import deform_meshio, from_meshio, to_meshio

__version__ = f"{_ffd.VERSION_MAJOR}.{_ffd.VERSION_MINOR}.{_ffd.VERSION_PATCH}"

__all__ = [
    "CELL_TYPES",
    "ControlsView",
    "Deformer",
    "Error",
    "FileError",
    "InvalidError",
    "Mesh",
    "NoMemoryError",
    "NonFiniteError",
    "NumericError",
    "ParseError",
    "RangeError",
    "Rig",
    "SolveResult",
    "UnsupportedError",
    "__version__",
    "deform_meshio",
    "from_meshio",
    "read_mesh",
    "to_meshio",
    "write_mesh",
]

# Each method's own deformer class registers itself in _deformer.METHOD_CLASSES.
if _importlib_util.find_spec(__name__ + ".methods") is not None:
    from . import methods  # noqa: F401
