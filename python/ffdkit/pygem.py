"""A drop-in for PyGeM's free-form deformation: ``from ffdkit.pygem import FFD``.

``FFD`` has the constructor, attributes, properties and methods of
``pygem.FFD`` (PyGeM >= 2.0, ``pygem/ffd.py``) and gives the same numbers,
computed by ffdkit's Bernstein lattice (Sederberg & Parry 1986) instead of
numpy loops. docs/pygem.md derives the map and docs/python.md says what is
covered. The map, for a point p, with R the box rotation, L the box lengths,
o the box origin and M = R diag(L):

    y  = M^-1 (p - o)                                   (PyGeM's psi)
    y' = y + sum_ijk b_i(y_0) b_j(y_1) b_k(y_2) mu_ijk  (PyGeM's T)
    p' = o + M y'                                       (PyGeM's inverse psi)

so p' = p + sum_ijk b_ijk(y) M mu_ijk: a Bernstein lattice on the box whose
control point (i, j, k) moves by M mu_ijk = R (mu_ijk * L). PyGeM deforms only
points whose y lies in the closed unit cube and returns the others unchanged;
so does this class by default (``outside="fixed"``). ``outside="extrapolate"``
continues the polynomials to every point instead (no clamping).

Covered: ``FFD``. Not covered (no ffdkit equivalent here): ``CFFD``, ``BFFD``,
``VFFD``, ``RBF``, ``IDW``, ``CustomDeformation`` and PyGeM's CAD handlers.
"""

from __future__ import annotations

import configparser
import copy
import math
import os

import numpy as np

from . import Rig

__all__ = ["FFD"]

_OUTSIDE = ("fixed", "extrapolate")


def _rotation(angles_deg):
    """R = Rx(ax) Ry(ay) Rz(az), angles in degrees, each counter-clockwise about a world axis
    acting on column vectors (PyGeM's angles2matrix(rz, ry, rx): the list [Rz, Ry, Rx] reversed
    and multiplied; docs/pygem.md "The deformation")."""
    ax, ay, az = (math.radians(float(a)) for a in angles_deg)
    cx, sx, cy, sy, cz, sz = (math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay),
                              math.cos(az), math.sin(az))
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return rx.dot(ry).dot(rz)


def _vector3(name, value):
    try:
        v = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as e:
        raise TypeError(f"FFD.{name}: expected 3 numbers, got {value!r}") from e
    if v.shape != (3,):
        raise ValueError(f"FFD.{name}: expected 3 numbers, got shape {np.shape(value)}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"FFD.{name}: {v.tolist()} is not finite")
    return v


def _points(src_pts):
    """src_pts as a C-contiguous (N, 3) float64 array (a view when it already is one)."""
    a = np.asarray(src_pts)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"FFD: points must be numbers, got dtype {a.dtype}")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"FFD: points must have shape (N, 3), got {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float64)


def _same_bits(a, b):
    """True when a and b hold the same doubles bit for bit (-0.0 is not 0.0)."""
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def _filename(filename):
    if not isinstance(filename, (str, os.PathLike)):
        raise TypeError("filename must be a string")
    return os.fspath(filename)


def _affine(matrix, label):
    """The linear map v -> matrix v applied to the rows of an (N, 3) array, PyGeM's psi style."""

    def apply(points):
        return np.asarray(points, dtype=np.float64).dot(matrix.T)

    apply.__doc__ = label
    apply.matrix = matrix
    return apply


