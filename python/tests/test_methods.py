"""Each method's own operations (python/ffdkit/methods.py, ffdkit.pbffd.place)
on the example rigs and meshes: properties (a refinement keeps the shape, a
frame rotation moves the points near its EBF and reset() returns every bit, a
GFFD primitive transform moves the influenced vertices, level switching) and
every error path (an op of another method: UnsupportedError; a bad body:
ParseError naming the key)."""

import json
from pathlib import Path

import numpy as np
import pytest

import ffdkit
from ffdkit.methods import GFFDDeformer, LatticeDeformer, PBFFDDeformer, TSplineDeformer

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


@pytest.fixture(scope="module")
def cow():
    return ffdkit.read_mesh(str(EXAMPLES / "tspline" / "cow.off"))


@pytest.fixture(scope="module")
def bunny():
    return ffdkit.read_mesh(str(EXAMPLES / "lattice" / "bunny.obj"))


def diagonal(points):
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def moved_rows(a, b, tol=0.0):
    return np.flatnonzero(np.abs(a - b).max(axis=1) > tol)


# ---------------------------------------------------------------------------
# the factory returns the method's subclass
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "rig,cls",
    [
        ({"version": 1, "deformer": "lattice"}, LatticeDeformer),
        ({"version": 1, "deformer": "tspline", "resolution": [5, 5, 5]}, TSplineDeformer),
        ({"version": 1, "deformer": "pbffd", "controls": {"interior": 10, "exterior": 10}}, PBFFDDeformer),
        (
            {"version": 1, "deformer": "gffd",
             "skeleton": [{"type": "point", "position": [0, 0, 0], "radius": 0.3}]},
            GFFDDeformer,
        ),
    ],
)
def test_factory_returns_the_method_subclass(cow, rig, cls):
    d = ffdkit.Rig.load(rig).deformer(cow)
    assert type(d) is cls and isinstance(d, ffdkit.Deformer)
    assert d.method == rig["deformer"]
    assert type(ffdkit.Deformer(ffdkit.Rig.load(rig), cow)) is cls


# ---------------------------------------------------------------------------
# lattice
# ---------------------------------------------------------------------------


def test_lattice_structure_from_the_report(bunny):
    d = ffdkit.Rig.load(str(EXAMPLES / "lattice" / "bernstein.json")).deformer(bunny)
    assert d.resolution == (3, 3, 3) and d.basis == "bernstein"
    d = ffdkit.Rig.load({"version": 1, "deformer": "lattice", "resolution": [4, 5, 6]}).deformer(bunny)
    assert d.resolution == (4, 5, 6) and d.basis == "bspline" and d.control_count == 120
    origin, axes = d.box
    assert origin.shape == (3,) and axes.shape == (3, 3)
    # the automatic box holds the mesh (grown by the 5% margin)
    stu = np.linalg.solve(axes.T, (bunny.points - origin).T).T
    assert stu.min() > 0 and stu.max() < 1
    # the lattice boundary interpolates: corner controls at the box's corners
    c = d.controls
    assert np.allclose(c[d.control_index(0, 0, 0)], origin, atol=1e-12)
    assert np.allclose(c[d.control_index(3, 4, 5)], origin + axes.sum(axis=0), atol=1e-12)
    assert np.allclose(c[d.control_index(3, 0, 0)], origin + axes[0], atol=1e-12)
    grid = d.control_grid()
    assert grid.shape == (4, 5, 6, 3)
    for ijk in [(0, 0, 0), (1, 2, 3), (3, 4, 5), (2, 0, 5)]:
        assert np.array_equal(grid[ijk], c[d.control_index(*ijk)])


def test_lattice_explicit_box_and_index_errors(bunny):
    box = {"origin": [-6.0, -1.0, -5.0], "axes": [[12.0, 0, 0], [0, 12.0, 0], [0, 0, 10.0]]}
    d = ffdkit.Rig.load({"version": 1, "deformer": "lattice", "box": box}).deformer(bunny)
    origin, axes = d.box
    assert origin.tolist() == box["origin"] and axes.tolist() == box["axes"]
    for bad in [(5, 0, 0), (0, -1, 0), (0, 0, 5)]:
        with pytest.raises(IndexError, match="out of range"):
            d.control_index(*bad)


