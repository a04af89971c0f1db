"""Build of clumpprops' compiled core (pybind11 from Debian's python3-pybind11).

    python3 setup.py build_ext --inplace        # what scripts/setup.sh runs
    CLUMPPROPS_SANITIZE=1 python3 setup.py build_ext --inplace --force   # AddressSanitizer + UBSan build (make asan)
"""
import os

from pybind11.setup_helpers import Pybind11Extension
from setuptools import setup

flags = ["-O3", "-fno-math-errno"]
link = []
if os.environ.get("CLUMPPROPS_SANITIZE"):
    flags = ["-O1", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined", "-fno-sanitize-recover=undefined"]
    link = ["-fsanitize=address,undefined"]

setup(
    ext_modules=[
        Pybind11Extension(
            "clumpprops.core._core",
            ["clumpprops/core/_core.cpp"],
            include_dirs=["clumpprops/core"],
            cxx_std=17,
            extra_compile_args=flags,
            extra_link_args=link,
            depends=["clumpprops/core/clumpprops.hpp"],
        )
    ],
)
