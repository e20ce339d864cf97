#!/usr/bin/env bash
# Run what a FreeCAD version can change (scripts/test.sh --versions: the headless unit layer and the
# GUI tests under Xvfb, side by side, but the quality layer and the tests marked once, which the
# host runs) on the FreeCAD of other Debian suites: trixie (Debian 13, FreeCAD 1.0) and sid
# (FreeCAD 1.1), each inside a Debian root built with debootstrap, the suites side by side; in each
# root the Addon Manager also installs the workbench from a git URL served from a bare clone of
# this checkout's HEAD (tests/addon_manager_install.py). Needs root
# (debootstrap, mount, chroot), git and deb.debian.org.
#
# The roots are built once per machine and kept in $CMMSAMPLING_ROOTS (default
# /var/cache/cmmsampling/roots/<suite>); a root is built again when its recipe (the package list of
# scripts/install-deps.sh, the functions below) changes. Screenshots: artifacts/gui-<suite>/.
# Usage: bash scripts/test-matrix.sh [suite ...]   (default: trixie sid)
# Exit code: non-zero when any suite fails.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
cache="${CMMSAMPLING_ROOTS:-/var/cache/cmmsampling/roots}"
mirror="${CMMSAMPLING_MIRROR:-http://deb.debian.org/debian}"
# git: FreeCAD 1.0's Addon Manager clones add-ons with it. qt6-svg-plugins (recommended by Qt 6):
# FreeCAD 1.1's theme draws check marks and spin-box arrows from SVG images.
EXTRA_PACKAGES=(git qt6-svg-plugins)
CHROOT_PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
mounted=()

log() { echo "[test-matrix] $*" >&2; }

mount_into() {
  # mount_into ROOT: /proc, /sys and /dev (with /dev/pts and /dev/shm) inside ROOT.
  local root="$1"
  mount -t proc proc "$root/proc" && mounted+=("$root/proc")
  mount -t sysfs sysfs "$root/sys" && mounted+=("$root/sys")
  mount --rbind /dev "$root/dev" && mounted+=("$root/dev")
  mount --make-rslave "$root/dev"
}

mounts_under() {
  # mounts_under DIR: the mount points at or below DIR, deepest first.
  awk -v d="$1" '$2 == d || index($2, d "/") == 1 {print $2}' /proc/mounts | sort -r
}

unmount_leftovers() {
  # unmount_leftovers DIR: unmount what an interrupted run left mounted below DIR.
  local point
  for point in $(mounts_under "$1"); do
    umount -R -l "$point" || true
  done
}

safe_remove() {
  # safe_remove DIR: delete DIR, never while something (the host's /dev, the checkout) is
  # mounted inside it.
  unmount_leftovers "$1"
  if [ -n "$(mounts_under "$1")" ]; then
    log "not deleting $1: still mounted"
    return 1
  fi
  rm -rf "$1"
}

unmount_all() {
  # Unmount, newest first, everything this script mounted.
  local i
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do
    umount -R "${mounted[i]}" 2>/dev/null || umount -R -l "${mounted[i]}" || true
  done
  mounted=()
}
trap unmount_all EXIT

packages() {
  # The packages of a root: those of scripts/install-deps.sh and EXTRA_PACKAGES.
  bash "$repo/scripts/install-deps.sh" --list
  printf '%s\n' "${EXTRA_PACKAGES[@]}"
}

recipe() {
  # recipe SUITE: a hash of everything a root is built from.
  { echo "$1 $mirror"; packages; declare -f build_root install_packages mount_into; } |
    sha256sum | cut -c1-16
}

install_packages() {
  # install_packages ROOT: the packages, without recommends; sid's index is often past its
  # Valid-Until date, so apt does not check that date in the roots.
  local root="$1"
  echo 'Acquire::Check-Valid-Until "false";' >"$root/etc/apt/apt.conf.d/99cmmsampling"
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  mount_into "$root"
  local code=0
  chroot "$root" /usr/bin/env -i PATH="$CHROOT_PATH" DEBIAN_FRONTEND=noninteractive \
    sh -c 'apt-get -o Acquire::Check-Valid-Until=false update -qq &&
           apt-get install -y -qq --no-install-recommends "$@" >/dev/null && apt-get clean' \
    sh $(packages) || code=$?
  unmount_all
  return "$code"
}

build_root() {
  # build_root SUITE DIR: a fresh minimal root with the packages, moved into DIR when complete.
  local suite="$1" dir="$2"
  safe_remove "$dir.new" || return 1
  mkdir -p "$dir.new"
  debootstrap --variant=minbase "$suite" "$dir.new" "$mirror" >"$dir.new.log" 2>&1 ||
    { tail -n 20 "$dir.new.log" >&2; return 1; }
  install_packages "$dir.new" || return 1
  recipe "$suite" >"$dir.new/.cmmsampling-recipe"
  safe_remove "$dir" || return 1
  mv "$dir.new" "$dir"
}

ensure_root() {
  # ensure_root SUITE: build the suite's root unless the cached one has the current recipe.
  local suite="$1" dir="$cache/$1" start
  if [ "$(cat "$dir/.cmmsampling-recipe" 2>/dev/null)" = "$(recipe "$suite")" ]; then
    return 0
  fi
  log "$suite: building the root in $dir"
  start=$SECONDS
  build_root "$suite" "$dir" || return 1
  log "$suite: root built in $((SECONDS - start)) s"
}