def test_lattice_moving_an_indexed_control(bunny):
    d = ffdkit.Rig.load(str(EXAMPLES / "lattice" / "bend.json")).deformer(bunny)
    bent = d.evaluate()
    d.reset()
    rest = d.evaluate()
    # the rig's moves, replayed by lattice index
    moves = json.loads((EXAMPLES / "lattice" / "bend.json").read_text())["moves"]
    assert len(moves) > 3
    d.move([d.control_index(*m["index"]) for m in moves], [m["delta"] for m in moves])
    assert np.allclose(d.evaluate(), bent, atol=1e-12)
    assert not np.allclose(rest, bent)


def test_lattice_has_no_method_operations(bunny):
    d = ffdkit.Rig.load({"version": 1, "deformer": "lattice"}).deformer(bunny)
    for op in ["refine", "freeze", "level", "frame", "curve", "primitive"]:
        with pytest.raises(ffdkit.UnsupportedError, match="lattice") as e:
            d.command(op)
        assert isinstance(e.value, NotImplementedError)
        assert isinstance(e.value.status, str) and e.value.status


# ---------------------------------------------------------------------------
# T-spline
# ---------------------------------------------------------------------------


@pytest.fixture
def tspline(cow):
    return ffdkit.Rig.load({"version": 1, "deformer": "tspline", "resolution": [5, 5, 5]}).deformer(cow)


def check_refinement_keeps_shape(d, refine):
    before, count = d.evaluate(), d.control_count
    jac = d.jacobian()
    refine()
    assert d.control_count > count
    after = d.evaluate()
    assert np.abs(after - before).max() <= 1e-9 * diagonal(before)
    assert np.abs(d.jacobian() - jac).max() <= 1e-7


@pytest.mark.parametrize(
    "how",
    ["near_cell", "near_face", "near_edge", "cell", "face", "edge", "proxy", "list", "dict"],
)
def test_tspline_refinement_keeps_the_shape(tspline, how):
    d = tspline
    # deformed first: a refinement keeps the current shape, not only the rest
    d.move([62, 63], [[0.02, 0.05, 0.0], [0.0, -0.03, 0.01]])
    refine = {
        "near_cell": lambda: d.refine_near([0.42, 0.15, 0.0]),
        "near_face": lambda: d.refine_near([0.0, 0.0, 0.0], element="face"),
        "near_edge": lambda: d.refine_near([0.1, 0.1, 0.0], element="edge"),
        "cell": lambda: d.refine_cell(21),
        "face": lambda: d.refine_face(21),
        "edge": lambda: d.refine_edge(28, ratio=0.3),
        "proxy": d.refine_proxy,
        "list": lambda: d.refine([{"cell": 42}, {"cell": {"near": [-0.3, 0.0, 0.0]}}]),
        "dict": lambda: d.refine({"cells": "proxy"}),
    }[how]
    refinements = d.refinements
    check_refinement_keeps_shape(d, refine)
    assert d.refinements == refinements + 1
    assert 0 <= d.max_weight_deviation < 1


def test_tspline_counts_follow_refinement(tspline):
    d = tspline
    assert (d.cell_count, d.face_count, d.edge_count, d.control_count) == (64, 240, 300, 125)
    with pytest.raises(ffdkit.InvalidError, match="zero knot interval"):
        d.refine_cell(0)  # an end layer
    d.refine_cell(21)
    assert d.cell_count > 64 and d.face_count > 240 and d.edge_count > 300
    assert d.controls.shape == (d.control_count, 3)
    assert d.linear_map().shape == (d.point_count, d.control_count)


def test_tspline_example_rig_then_refine(cow):
    d = ffdkit.Rig.load(str(EXAMPLES / "tspline" / "cow-head.json")).deformer(cow)
    assert isinstance(d, TSplineDeformer) and d.refinements == 1
    check_refinement_keeps_shape(d, lambda: d.refine_near([-0.4, 0.0, 0.0]))


def test_tspline_freeze_and_unfreeze(tspline):
    d = tspline
    assert d.frozen.size == 0
    d.freeze([0, 5, 7])
    d.freeze(9)
    assert d.frozen.tolist() == [0, 5, 7, 9]
    d.freeze(np.array([5, 9]), frozen=False)
    assert d.frozen.tolist() == [0, 7]
    # all or nothing: an id past the end changes nothing
    with pytest.raises(ffdkit.RangeError):
        d.freeze([1, 2, 10**6])
    assert d.frozen.tolist() == [0, 7]
    with pytest.raises(ffdkit.ParseError, match="frozen"):
        d.command("freeze", points=[1], frozen="yes")
    with pytest.raises(ffdkit.ParseError, match="point"):
        d.command("freeze", point=[1])


