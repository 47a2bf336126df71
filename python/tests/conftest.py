"""Shared fixtures of ffdkit's tests: the repository's meshes and rigs (data/,
examples/) and the ffd command of the build under test."""
import os
import pathlib
import shutil

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"
DATA = REPO / "data"


@pytest.fixture(scope="session")
def repo() -> pathlib.Path:
    return REPO


@pytest.fixture(scope="session")
def ffd_cli() -> pathlib.Path:
    """The ffd command built next to the module under test (BUILD/python/ffdkit)."""
    import ffdkit

    build = pathlib.Path(os.path.abspath(ffdkit.__file__)).parent.parent.parent  # not resolved: a symlink
    for cand in (build / "ffd", shutil.which("ffd")):
        if cand and os.access(str(cand), os.X_OK) and pathlib.Path(cand).is_file():
            return pathlib.Path(cand)
    pytest.skip("no ffd command next to the module (run from a CMake build: PYTHONPATH=build/python)")


def sanitized() -> bool:
    return os.environ.get("FFDKIT_TEST_SANITIZED") == "1"
