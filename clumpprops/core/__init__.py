"""The compiled core: ``clumpprops.hpp`` (header-only C++17) and its pybind11 module ``_core``.

Built in place by ``scripts/setup.sh`` (``python3 setup.py build_ext --inplace``).
``CLUMPPROPS_CORE_DIR`` (a directory holding another build of ``_core``, e.g. the
AddressSanitizer build of ``make asan``) takes precedence when set.
"""
import os as _os

_dir = _os.environ.get("CLUMPPROPS_CORE_DIR")
if _dir:
    __path__.insert(0, _dir)  # noqa: F821  (package __path__)