def test_tspline_proxy_mesh(tspline):
    d = tspline
    points, faces, point_controls = d.proxy_arrays()
    assert points.shape == (len(point_controls), 3)
    assert np.array_equal(points, d.controls[point_controls.astype(int)])
    # a closed 2-manifold: every edge in exactly two faces, once each way
    edges = {}
    for f in faces:
        for a, b in zip(f, f[1:] + f[:1]):
            edges[(a, b)] = edges.get((a, b), 0) + 1
    assert all(n == 1 and edges.get((b, a)) == 1 for (a, b), n in edges.items())
    mesh = d.proxy()
    assert isinstance(mesh, ffdkit.Mesh)
    assert mesh.vertex_count == len(point_controls) and mesh.face_count == len(faces)
    assert np.array_equal(mesh.points, points)
    # the proxy follows the controls; it grows with a refinement
    c = int(point_controls[0])
    d.move([c], [[0.0, 0.1, 0.0]])
    assert np.allclose(d.proxy_arrays()[0][0], points[0] + [0.0, 0.1, 0.0])
    d.refine_proxy()
    assert len(d.proxy_arrays()[2]) > len(point_controls)


def test_tspline_errors(tspline):
    d = tspline
    count = d.control_count
    with pytest.raises(ffdkit.ParseError, match=r"insertions\[0\]\.cel"):
        d.refine([{"cel": 1}])
    with pytest.raises(ffdkit.ParseError, match="insertions"):
        d.command("refine")
    with pytest.raises(ffdkit.ParseError, match="insertion"):
        d.command("refine", insertion=[{"cell": 0}])
    with pytest.raises(ffdkit.ParseError, match="insertions"):
        d.refine([])
    with pytest.raises(ffdkit.RangeError):
        d.refine_cell(10**6)
    with pytest.raises(ValueError, match="element"):
        d.refine_near([0, 0, 0], element="vertex")
    with pytest.raises(ValueError, match="3 numbers"):
        d.refine_near([0, 0])
    with pytest.raises(ffdkit.UnsupportedError, match='"refine", "freeze"'):
        d.command("level", level=1)
    with pytest.raises(ffdkit.UnsupportedError):
        d.command("primitive", remove=0)
    assert d.control_count == count and d.refinements == 0


# ---------------------------------------------------------------------------
# PB-FFD
# ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def placement(cow):
    return ffdkit.pbffd.place(cow, interior=20, exterior=20, levels=2)


@pytest.fixture
def pbffd(cow, placement):
    # a fresh deformer on the placed controls (the explicit form place returns)
    rig = {"version": 1, "deformer": "pbffd", "controls": placement.controls, "levels": 2}
    return ffdkit.Rig.load(rig).deformer(cow)


def test_pbffd_place(cow, placement):
    d, centers, controls, report = placement
    assert isinstance(d, PBFFDDeformer)
    assert centers.shape == (40, 3) and len(controls) == 40
    assert report["params"]["interior"] == 20 and report["params"]["exterior"] == 20
    assert report["controls"]["levels"] == 2 and d.levels == 2
    assert np.array_equal(centers, d.controls[:40])
    assert set(controls[0]) >= {"center", "radius", "frame"}
    # the explicit controls rebuild the same deformer
    again = ffdkit.Rig.load({"version": 1, "deformer": "pbffd", "controls": controls, "levels": 2})
    again = again.deformer(cow)
    assert np.array_equal(again.controls, d.controls) and np.array_equal(again.radii, d.radii)
    # a path works too; the defaults place 60 + 60
    p = ffdkit.pbffd.place(str(EXAMPLES / "pbffd" / "cow.off"), interior=8, exterior=8, master=False)
    assert p.centers.shape == (16, 3)


def test_pbffd_place_errors(cow):
    with pytest.raises(TypeError, match="interiour"):
        ffdkit.pbffd.place(cow, interiour=20)
    with pytest.raises(TypeError, match="Mesh"):
        ffdkit.pbffd.place(np.zeros((4, 3)))
    with pytest.raises((ffdkit.ParseError, ffdkit.InvalidError), match="interior"):
        ffdkit.pbffd.place(cow, interior=0)
    with pytest.raises(ffdkit.InvalidError, match="interior points"):
        ffdkit.pbffd.place(cow, interior=10**6, exterior=10)
    with pytest.raises((ffdkit.ParseError, ffdkit.InvalidError), match="levels"):
        ffdkit.pbffd.place(cow, interior=10, exterior=10, levels=0)


