#!/usr/bin/env bash
# The library as a user gets it from pip: build the sdist, build a wheel from that sdist, install
# the wheel into a fresh venv without system site packages (everything else from PyPI), and run
# the library tests (pytest -m library) from a folder outside the source tree, so that a file the
# package does not ship fails them.  Run for each Python given (default: python3.11 and python3.13,
# those that are found).
#
#   bash scripts/test_wheel.sh [PYTHON ...]
set -euo pipefail
cd "$(dirname "$0")/.."
SRC="$PWD"
PYTHONS=("$@")
[ ${#PYTHONS[@]} -gt 0 ] || PYTHONS=(python3.11 python3.13)
WORK=$(mktemp -d /tmp/clumpprops-wheel.XXXXXX)
trap 'rm -rf "$WORK"' EXIT
log() { echo "[test-wheel] $*"; }
# pip's own warnings about this machine's extra index folders are noise here
quiet() { grep -v "^WARNING: Location 'file:" || true; }

status=0
tested=0
# a Python by name: on PATH, else one that pyenv installed (machines with pyenv keep the others there)
find_python() {
  local name="$1" c
  for c in "$name" "${PYENV_ROOT:-$HOME/.pyenv}"/versions/"${name#python}"*/bin/"$name"; do
    if command -v "$c" >/dev/null 2>&1 && "$c" -c 'import venv, ensurepip' >/dev/null 2>&1; then
      command -v "$c"; return 0
    fi
  done
  return 1
}

for name in "${PYTHONS[@]}"; do
  if ! py=$(find_python "$name"); then
    log "$name: not found (or without venv); skipped"
    continue
  fi
  v=$("$py" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  d="$WORK/py$v"
  mkdir -p "$d/dist" "$d/run"
  "$py" -m venv "$d/venv"
  "$d/venv/bin/python" -m pip install -q --upgrade pip build 2>&1 | quiet
  # the sdist from the tree, then the wheel from the sdist (python -m build does both, in isolation)
  "$d/venv/bin/python" -m build -q --outdir "$d/dist" "$SRC" >"$d/build.log" 2>&1 \
    || { tail -30 "$d/build.log"; log "Python $v: build failed"; status=1; continue; }
  whl=$(ls "$d"/dist/clumpprops-*.whl)
  log "Python $v: built $(basename "$(ls "$d"/dist/clumpprops-*.tar.gz)") and $(basename "$whl")"
  "$d/venv/bin/python" -m pip install -q "$whl[test,mesh,plot]" 2>&1 | quiet  # the optional extras too: their tests run
  # the tests and the example files they read, without the package: clumpprops comes from the wheel
  cp -r "$SRC/tests" "$SRC/examples" "$d/run/"
  ( cd "$d/run" && "$d/venv/bin/python" -c 'import clumpprops, sys; f = clumpprops.__file__; print("[test-wheel] clumpprops", clumpprops.__version__, "from", f); sys.exit("/venv/" not in f)' ) \
    || { log "Python $v: clumpprops not imported from the wheel"; status=1; continue; }
  # the files of tests/conftest.py's LIBRARY (the others import YADE, the studies or results/)
  files=$("$d/venv/bin/python" -c 'import ast, sys
tree = ast.parse(open("tests/conftest.py").read())
lib = next(n.value for n in tree.body if isinstance(n, ast.Assign) and n.targets[0].id == "LIBRARY")
print(" ".join("tests/" + f for f in sorted(ast.literal_eval(lib))))')
  if ( cd "$d/run" && OMP_NUM_THREADS=1 "$d/venv/bin/python" -m pytest -q -p no:cacheprovider -m library $files ); then
    tested=$((tested + 1))
  else
    log "Python $v: library tests failed against the installed wheel"; status=1
  fi
done
[ "$tested" -gt 0 ] || { log "no Python could be tested"; status=1; }
exit $status
