#!/usr/bin/env bash
# Set up everything clumpprops needs on a fresh Debian machine; idempotent.
#
#   bash scripts/setup.sh                              # Debian 12: YADE 2023.02a, venv .venv
#   VENV=.venv-debian13 bash scripts/setup.sh          # the same inside the Debian 13 root
#                                                      # (scripts/debian13.sh run ...): YADE 2025.2
#
# Steps (each a function below, run in this order; add new steps the same way):
#   debian_packages  YADE, LIGGGHTS and LAMMPS (exporter checks), Dask and Jinja2 (the study engine), pybind11,
#                    python3-build and g++, Sphinx, MyST, numpydoc, sphinx-argparse and furo (make docs)
#                    (the compiled core) and the scientific stack for /usr/bin/python3 (YADE's interpreter), via apt
#   make_venv        $VENV: a venv of /usr/bin/python3 that sees Debian's packages and can `import yade`
#   build_core       the compiled core (C++17 + pybind11), in place
#   install_package  clumpprops in editable mode into $VENV (console script `clumpprops`)
#   pip_packages     manifold3d, meshio, trimesh and multisphere from PyPI (the [mesh] and [fit] extras:
#                    export --to stl/vtk, fit), with the installed numpy and SciPy kept
#   report           one line: clumpprops, Python, numpy and the YADE version that was set up
#
# VENV (default .venv) is relative to the repository root.  The repository is bind-mounted into
# the Debian 13 root, so the host's .venv (Python 3.11) must not be reused there: use
# VENV=.venv-debian13 inside it (the Makefile does).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV="${VENV:-.venv}"
PY="$VENV/bin/python"
YADE_PY=/usr/lib/x86_64-linux-gnu/yade-double/py
PKGS="yade liggghts lammps python3-distributed python3-numpy python3-scipy python3-pandas python3-matplotlib python3-pytest python3-hypothesis python3-mpmath python3-jinja2 python3-build python3-venv python3-pip python3-setuptools python3-pybind11 python3-dev g++ python3-sphinx python3-myst-parser python3-numpydoc python3-sphinx-argparse furo"

log() { echo "[setup] $*"; }

debian_packages() {
  local missing="" p SUDO=""
  for p in $PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
  done
  [ -z "$missing" ] && return 0
  log "installing Debian packages:$missing"
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $missing >/dev/null
}

make_venv() {
  [ -d "$YADE_PY" ] || { echo "[setup] YADE's python package not found at $YADE_PY" >&2; exit 1; }
  # a venv made by another Python (e.g. the host's .venv seen from the Debian 13 root) is remade
  local want have
  want=$(/usr/bin/python3 -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  have=$(sed -n 's/^version[_a-z]* *= *\([0-9]*\.[0-9]*\).*/\1/p' "$VENV/pyvenv.cfg" 2>/dev/null | head -1 || true)
  if [ -f "$VENV/pyvenv.cfg" ] && [ "$have" != "$want" ]; then
    log "$VENV was made by Python ${have:-?}, not /usr/bin/python3 ($want): remaking it"
    rm -rf "$VENV"
  fi
  if [ ! -x "$PY" ]; then
    log "creating $VENV from /usr/bin/python3 (with Debian's site packages)"
    /usr/bin/python3 -m venv --system-site-packages "$VENV"
  fi
  local site
  site=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
  echo "$YADE_PY" > "$site/yade_double.pth"
}

build_core() {
  # the compiled core (C++17 header clumpprops/core/clumpprops.hpp + pybind11 module): built in
  # place, beside the sources, when missing or older than them (one .so per Python: the Debian 12
  # and Debian 13 builds sit side by side)
  local ext
  ext=$("$PY" -c 'import sysconfig; print("clumpprops/core/_core" + sysconfig.get_config_var("EXT_SUFFIX"))')
  if [ ! -f "$ext" ] || [ -n "$(find clumpprops/core/clumpprops.hpp clumpprops/core/_core.cpp setup.py -newer "$ext")" ]; then
    log "building the compiled core ($ext)"
    "$PY" setup.py -q build_ext --inplace >/dev/null
  fi
}

install_package() {
  if ! "$PY" -I -c 'import clumpprops, sys; sys.exit(0 if clumpprops.__file__.startswith("'"$PWD"'/") else 1)' 2>/dev/null; then
    log "installing clumpprops (editable) into $VENV"
    local site
    site=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
    "$PY" -m pip install -q --no-deps --no-build-isolation --no-index -e . \
      || echo "$PWD" > "$site/clumpprops_src.pth"
  fi
}

# the optional mesh and file libraries (extras [mesh]: export --to stl/vtk; docs/visualise.md), from PyPI.
# meshio needs rich, which needs markdown-it-py >= 2.2: keep it within the major version Debian
# ships, so that Debian's myst-parser (the docs) still accepts it.
PIP_PKGS="manifold3d meshio trimesh multisphere"

pip_packages() {
  "$PY" -c 'import importlib.util as u, sys; sys.exit(any(u.find_spec(m) is None for m in sys.argv[1:]))' $PIP_PKGS && return 0
  local major pins
  major=$("$PY" -c 'import markdown_it; print(int(markdown_it.__version__.split(".")[0]) + 1)' 2>/dev/null || echo 99)
  log "installing from PyPI: $PIP_PKGS"
  # multisphere's scikit-image would otherwise replace the numpy YADE is built against
  pins=$("$PY" -c 'import numpy, scipy; print(f"numpy=={numpy.__version__} scipy=={scipy.__version__}")')
  "$PY" -m pip install -q $PIP_PKGS $pins "markdown-it-py<$major"
}

report() {
  "$PY" -I -c 'import sys, numpy, clumpprops, yade.config; print("[setup] ok:", sys.argv[1], "| clumpprops", clumpprops.__version__, "from", clumpprops.__file__, "| Python", sys.version.split()[0], "| numpy", numpy.__version__, "| YADE", yade.config.version)' "$VENV" 2>&1 | tail -1
}

debian_packages
make_venv
build_core
install_package
pip_packages
report