def test_pbffd_level_switching(pbffd):
    d = pbffd
    assert (d.level, d.levels, d.ebf_count, d.control_count) == (0, 2, 40, 40)
    rest = d.evaluate()
    d.level = 1
    assert d.level == 1 and 0 < d.control_count < 40 and d.ebf_count == d.control_count
    assert d.controls.shape == (d.control_count, 3) and d.frames.shape == (d.control_count, 3, 3)
    # a coarse control moves the mesh (through the cascade of eq. 9-10)
    d.move([0], [[0.0, 0.1, 0.0]])
    coarse = d.evaluate()
    assert moved_rows(rest, coarse, 1e-9).size > 0
    d.set_level(0)
    assert d.level == 0 and d.control_count == 40
    assert np.array_equal(d.evaluate(), coarse)  # showing a level changes nothing
    d.reset()
    assert np.array_equal(d.evaluate(), rest)
    with pytest.raises(ffdkit.RangeError, match="level"):
        d.level = 2
    with pytest.raises(ffdkit.ParseError, match="level"):
        d.set_level("coarse")
    with pytest.raises(ffdkit.ParseError, match="level"):
        d.command("level")
    with pytest.raises(ffdkit.ParseError, match="lvl"):
        d.command("level", lvl=1)
    assert d.level == 0


def test_pbffd_frame_rotation_moves_nearby_points_and_reset_restores(pbffd):
    d = pbffd
    rest = d.evaluate()
    frames, radii, centers = d.frames, d.radii, d.controls[:40]
    assert np.allclose(np.linalg.norm(frames, axis=2), 1.0)
    assert d.enabled.all()
    j = 3
    d.rotate_frame([j], [0, 0, 1], 0.5)
    twisted = d.evaluate()
    moved = moved_rows(rest, twisted, 1e-12)
    assert moved.size > 0
    # the moved points are near EBF j: inside its ROI ellipsoid (the frame's
    # semi-axes; the frame after the rotation: the ROI turns with it)
    local = (rest[moved] - centers[j]) @ frames[j].T / radii[j]
    assert np.all(np.linalg.norm(local, axis=1) <= 1 + 1e-9)
    assert not np.allclose(d.frames[j], frames[j]) and np.array_equal(d.frames[:j], frames[:j])
    d.scale_frame([j, j + 1], [1.5, 1.0, 1.0])
    assert moved_rows(twisted, d.evaluate(), 1e-12).size > 0
    d.reset()
    assert np.array_equal(d.evaluate(), rest)  # every bit
    assert np.array_equal(d.frames, frames)


def test_pbffd_frame_errors(pbffd):
    d = pbffd
    rest = d.evaluate()
    with pytest.raises(ffdkit.ParseError, match="axis"):
        d.set_frame([0])
    with pytest.raises(ffdkit.ParseError, match="angle"):
        d.set_frame([0], axis=[0, 0, 1])
    with pytest.raises(ffdkit.InvalidError, match="axis"):
        d.rotate_frame([0], [0, 0, 0], 1.0)
    with pytest.raises(ffdkit.InvalidError, match="scale"):
        d.scale_frame([0], [1.0, 0.0, 1.0])
    with pytest.raises(ffdkit.RangeError):
        d.rotate_frame([40], [0, 0, 1], 1.0)
    with pytest.raises(ffdkit.ParseError, match="points"):
        d.command("frame", axis=[0, 0, 1], angle=1.0)
    with pytest.raises(ffdkit.ParseError, match="rotate"):
        d.command("frame", points=[0], rotate=1.0)
    ids = d.curve([[0.3, 0.1, 0.0], [0.5, 0.1, 0.0]])
    with pytest.raises(ffdkit.InvalidError, match="curve point"):
        d.rotate_frame([int(ids[0])], [0, 0, 1], 1.0)
    d.reset()
    assert np.array_equal(d.evaluate(), rest)


