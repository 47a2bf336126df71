"""The scripts in examples/python run, each in a temporary directory, and write what they say."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "python"


def run(script, tmp_path, *args):
    env = dict(os.environ)
    # the package the tests import, wherever it is (build/python or an installed one)
    import ffdkit

    env["PYTHONPATH"] = os.pathsep.join(
        [str(Path(os.path.abspath(ffdkit.__file__)).parents[1])] +
        ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    done = subprocess.run([sys.executable, str(EXAMPLES / script), *args], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def obj_points(path):
    return np.array([[float(v) for v in line.split()[1:4]]
                     for line in path.read_text().splitlines() if line.startswith("v ")])


def test_pygem_port(tmp_path):
    out = run("pygem_port.py", tmp_path)
    assert "largest displacement" in out
    rest, moved = obj_points(tmp_path / "sphere.obj"), obj_points(tmp_path / "sphere_deformed.obj")
    assert rest.shape == moved.shape == (20000, 3)
    assert 0.05 < np.max(np.linalg.norm(moved - rest, axis=1)) < 1.0
    from ffdkit.pygem import FFD

    ffd = FFD()
    ffd.read_parameters(str(tmp_path / "parameters.prm"))
    assert np.array_equal(ffd(rest), moved)


def test_meshio_volume(tmp_path):
    meshio = pytest.importorskip("meshio")
    out = run("meshio_volume.py", tmp_path)
    assert "wrote beam_morphed.vtu" in out
    m = meshio.read(tmp_path / "beam_morphed.vtu")
    assert m.cells[0].type == "tetra" and len(m.cells[0].data) == 1152
    assert set(m.point_data) >= {"distance"} and "part" in m.cell_data
    assert np.max(np.abs(m.points[:, 0] - m.point_data["distance"])) < 0.5
    # the far end turned about the beam's axis: its cross-section is no longer axis-aligned
    end = m.points[np.isclose(m.point_data["distance"], 6.0)]
    assert np.ptp(end[:, 1]) > 1.05


def test_direct_manipulation(tmp_path):
    out = run("direct_manipulation.py", tmp_path)
    assert out.count("residuals") == 6
    import ffdkit

    m = ffdkit.read_mesh(str(tmp_path / "bunny_dragged.obj"))
    rest = ffdkit.read_mesh(str(EXAMPLES.parent / "lattice" / "bunny.obj"))
    assert m.vertex_count == rest.vertex_count
    ear = int(np.argmax(np.array(rest.points)[:, 1]))
    np.testing.assert_allclose(np.array(m.points)[ear] - np.array(rest.points)[ear],
                               [6.0, 3.0, 0.0], atol=1e-6)


def test_shape_optimisation(tmp_path):
    out = run("shape_optimisation.py", tmp_path, "8")
    J = [float(line.split("J = ")[1].split()[0]) for line in out.splitlines() if "J = " in line]
    assert len(J) == 9
    assert all(b < a for a, b in zip(J, J[1:]))  # gradient descent with a 1/L step: J falls
    assert J[-1] < 0.05 * J[0]
