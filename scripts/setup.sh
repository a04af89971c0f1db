#!/usr/bin/env bash
# Set up everything clumpprops needs on a fresh Debian 12 machine; idempotent.
#  - Debian packages: YADE 2023.02a and the scientific stack for /usr/bin/python3 (YADE's interpreter)
#  - .venv: a venv of /usr/bin/python3 that sees those packages, can `import yade`,
#    and has clumpprops installed in editable mode (console script `clumpprops`).
set -euo pipefail
cd "$(dirname "$0")/.."
PKGS="yade python3-numpy python3-scipy python3-pandas python3-matplotlib python3-pytest python3-hypothesis python3-mpmath python3-venv python3-pip python3-setuptools python3-pybind11 python3-dev g++"
missing=""
for p in $PKGS; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  echo "[setup] installing Debian packages:$missing"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $missing >/dev/null
fi
YADE_PY=/usr/lib/x86_64-linux-gnu/yade-double/py
[ -d "$YADE_PY" ] || { echo "[setup] YADE's python package not found at $YADE_PY" >&2; exit 1; }
if [ ! -x .venv/bin/python ]; then
  echo "[setup] creating .venv from /usr/bin/python3 (with Debian's site packages)"
  /usr/bin/python3 -m venv --system-site-packages .venv
fi
# the compiled core (C++17 header clumpprops/core/clumpprops.hpp + pybind11 module): built in
# place, beside the sources, when missing or older than them
EXT=$(.venv/bin/python -c 'import sysconfig; print("clumpprops/core/_core" + sysconfig.get_config_var("EXT_SUFFIX"))')
if [ ! -f "$EXT" ] || [ -n "$(find clumpprops/core/clumpprops.hpp clumpprops/core/_core.cpp setup.py -newer "$EXT")" ]; then
  echo "[setup] building the compiled core ($EXT)"
  .venv/bin/python setup.py -q build_ext --inplace >/dev/null
fi
SITE=$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
echo "$YADE_PY" > "$SITE/yade_double.pth"
if ! .venv/bin/python -I -c 'import clumpprops, sys; sys.exit(0 if clumpprops.__file__.startswith("'"$PWD"'/") else 1)' 2>/dev/null; then
  echo "[setup] installing clumpprops (editable) into .venv"
  .venv/bin/python -m pip install -q --no-deps --no-build-isolation --no-index -e . \
    || echo "$PWD" > "$SITE/clumpprops_src.pth"
fi
.venv/bin/python -I -c 'import clumpprops, yade.config; print("[setup] ok: clumpprops", clumpprops.__version__, "from", clumpprops.__file__, "| YADE", yade.config.version)' 2>&1 | tail -1