def test_pbffd_curve(cow):
    d = ffdkit.Rig.load({"version": 1, "deformer": "pbffd",
                         "controls": {"interior": 20, "exterior": 20}}).deformer(cow)
    rest = d.evaluate()
    ids = d.curve([[0.3, 0.1, 0.0], [0.45, 0.12, 0.0], [0.6, 0.1, 0.0]], radius=0.15, samples=12)
    assert ids.tolist() == [40, 41, 42] and d.control_count == 43
    assert d.curves == [{"offset": 40, "count": 3, "radius": 0.15}]
    assert np.array_equal(d.controls[40], [0.3, 0.1, 0.0])
    assert np.array_equal(d.evaluate(), rest)  # a curve at rest moves nothing
    d.move_curve(0, [1, 2], [0.0, 0.1, 0.0])
    bent = d.evaluate()
    moved = moved_rows(rest, bent, 1e-12)
    assert 0 < moved.size < d.point_count
    # only points near the curve follow
    assert rest[moved, 0].min() > 0.3 - 0.15 - 1e-9
    second = d.curve(np.array([[-0.5, 0.0, 0.0], [-0.4, 0.0, 0.0]]))
    assert second.tolist() == [43, 44] and len(d.curves) == 2 and d.curves[1]["radius"] > 0
    assert np.array_equal(d.curve_controls(0), ids)
    with pytest.raises(IndexError):
        d.move_curve(0, [3], [0.0, 0.1, 0.0])


