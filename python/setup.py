"""Builds ffdkit's compiled core (ffdkit._ffd) with CMake from the repository
that holds this folder, then packages it with the .py files.

The configure step is the repository's own CMakeLists.txt with only the module
(FFD_PYTHON=ON, tests, benchmarks and fuzzers off) for the Python that runs
this script; the static libffd is linked into the module. FFDKIT_SOURCE_DIR
overrides where the repository is; CMAKE_BUILD_PARALLEL_LEVEL the build's jobs.
"""
import os
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = Path(__file__).resolve().parent


def source_dir() -> Path:
    root = Path(os.environ.get("FFDKIT_SOURCE_DIR", HERE.parent)).resolve()
    if not (root / "CMakeLists.txt").is_file() or not (root / "include" / "ffd.h").is_file():
        sys.exit(f"ffdkit: {root} is not the ffdkit repository (no CMakeLists.txt and include/ffd.h); "
                 "install from a checkout (pip install --no-build-isolation ./python) or set FFDKIT_SOURCE_DIR")
    return root


class CMakeBuild(build_ext):
    """Configures and builds the repository's ffd_python target."""

    def build_extension(self, ext):
        if shutil.which("cmake") is None:
            sys.exit("ffdkit: cmake is not installed (Debian: bash scripts/setup.sh, or apt install cmake)")
        build = Path(self.build_temp).resolve() / "cmake"
        build.mkdir(parents=True, exist_ok=True)
        cfg = "Debug" if self.debug else "Release"
        subprocess.check_call([
            "cmake", "-S", str(source_dir()), "-B", str(build), f"-DCMAKE_BUILD_TYPE={cfg}",
            f"-DPython3_EXECUTABLE={sys.executable}", "-DFFD_PYTHON=ON", "-DBUILD_TESTING=OFF",
            "-DFFD_BUILD_BENCH=OFF", "-DFFD_BUILD_FUZZ=OFF",
        ])
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(min(os.cpu_count() or 1, 4)))
        subprocess.check_call(["cmake", "--build", str(build), "--target", "ffd_python", "-j", jobs])
        built = sorted((build / "python" / "ffdkit").glob("_ffd*.so"))
        if not built:
            sys.exit(f"ffdkit: the build made no module in {build / 'python' / 'ffdkit'}")
        dest = Path(self.get_ext_fullpath(ext.name))
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[0], dest)


setup(ext_modules=[Extension("ffdkit._ffd", sources=[])], cmdclass={"build_ext": CMakeBuild})
