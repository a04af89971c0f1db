"""The package as users get it: one version everywhere, the files a build needs in the sdist and
nothing of the studies, and a clear line where YADE is missing."""
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

import clumpprops

ROOT = Path(__file__).resolve().parents[1]


def test_the_version_is_the_same_in_the_package_its_metadata_and_the_command_line():
    assert metadata.version("clumpprops") == clumpprops.__version__
    out = subprocess.run([sys.executable, "-m", "clumpprops", "--version"], capture_output=True, text=True).stdout
    assert out.split() == ["clumpprops", clumpprops.__version__]
    cff = ROOT / "CITATION.cff"
    if cff.exists():                             # a checkout (the sdist has no CITATION.cff test to run)
        assert re.search(r'^version: "([^"]+)"', cff.read_text(), re.M).group(1) == clumpprops.__version__


def test_the_compiled_core_and_its_header_are_installed_beside_the_package():
    import clumpprops.core._core as core
    pkg = Path(clumpprops.__file__).parent
    assert Path(core.__file__).parent == pkg / "core"
    assert (pkg / "core" / "clumpprops.hpp").exists()


def test_without_yade_the_adapter_says_in_one_line_how_to_get_it():
    code = ("import sys; sys.modules['yade'] = None\n"          # YADE absent, even where it is installed
            "import clumpprops.yade as cy\n"
            "try:\n    cy.append_clump([[0, 0, 0]], [1.0])\n"
            "except ModuleNotFoundError as e:\n    print(e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout.strip()
    assert len(out.splitlines()) == 1 and "needs YADE, which is not on PyPI" in out


@pytest.mark.skipif(not (ROOT / "MANIFEST.in").exists(), reason="needs the source tree")
def test_the_sdist_holds_the_core_sources_and_nothing_of_the_studies(tmp_path):
    build = pytest.importorskip("build")          # noqa: F841  (python -m build, from PyPI)
    r = subprocess.run([sys.executable, "-m", "build", "--sdist", "--no-isolation", "--outdir", str(tmp_path), str(ROOT)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    import tarfile
    (sdist,) = tmp_path.glob("clumpprops-*.tar.gz")
    names = [n.split("/", 1)[1] for n in tarfile.open(sdist).getnames() if "/" in n]
    for need in ("clumpprops/core/_core.cpp", "clumpprops/core/clumpprops.hpp", "setup.py", "pyproject.toml",
                 "LICENSE", "README.md", "clumpprops/yade/__init__.py", "clumpprops/yade/build.py"):
        assert need in names, need
    assert not [n for n in names if n.split("/")[0] in ("results", "studies", "tests", "benchmarks", "yade_scripts")]
    assert not [n for n in names if n.endswith(".so")]


def test_marker_sets_name_existing_test_files_and_library_tests_neither_run_yade_nor_are_slow():
    import conftest

    here = {p.name for p in Path(__file__).resolve().parent.glob("test_*.py")}
    for marker, files in conftest.MARKERS.items():
        assert files <= here, (marker, files - here)
    assert not conftest.LIBRARY & (conftest.YADE | conftest.SLOW)


def test_every_subpackage_is_listed_for_the_wheel():
    """setuptools builds the wheel from pyproject's explicit package list: a subpackage missing
    from it installs without that folder (a wheel user gets ModuleNotFoundError)."""
    import tomllib
    root = Path(__file__).resolve().parents[1]
    if not (root / "pyproject.toml").exists():
        pytest.skip("outside the source tree: the wheel test's own imports find a missing subpackage")
    listed = set(tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(p.parent.relative_to(root).parts) for p in (root / "clumpprops").rglob("__init__.py")}
    assert found == listed, (found - listed, listed - found)