def test_pbffd_curve_errors(pbffd):
    d = pbffd
    with pytest.raises(ffdkit.ParseError, match="points"):
        d.curve([[0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"\(k, 3\)"):
        d.curve([0.0, 0.0, 0.0])
    with pytest.raises((ffdkit.ParseError, ffdkit.InvalidError), match="radius"):
        d.curve([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], radius=-1.0)
    with pytest.raises(ffdkit.ParseError, match="samples"):
        d.curve([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], samples=-2)
    with pytest.raises(ffdkit.ParseError, match="moves"):
        d.command("curve", points=[[0, 0, 0], [1, 0, 0]], moves=[])
    assert d.curves == [] and d.control_count == 40
    with pytest.raises(ffdkit.UnsupportedError, match='"level", "frame", "curve"'):
        d.command("refine", insertions=[{"cells": "proxy"}])


def test_pbffd_example_rigs(cow):
    d = ffdkit.Rig.load(str(EXAMPLES / "pbffd" / "cow-levels.json")).deformer(cow)
    assert isinstance(d, PBFFDDeformer) and d.levels == 3
    edited = d.evaluate()
    d.level = 2
    assert d.evaluate().tobytes() == edited.tobytes()
    d.reset()
    assert moved_rows(cow.points, d.evaluate(), 1e-12).size == 0


# ---------------------------------------------------------------------------
# GFFD
# ---------------------------------------------------------------------------

SPINE = {"type": "polyline", "vertices": [[-0.5, 0, 0], [0, 0, 0], [0.5, 0, 0]], "radius": 0.3}


@pytest.fixture
def gffd(cow):
    return ffdkit.Rig.load({"version": 1, "deformer": "gffd", "skeleton": [SPINE]}).deformer(cow)


def test_gffd_skeleton(gffd):
    d = gffd
    (p,) = d.skeleton
    assert (p["type"], p["radius"], p["offset"], p["count"]) == ("polyline", 0.3, 0, 3)
    assert np.array_equal(p["vertices"], SPINE["vertices"])
    assert 0 < d.influenced <= d.point_count
    assert d.primitive_controls(0).tolist() == [0, 1, 2]
    with pytest.raises(IndexError):
        d.primitive_controls(1)


def test_gffd_primitive_transform_moves_the_influenced_vertices(cow):
    # a short spine in the head: some vertices are outside its influence
    d = ffdkit.Rig.load({"version": 1, "deformer": "gffd", "skeleton": [
        {"type": "polyline", "vertices": [[0.35, 0.1, 0], [0.5, 0.1, 0]], "radius": 0.15}]}).deformer(cow)
    rest = d.evaluate()
    influenced = d.influenced
    assert 0 < influenced < d.point_count
    d.transform_primitive(0, translate=[0.0, 0.05, 0.0])
    assert np.allclose(d.skeleton[0]["vertices"], [[0.35, 0.15, 0], [0.5, 0.15, 0]])
    moved = moved_rows(rest, d.evaluate(), 0.0)
    assert moved.size == influenced
    d.reset()
    assert np.array_equal(d.evaluate(), rest)
    d.transform_primitive(0, axis=[0, 0, 1], angle=0.4)
    v = d.skeleton[0]["vertices"]
    assert np.isclose(np.linalg.norm(v[1] - v[0]), 0.15)  # rigid
    assert moved_rows(rest, d.evaluate(), 0.0).size == influenced
    d.transform_primitive(0, np.diag([1.5, 1.0, 1.0]), center=[0.35, 0.1, 0])
    c = np.array([0.35, 0.1, 0.0])
    assert np.allclose(d.skeleton[0]["vertices"], (v - c) * [1.5, 1.0, 1.0] + c)
    with pytest.raises(ValueError, match="not both"):
        d.transform_primitive(0, np.eye(3), axis=[0, 0, 1])
    with pytest.raises(ValueError, match="zero vector"):
        d.transform_primitive(0, axis=[0, 0, 0], angle=1.0)


def test_gffd_skeleton_edits(gffd):
    d = gffd
    rest = d.evaluate()
    i = d.add_primitive(type="point", position=[0.4, 0.1, 0.0], radius=0.2)
    assert i == 1 and d.control_count == 4 and d.point_count == 2904
    assert [p["type"] for p in d.skeleton] == ["polyline", "point"]
    assert d.primitive_controls(1).tolist() == [3]
    assert np.array_equal(d.evaluate(), rest)  # a new primitive at rest moves nothing
    d.move([3], [[0.0, 0.05, 0.0]])
    assert moved_rows(rest, d.evaluate(), 0.0).size > 0
    d.set_radius(0, 0.35)
    assert d.skeleton[0]["radius"] == 0.35
    d.primitive(add={"type": "polyline", "vertices": np.array([[-0.6, 0.1, 0], [-0.4, 0.1, 0]]),
                     "radius": 0.1})
    assert len(d.skeleton) == 3 and d.control_count == 6
    d.remove_primitive(1)
    assert [p["type"] for p in d.skeleton] == ["polyline", "polyline"] and d.control_count == 5


def test_gffd_errors(gffd):
    d = gffd
    with pytest.raises(ffdkit.RangeError, match="index: 5 out of range"):
        d.set_radius(5, 1.0)
    with pytest.raises(ffdkit.ParseError, match="add.type"):
        d.add_primitive(type="blob")
    with pytest.raises(ffdkit.ParseError, match="foo"):
        d.primitive(foo=1)
    with pytest.raises(ffdkit.ParseError, match="body"):
        d.primitive(add=dict(SPINE), remove=0)
    with pytest.raises(ffdkit.ParseError, match="radius"):
        d.primitive(index=0)
    with pytest.raises((ffdkit.ParseError, ffdkit.InvalidError), match="radius"):
        d.set_radius(0, -1.0)
    with pytest.raises(ffdkit.ParseError, match="file"):
        d.add_primitive(type="polyline", file="spine.obj", radius=0.1)
    with pytest.raises(ffdkit.InvalidError, match="only primitive"):
        d.remove_primitive(0)
    with pytest.raises(ffdkit.UnsupportedError, match='"primitive"'):
        d.command("refine", insertions=[{"cells": "proxy"}])
    # GFFD's map is not linear in its controls
    with pytest.raises(ffdkit.UnsupportedError):
        d.linear_map()
    with pytest.raises(ffdkit.UnsupportedError):
        d.solve([0], [[0.0, 0.0, 0.0]])
    assert len(d.skeleton) == 1 and d.control_count == 3


def test_gffd_example_rig(bunny, tmp_path):
    # twist.json without "resample" (it adds vertices: a deformer refuses it)
    rig = json.loads((EXAMPLES / "gffd" / "twist.json").read_text())
    with pytest.raises(ffdkit.InvalidError, match="resample"):
        ffdkit.Rig.load(str(EXAMPLES / "gffd" / "twist.json")).deformer(bunny)
    del rig["resample"]
    (tmp_path / "head.off").write_bytes((EXAMPLES / "gffd" / "head.off").read_bytes())
    (tmp_path / "twist.json").write_text(json.dumps(rig))
    d = ffdkit.Rig.load(str(tmp_path / "twist.json")).deformer(bunny)
    assert isinstance(d, GFFDDeformer)
    assert [p["type"] for p in d.skeleton] == ["polyhedron", "polyline", "polyline"]
    turned = d.evaluate()
    d.set_radius(2, 2.6)  # re-binds at the current shape's rest: the turn stays
    assert np.abs(d.evaluate() - turned).max() < 0.05 * diagonal(turned)
