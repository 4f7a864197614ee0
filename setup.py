"""Build the C++ core with CMake from setuptools (works offline and with editable installs)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        import pybind11

        target = Path(self.get_ext_fullpath(ext.name)).resolve()
        # Build into the source tree, so that `cmake --build build/cmake-*` alone updates an
        # editable install; then copy to where setuptools expects the extension.
        out_dir = ROOT / "python" / "pipeflex"
        tag = f"py{sys.version_info.major}{sys.version_info.minor}"
        build_dir = ROOT / "build" / f"cmake-{tag}"
        build_dir.mkdir(parents=True, exist_ok=True)
        generator = ["-G", "Ninja"] if _has("ninja") else []
        cfg = [
            "cmake", str(ROOT), *generator,
            f"-DPython_EXECUTABLE={sys.executable}",
            f"-DCMAKE_LIBRARY_OUTPUT_DIRECTORY={out_dir}",
            f"-Dpybind11_DIR={pybind11.get_cmake_dir()}",
            f"-DCMAKE_BUILD_TYPE={os.environ.get('PIPEFLEX_BUILD_TYPE', 'Release')}",
        ]
        cfg += os.environ.get("CMAKE_ARGS", "").split()
        subprocess.run(cfg, cwd=build_dir, check=True)
        subprocess.run(["cmake", "--build", ".", "--parallel", str(os.cpu_count() or 2)],
                       cwd=build_dir, check=True)
        built = out_dir / target.name
        if built.resolve() != target:
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(built, target)


def _has(program):
    from shutil import which

    return which(program) is not None


setup(ext_modules=[CMakeExtension("pipeflex._core")], cmdclass={"build_ext": CMakeBuild})
