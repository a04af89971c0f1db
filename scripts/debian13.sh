#!/usr/bin/env bash
# YADE 2025.2 on a Debian 12 machine: a Debian 13 ("trixie") root made with debootstrap.
#
#   scripts/debian13.sh build          # make the root if missing (~1 min + ~6 min of apt), reuse it otherwise
#   scripts/debian13.sh run CMD ...    # run CMD inside the root, in the repository (bind-mounted at /repo)
#   scripts/debian13.sh path           # print the root's path
#
# The root lives outside the repository, in $CLUMPPROPS_DEBIAN13 (default
# /var/cache/clumpprops/debian13).  Every `run` uses a private mount namespace
# (unshare -m), so its bind mounts (/dev, /proc, /sys, the repository, /tmp) vanish
# when it exits and any number of runs can go side by side.  `build` needs root (debootstrap,
# apt); `run` does not: without root it enters the root through an unprivileged user namespace
# (unshare -r: the user is root only inside it), as on any kernel that allows them (Debian's do).
# A user without root therefore needs the root built once by someone with root, at the path
# $CLUMPPROPS_DEBIAN13 names.
set -euo pipefail
ROOT="${CLUMPPROPS_DEBIAN13:-/var/cache/clumpprops/debian13}"
REPO="$(cd "$(dirname "$0")/.." && pwd)"
# Debian packages inside the root: YADE 2025.2 and the project's Python stack (Python 3.13, numpy 2)
PKGS="yade python3-numpy python3-scipy python3-pandas python3-matplotlib python3-pytest python3-hypothesis \
python3-mpmath python3-distributed python3-jinja2 python3-pybind11 python3-dev g++ python3-setuptools git ca-certificates"
STAMP="$ROOT/.clumpprops-ready"

need_root() { [ "$(id -u)" -eq 0 ] || { echo "[debian13] needs root (debootstrap, chroot)" >&2; exit 1; }; }

mirror() {
  # the mirror this machine's apt uses (sources.list or deb822 .sources), else deb.debian.org
  local m
  m=$(grep -hoE '^(deb|URIs:)\s+[^ ]+' /etc/apt/sources.list /etc/apt/sources.list.d/*.list \
        /etc/apt/sources.list.d/*.sources 2>/dev/null | grep -v security | awk '{print $2}' | head -1 || true)
  echo "${m:-http://deb.debian.org/debian}"
}

in_root() {
  # run "$@" chrooted into ROOT with /dev, /proc, /sys, /tmp and the repository mounted, in a
  # private mount namespace (nothing stays mounted afterwards)
  local wd="${WORKDIR:-/repo}"
  # without root: a user namespace mapping the user to root, and a PID namespace so that /proc mounts
  local ns=(unshare -m --propagation private)
  [ "$(id -u)" -eq 0 ] || ns=(unshare -r -m -p -f --kill-child --propagation private)   # dies with its caller
  ${EXEC:-} "${ns[@]}" bash -s "$ROOT" "$REPO" "$wd" "$@" <<'EOS'
set -e
ROOT="$1"; REPO="$2"; WD="$3"; shift 3
mount --rbind /dev "$ROOT/dev"
mount -t proc proc "$ROOT/proc"
mount --rbind /sys "$ROOT/sys"
mkdir -p "$ROOT/repo" "$ROOT/tmp"
mount --bind "$REPO" "$ROOT/repo"
mount --bind /tmp "$ROOT/tmp"
[ -f /etc/resolv.conf ] && cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf" 2>/dev/null || true
# pip inside the root reaches PyPI as the host's pip does: the host's certificate bundle (a proxy's
# own certificate authority may be in it) and its index settings
PIPENV=()
CERT="${PIP_CERT:-/etc/ssl/certs/ca-certificates.crt}"
if [ -f "$CERT" ] && cp -L "$CERT" "$ROOT/etc/ssl/certs/clumpprops-host-ca.crt" 2>/dev/null; then
  PIPENV+=(PIP_CERT=/etc/ssl/certs/clumpprops-host-ca.crt)
fi
for v in PIP_INDEX_URL PIP_EXTRA_INDEX_URL PIP_TRUSTED_HOST PIP_DEFAULT_TIMEOUT; do
  [ -n "${!v:-}" ] && PIPENV+=("$v=${!v}")
done
exec chroot "$ROOT" /usr/bin/env -i HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
  LANG=C.UTF-8 OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}" CLUMPPROPS_ROOT=/repo CLUMPPROPS_IN_DEBIAN13=1 "${PIPENV[@]}" \
  bash -c 'cd "$0" && exec "$@"' "$WD" "$@"
EOS
}

build() {
  need_root
  if [ -f "$STAMP" ]; then echo "[debian13] ready: $ROOT ($(cat "$STAMP"))"; return 0; fi
  command -v debootstrap >/dev/null || { apt-get update -qq; DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null; }
  mkdir -p "$(dirname "$ROOT")"
  if [ ! -x "$ROOT/usr/bin/apt-get" ]; then
    echo "[debian13] debootstrap --variant=minbase trixie $ROOT ($(mirror)); about 1 min"
    rm -rf "$ROOT"
    debootstrap --variant=minbase trixie "$ROOT" "$(mirror)" >/tmp/clumpprops-debootstrap.log 2>&1 \
      || { tail -20 /tmp/clumpprops-debootstrap.log >&2; exit 1; }
  fi
  echo "[debian13] apt-get install (YADE 2025.2 and the Python stack, --no-install-recommends); about 6 min"
  WORKDIR=/ in_root bash -c "apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $PKGS >/tmp/clumpprops-debian13-apt.log 2>&1 || { tail -30 /tmp/clumpprops-debian13-apt.log; exit 1; }"
  local v
  v=$(WORKDIR=/ in_root python3 -c 'import sys; sys.path.insert(0, "/usr/lib/x86_64-linux-gnu/yade-double/py"); import yade.config, numpy; print("YADE", yade.config.version, "numpy", numpy.__version__, "python", sys.version.split()[0])' 2>/dev/null | tail -1)
  case "$v" in YADE*) ;; *) echo "[debian13] YADE does not import in $ROOT" >&2; exit 1;; esac
  echo "$v" > "$STAMP"
  echo "[debian13] ready: $ROOT ($v, $(du -sh "$ROOT" 2>/dev/null | cut -f1))"
}

case "${1:-}" in
  build) build ;;
  path) echo "$ROOT" ;;
  run) shift; [ -f "$STAMP" ] || { echo "[debian13] no Debian 13 root at $ROOT: scripts/debian13.sh build makes it (as root, once); without root, ask someone with root to build it, or set CLUMPPROPS_DEBIAN13 to one that exists" >&2; exit 1; }
       EXEC=exec in_root "$@" ;;   # exec all the way down: a signal to this process reaches YADE
  *) sed -n '2,12p' "$0"; exit 2 ;;
esac