ensure_debootstrap() {
  command -v debootstrap >/dev/null && return 0
  log "installing debootstrap"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends debootstrap >/dev/null
}

in_root() {
  # in_root SUITE COMMAND: run a shell command in the checkout inside the suite's root, with a clean
  # environment and a fresh /tmp; the checkout is bind-mounted at /work/cmmsampling (and, where
  # they exist, ../shared/testdata and ../shared/reference/qif3/mbd under /work/shared).
  local suite="$1" command="$2" dir="$cache/$1" shared
  unmount_leftovers "$dir"
  rmdir "$dir/work/shared/testdata" "$dir/work/shared/reference/qif3/mbd" "$dir/work/shared/reference/qif3" \
    "$dir/work/shared/reference" "$dir/work/shared" 2>/dev/null || true   # earlier mount points
  mkdir -p "$dir/work/cmmsampling"
  mount --bind "$repo" "$dir/work/cmmsampling" && mounted+=("$dir/work/cmmsampling")
  # The CAD files tests/package/test_real_parts.py reads, the QIF MBD models OCC builds (tests/formats).
  for shared in testdata reference/qif3/mbd; do
    if [ -d "$repo/../shared/$shared" ]; then
      mkdir -p "$dir/work/shared/$shared"
      mount --bind "$repo/../shared/$shared" "$dir/work/shared/$shared" && mounted+=("$dir/work/shared/$shared")
    fi
  done
  mount -t tmpfs tmpfs "$dir/tmp" && mounted+=("$dir/tmp")
  mount_into "$dir"
  local code=0
  chroot "$dir" /usr/bin/env -i PATH="$CHROOT_PATH" HOME=/root LANG=C.UTF-8 \
    CMMSAMPLING_ARTIFACTS="/work/cmmsampling/artifacts/gui-$suite" \
    bash -c "cd /work/cmmsampling && $command" || code=$?
  unmount_all
  return "$code"
}

prepare_addon_remote() {
  # A bare clone of the checkout's HEAD as branch main in artifacts/addon-remote/cmmsampling,
  # ready for git's plain HTTP transport, and the branch's zip archive where GitLab-like hosts
  # keep it (-/archive/main/cmmsampling-main.zip): what tests/addon_manager_install.py serves.
  local remote="$repo/artifacts/addon-remote/cmmsampling"
  rm -rf "$repo/artifacts/addon-remote"
  git init -q --bare "$remote"
  git -C "$repo" push -q "$remote" HEAD:refs/heads/main
  git -C "$remote" update-server-info
  mkdir -p "$remote/-/archive/main"
  git -C "$remote" archive --format=zip --prefix=cmmsampling-main/ \
    -o "$remote/-/archive/main/cmmsampling-main.zip" main
}

ADDON_CHECK='home=$(mktemp -d) && HOME=$home XDG_DATA_HOME=$home/.local/share XDG_CONFIG_HOME=$home/.config \
  CMMSAMPLING_REMOTE=/work/cmmsampling/artifacts/addon-remote freecadcmd tests/addon_manager_install.py'

run_suite() {
  # run_suite SUITE: the README's test command and the Addon Manager check inside the root.
  local suite="$1" start=$SECONDS code=0
  log "$suite: $(in_root "$suite" 'freecadcmd --version 2>/dev/null | head -n 1' || true)"
  in_root "$suite" "bash scripts/test.sh --versions" || code=$?
  log "$suite: scripts/test.sh exited with $code after $((SECONDS - start)) s"
  in_root "$suite" "$ADDON_CHECK" || code=1
  return "$code"
}

main() {
  [ "$(id -u)" -eq 0 ] || { echo "test-matrix.sh must run as root (debootstrap, chroot)" >&2; exit 2; }
  local suites=("$@") status=0 suite
  [ ${#suites[@]} -gt 0 ] || suites=(trixie sid)
  ensure_debootstrap
  mkdir -p "$cache"
  exec 9>"$cache/.lock"
  flock 9   # one matrix run at a time per machine: they share the roots
  prepare_addon_remote
  local ready=()
  for suite in "${suites[@]}"; do
    if ensure_root "$suite"; then
      ready+=("$suite")
    else
      log "$suite: FAILED to build the root"
      status=1
    fi
  done
  [ ${#ready[@]} -eq 0 ] || run_suites "${ready[@]}" || status=1
  exit "$status"
}

run_suites() {
  # run_suites SUITE...: run_suite of every suite at once, each in its own root, its output in
  # artifacts/matrix-<suite>.log, printed in order once it has ended. A suite's tests spend much
  # of their time waiting (the GUI's timers, the worker processes), so on two cores the suites
  # side by side take about as long as the slower one alone. Non-zero when any fails.
  local suite index status=0 pids=() logs=()
  mkdir -p "$repo/artifacts"
  for suite in "$@"; do
    logs+=("$repo/artifacts/matrix-$suite.log")
    run_suite "$suite" >"${logs[-1]}" 2>&1 &
    pids+=("$!")
  done
  for index in "${!pids[@]}"; do
    wait "${pids[index]}" || status=1
    cat "${logs[index]}" >&2
  done
  return "$status"
}

main "$@"