class FFD:
    """Free-form deformation with PyGeM's interface (``pygem.FFD``) at ffdkit's speed.

    :param n_control_points: control points along x, y, z (default [2, 2, 2]).
    :param outside: ``"fixed"`` (PyGeM's rule: points outside the box are returned
        unchanged) or ``"extrapolate"`` (the Bernstein polynomials continued outside).

    Attributes, as in PyGeM: ``box_length``, ``box_origin``, ``rot_angle`` (degrees,
    about x, y, z), ``array_mu_x/y/z`` (arrays of shape ``n_control_points``: the
    displacement of each control point along the box's own axes, in units of the
    box length along that axis), ``conversion_unit`` (unused, as in PyGeM).

    >>> ffd = FFD([3, 3, 3])
    >>> ffd.array_mu_x[2, 1, 1] = 0.5
    >>> new_points = ffd(points)        # (N, 3) -> (N, 3)
    """

    reference_frame = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])

    def __init__(self, n_control_points=None, *, outside="fixed"):
        self.conversion_unit = 1.0
        self.box_length = np.array([1.0, 1.0, 1.0])
        self.box_origin = np.array([0.0, 0.0, 0.0])
        self.rot_angle = np.array([0.0, 0.0, 0.0])
        self.array_mu_x = None
        self.array_mu_y = None
        self.array_mu_z = None
        if n_control_points is None:
            n_control_points = [2, 2, 2]
        self.n_control_points = n_control_points
        if outside not in _OUTSIDE:
            raise ValueError(f"FFD: outside must be one of {_OUTSIDE}, got {outside!r}")
        self.outside = outside
        self._rig_key = None
        self._rig = None
        self._lattice_key = None  # __call__'s lattice, binding (_lattice_deformer)
        self._deformer = None
        self._bound = None

    # ------------------------------------------------------------------ attributes

    @property
    def n_control_points(self):
        """The number of control points along x, y and z (numpy array of 3 ints)."""
        return self._n_control_points

    @n_control_points.setter
    def n_control_points(self, npts):
        n = np.array(npts)
        if n.shape != (3,) or n.dtype.kind not in "iu":
            raise ValueError(f"FFD.n_control_points: expected 3 integers, got {npts!r}")
        if np.any(n < 1):
            raise ValueError(f"FFD.n_control_points: each must be at least 1, got {n.tolist()}")
        self._n_control_points = n
        self.array_mu_x = np.zeros(n)
        self.array_mu_y = np.zeros(n)
        self.array_mu_z = np.zeros(n)

    @property
    def rotation_matrix(self):
        """The box rotation R = Rx Ry Rz from ``rot_angle`` (degrees)."""
        return _rotation(self.rot_angle)

    @property
    def position_vertices(self):
        """The box origin and the three vertices next to it, (4, 3)."""
        return self.box_origin + np.vstack(
            [np.zeros((1, 3)), self.rotation_matrix.dot(np.diag(self.box_length)).T])

    @property
    def psi(self):
        """The map from the physical frame (relative to the box origin) to the unit cube:
        a callable on (N, 3) arrays (``psi(points - box_origin)``)."""
        m = self.rotation_matrix.dot(np.diag(np.asarray(self.box_length, dtype=np.float64)))
        return _affine(np.linalg.inv(m), "physical (minus origin) -> reference")

    @property
    def inverse_psi(self):
        """The map from the unit cube back to the physical frame (add ``box_origin``)."""
        m = self.rotation_matrix.dot(np.diag(np.asarray(self.box_length, dtype=np.float64)))
        return _affine(m, "reference -> physical (minus origin)")

    @property
    def T(self):
        """The deformation of the unit cube: a callable on (N, 3) reference points,
        ``y + sum_ijk b_ijk(y) mu_ijk`` for every point (no inside test, as in PyGeM)."""
        rig = Rig.load(self._rig_dict(unit=True))

        def T_mapping(points):
            return rig.apply(_points(points))

        return T_mapping

    def reset_weights(self):
        """Set every displacement (``array_mu_x/y/z``) to zero."""
        self.array_mu_x.fill(0.0)
        self.array_mu_y.fill(0.0)
        self.array_mu_z.fill(0.0)

    def control_points(self, deformed=True):
        """The control points of the lattice (rest, or moved when ``deformed``), (n_x n_y n_z, 3),
        index (i, j, k) at row (i n_y + j) n_z + k."""
        n = self.n_control_points
        grids = [np.linspace(0, self.box_length[a], n[a]) for a in range(3)]
        x, y, z = np.meshgrid(*grids, indexing="ij")
        box_points = np.array([x.ravel(), y.ravel(), z.ravel()])
        if deformed:
            mu = self._mu()
            box_points = box_points + np.array(
                [mu[a].ravel() * self.box_length[a] for a in range(3)])
        return (self.rotation_matrix.dot(box_points) + np.reshape(self.box_origin, (3, 1))).T

    # ------------------------------------------------------------------ .prm files

    def read_parameters(self, filename="parameters.prm"):
        """Read a PyGeM parameter file into the attributes. As in PyGeM, a file that does not
        exist is created with the current parameters. The file is checked by ffdkit's .prm
        reader first (docs/pygem.md): errors raise ffdkit.ParseError (or another
        ffdkit.Error) naming the file and line."""
        filename = _filename(filename)
        if not os.path.isfile(filename):
            self.write_parameters(filename)
            return
        with open(filename, "rb") as f:
            text = f.read().decode("utf-8")
        # the strict reader, whatever the file's extension: file:line messages for every bad value
        Rig._parse_prm(text, filename)
        config = configparser.RawConfigParser()
        config.read(filename)
        box = "Box info"

        def length_key(axis):
            key = "box length " + axis
            return key if config.has_option(box, key) else "box lenght " + axis

        n = [config.getint(box, "n control points " + a) for a in "xyz"]
        self.box_length = np.array([config.getfloat(box, length_key(a)) for a in "xyz"])
        self.box_origin = np.array([config.getfloat(box, "box origin " + a) for a in "xyz"])
        self.rot_angle = np.array([config.getfloat(box, "rotation angle " + a) for a in "xyz"])
        self.n_control_points = n
        for axis, mu in zip("xyz", self._mu()):
            for line in config.get("Parameters weights", "parameter " + axis).split("\n"):
                values = line.split()
                if values:
                    mu[tuple(int(v) for v in values[0:3])] = float(values[3])

    def write_parameters(self, filename="parameters.prm"):
        """Write the attributes as a PyGeM parameter file (every weight listed, zeros too).
        Numbers are written with Python's repr, so reading the file back gives the same bits."""
        filename = _filename(filename)
        with open(filename, "w") as f:
            f.write(self._prm_text())

    def _prm_text(self):
        n = [int(v) for v in self.n_control_points]
        lines = [
            "",
            "[Box info]",
            "# The FFD bounding box: control points per axis, edge lengths in the box's own frame,",
            "# the corner [0][0][0] (also the centre of rotation) and the rotation about x, y, z",
            "# in degrees.",
        ]
        lines += [f"n control points {a}: {n[i]}" for i, a in enumerate("xyz")]
        lines += [f"box length {a}: {float(self.box_length[i])!r}" for i, a in enumerate("xyz")]
        lines += [f"box origin {a}: {float(self.box_origin[i])!r}" for i, a in enumerate("xyz")]
        lines += [f"rotation angle {a}: {float(self.rot_angle[i])!r}" for i, a in enumerate("xyz")]
        lines += [
            "",
            "",
            "[Parameters weights]",
            "# One line per control point: x index, y index, z index, displacement along the",
            "# box's own axis divided by the box length along that axis.",
        ]
        for axis, mu in zip("xyz", self._mu()):
            lines.append("")
            prefix = f"parameter {axis}:"
            first = True
            for i in range(n[0]):
                for j in range(n[1]):
                    for k in range(n[2]):
                        lead = prefix + " " if first else " " * (len(prefix) + 1)
                        lines.append(f"{lead}{i}   {j}   {k}   {float(mu[i, j, k])!r}")
                        first = False
        return "\n".join(lines) + "\n"

    # ------------------------------------------------------------------ deformation

    def _mu(self):
        n = tuple(int(v) for v in self.n_control_points)
        arrays = []
        for name in ("array_mu_x", "array_mu_y", "array_mu_z"):
            a = getattr(self, name)
            if not isinstance(a, np.ndarray) or a.shape != n:
                raise ValueError(f"FFD.{name}: expected an array of shape {n} (n_control_points), "
                                 f"got {np.shape(a)}")
            arrays.append(a)
        return arrays

    def _rig_dict(self, unit=False):
        """The ffdkit rig of this FFD: a Bernstein lattice on the box whose control point
        (i, j, k) moves by R (mu_ijk * L) (docs/pygem.md, "Mapping onto ffd_rig"). unit: the
        unit cube without rotation, mu unscaled, every point deformed (PyGeM's T).

        PyGeM accepts one control point along an axis (degree 0: a constant shift); ffdkit's
        lattice needs two, so such an axis is degree-elevated: two control points, both
        with the one displacement ((1 - t) + t = 1, the same polynomial)."""
        n = [int(v) for v in self.n_control_points]
        mu = np.stack([np.asarray(a, dtype=np.float64) for a in self._mu()], axis=-1)
        for axis in range(3):
            if n[axis] == 1:
                mu = np.concatenate([mu, mu], axis=axis)
                n[axis] = 2
        if unit:
            axes = np.eye(3)
            origin = np.zeros(3)
            delta = mu
            outside = "extrapolate"
        else:
            length = _vector3("box_length", self.box_length)
            origin = _vector3("box_origin", self.box_origin)
            rotation = _rotation(_vector3("rot_angle", self.rot_angle))
            axes = (rotation * length).T  # row a: L_a R e_a
            delta = (mu * length).dot(rotation.T)
            outside = self.outside
        if not np.all(np.isfinite(delta)):
            raise ValueError("FFD: a displacement mu * box_length is not finite")
        moves = [{"index": [int(i), int(j), int(k)], "delta": delta[i, j, k].tolist()}
                 for i, j, k in zip(*np.nonzero(np.any(delta != 0.0, axis=-1)))]
        return {
            "version": 1,
            "deformer": "lattice",
            "basis": "bernstein",
            "resolution": n,
            "box": {"origin": origin.tolist(), "axes": axes.tolist()},
            "outside": outside,
            "moves": moves,
        }

    def rig(self):
        """The ffdkit.Rig this FFD applies (rebuilt only when an attribute changed)."""
        d = self._rig_dict()
        key = repr(d)
        if key != self._rig_key:
            self._rig = Rig.load(d)
            self._rig_key = key
        return self._rig

    def __call__(self, src_pts):
        """Deform ``src_pts`` ((N, 3), any real dtype) and return the deformed points as a new
        (N, 3) float64 array; ``src_pts`` is not modified.

        The same numbers as ``self.rig().apply(src_pts)``, faster in a loop: the lattice
        (box, control count, outside rule) is built once and kept while those attributes
        stay, the points' binding is kept while the points are bitwise the same as the last
        call's (one comparison, and a copy of the points held for it), and a call with new
        weights only sets the control points and evaluates."""
        pts = _points(src_pts)
        if pts.shape[0] == 0:
            return pts.copy()
        rig = self._rig_dict()
        moves = rig.pop("moves")
        structure = repr(rig)
        if structure != self._lattice_key:
            self._lattice_key, self._bound = None, None
            self._deformer = self._lattice_deformer(rig)
            self._lattice_key = structure
        d = self._deformer
        if self._bound is None or not _same_bits(self._bound, pts):
            self._bound = None
            d.bind(pts)
            self._bound = pts.copy()
        controls = self._rest_controls.copy()
        for move in moves:
            controls[self._control_id[tuple(move["index"])]] += move["delta"]
        d.set_controls(None, controls)
        return d.evaluate()

    def _lattice_deformer(self, rig):
        """A deformer of the rig's lattice (no moves) on its box's corners, with its rest
        control points and the control id of each lattice index (i, j, k), found from the
        rest positions so that no id order is assumed."""
        origin = np.asarray(rig["box"]["origin"])
        axes = np.asarray(rig["box"]["axes"])
        corners = np.array([origin + i * axes[0] + j * axes[1] + k * axes[2]
                            for i in (0, 1) for j in (0, 1) for k in (0, 1)])
        d = Rig.load(rig).deformer(corners)
        rest = np.array(d.controls, dtype=np.float64)
        local = np.linalg.solve(axes.T, (rest - origin).T).T  # rest = origin + local @ axes
        n = np.asarray(rig["resolution"])
        index = np.rint(local * (n - 1)).astype(int)
        self._control_id = {tuple(ijk): c for c, ijk in enumerate(index.tolist())}
        if len(self._control_id) != len(rest):
            raise RuntimeError("FFD: the lattice's control points do not form its grid")
        self._rest_controls = rest
        return d

    def reflect(self, axis=0, in_place=True):
        """Mirror the lattice across the face opposite the origin along ``axis`` (0, 1, 2): the
        control points become 2n - 1 along it and the box length doubles; the displacements
        along that axis change sign in the mirrored half. The displacements of the mirror
        plane along that axis must be zero (RuntimeError otherwise), as in PyGeM. Returns a new
        FFD when ``in_place`` is False, else None."""
        if axis not in (0, 1, 2):
            raise ValueError(f"The axis has to be 0, 1, or 2. Current value {axis}.")
        mu = self._mu()
        plane = [slice(None)] * 3
        plane[axis] = -1
        if np.count_nonzero(mu[axis][tuple(plane)]) != 0:
            raise RuntimeError(f"FFD.reflect: the control points in the symmetry plane are "
                               f"displaced along axis {axis}; reflecting would tear the lattice")
        target = self if in_place else copy.deepcopy(self)
        rest = [slice(None)] * 3
        rest[axis] = slice(1, None)
        mirrored = []
        for a, m in enumerate(mu):
            sign = -1.0 if a == axis else 1.0
            mirrored.append(np.append(m, sign * np.flip(m, axis)[tuple(rest)], axis=axis))
        n = np.array(target.n_control_points)
        n[axis] = 2 * n[axis] - 1
        target._n_control_points = n
        target.box_length = np.array(target.box_length, dtype=np.float64)
        target.box_length[axis] *= 2
        target.array_mu_x, target.array_mu_y, target.array_mu_z = mirrored
        return None if in_place else target

    def __deepcopy__(self, memo):
        other = self.__class__.__new__(self.__class__)
        for name, value in self.__dict__.items():
            if name not in ("_rig", "_rig_key", "_lattice_key", "_deformer", "_bound"):
                setattr(other, name, copy.deepcopy(value, memo))
        other._rig_key = None
        other._rig = None
        other._lattice_key = None
        other._deformer = None
        other._bound = None
        return other

    def __str__(self):
        return (f"conversion_unit = {self.conversion_unit}\n"
                f"n_control_points = {self.n_control_points}\n\n"
                f"box_length = {self.box_length}\n"
                f"box_origin = {self.box_origin}\n"
                f"rot_angle  = {self.rot_angle}\n"
                f"\narray_mu_x =\n{self.array_mu_x}\n"
                f"\narray_mu_y =\n{self.array_mu_y}\n"
                f"\narray_mu_z =\n{self.array_mu_z}\n"
                f"\nrotation_matrix = \n{self.rotation_matrix}\n"
                f"\nposition_vertices = {self.position_vertices}\n"
                f"outside = {self.outside}\n")
