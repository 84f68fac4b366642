"""pip install . : builds crumple's Python module and crumple-sim with CMake, into build-pip/ (CRUMPLE_PIP_BUILD_DIR
chooses another folder; CRUMPLE_PIP_JOBS the build's jobs), for the interpreter that runs pip, and packs them with
the package's Python files. The version is the one CMakeLists.txt's project() says. docs/python.md tells more."""
import os
import pathlib
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).parent.resolve()


def version():
    text = (ROOT / "CMakeLists.txt").read_text(encoding="utf-8")
    return re.search(r"project\(crumple VERSION (\d+\.\d+\.\d+)", text).group(1)


class CMakeBuild(build_ext):
    """The extension `crumple._crumple` and the program crumple-sim (for crumple-sweep: crumple/bin/), built by
    CMake."""

    def build_extension(self, ext):
        build = pathlib.Path(os.environ.get("CRUMPLE_PIP_BUILD_DIR", ROOT / "build-pip")).resolve()
        jobs = os.environ.get("CRUMPLE_PIP_JOBS", str(os.cpu_count() or 1))
        subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                        f"-DPython3_EXECUTABLE={sys.executable}", "-DCRUMPLE_BUILD_TESTS=OFF",
                        "-DCRUMPLE_BUILD_SANDBOX=OFF", "-DCRUMPLE_BUILD_BENCH=OFF", "-DCRUMPLE_INSTALL=OFF"], check=True)
        subprocess.run(["cmake", "--build", str(build), "-j", jobs, "--target", "crumple_python", "crumple-sim"],
                       check=True)
        built = sorted((build / "python" / "crumple").glob("_crumple*.so"))
        if not built:
            raise RuntimeError(f"CMake built no module _crumple in {build / 'python' / 'crumple'}")
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(built[-1], target)
        bin_dir = target.parent / "bin"
        bin_dir.mkdir(exist_ok=True)
        shutil.copy2(build / "apps" / "crumple-sim", bin_dir / "crumple-sim")


setup(
    version=version(),
    packages=["crumple"],
    package_dir={"crumple": "apps/python/crumple"},
    package_data={"crumple": ["__init__.pyi", "py.typed"]},
    ext_modules=[Extension("crumple._crumple", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    # setuptools' own staging beside CMake's build, not in build/ (the CMake build folder of tools/test.sh).
    options={"build": {"build_base": str(ROOT / "build-pip" / "setuptools")}},
    zip_safe=False,
)
