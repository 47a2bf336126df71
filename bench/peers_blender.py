# Blender's side of bench/peers.sh: the Lattice modifier on the points of
# bench_peers gen, a 5^3 lattice on the unit cube whose every point moves by
# the same deltas ffdkit uses (lattice point (i, j, k) of Blender is ffdkit's
# control (i, j, k); Blender's own B-spline interpolation, KEY_BSPLINE).
#   blender -b --factory-startup -t 2 --python bench/peers_blender.py -- DIR ROUNDS
# Prints "depsgraph_update MS without_modifier MS": medians over ROUNDS of
# the depsgraph update after a lattice move (what the user waits for: the
# modifier re-run on every point plus Blender's copy of the evaluated mesh)
# and of the same update of the mesh with the modifier removed (the copy
# alone; Blender 3.4 does not expose its per-modifier timer to Python); then
# the first deformed point, so the work cannot be skipped.
import sys
import time

import bpy
import numpy

directory, rounds = sys.argv[-2], int(sys.argv[-1])
points = numpy.fromfile(directory + "/points.f64", dtype="<f8")
deltas = numpy.fromfile(directory + "/deltas.f64", dtype="<f8").reshape(-1, 3)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
mesh = bpy.data.meshes.new("points")
mesh.vertices.add(len(points) // 3)
mesh.vertices.foreach_set("co", points.astype(numpy.float32))
mesh.update()
obj = bpy.data.objects.new("points", mesh)
scene.collection.objects.link(obj)

lat = bpy.data.lattices.new("lattice")
lat.points_u = lat.points_v = lat.points_w = 5
for axis in "uvw":
    setattr(lat, "interpolation_type_" + axis, "KEY_BSPLINE")
lat_obj = bpy.data.objects.new("lattice", lat)
lat_obj.location = (0.5, 0.5, 0.5)  # Blender's lattice spans [-0.5, 0.5]^3 locally
scene.collection.objects.link(lat_obj)
mod = obj.modifiers.new("lattice", "LATTICE")
mod.object = lat_obj

# Blender orders lattice points u fastest; ffdkit's control (i, j, k) is i*25 + j*5 + k.
rest = [tuple(p.co) for p in lat.points]
def set_points(sign):
    for w in range(5):
        for v in range(5):
            for u in range(5):
                d = deltas[u * 25 + v * 5 + w] * sign
                p = lat.points[u + 5 * v + 25 * w]
                r = rest[u + 5 * v + 25 * w]
                p.co_deform = (r[0] + d[0], r[1] + d[1], r[2] + d[2])

depsgraph = bpy.context.evaluated_depsgraph_get()
def median(xs):
    return 1e3 * sorted(xs)[len(xs) // 2]

times = []
for r in range(rounds + 1):
    set_points(1 if r % 2 == 0 else -1)
    lat.update_tag()
    t0 = time.perf_counter()
    depsgraph.update()
    t1 = time.perf_counter()
    evaluated = obj.evaluated_get(depsgraph)
    first = tuple(evaluated.data.vertices[0].co)
    if r > 0:  # the first update also builds the evaluated mesh
        times.append(t1 - t0)

obj.modifiers.remove(mod)
depsgraph.update()
bare = []
for r in range(rounds):
    mesh.update_tag()
    t0 = time.perf_counter()
    depsgraph.update()
    bare.append(time.perf_counter() - t0)
print("depsgraph_update %.3f without_modifier %.3f first %.6f %.6f %.6f"
      % (median(times), median(bare), *first))
