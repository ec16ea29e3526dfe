#!/usr/bin/env bash
# Test the project on a fresh Debian root of another (or the same) release, as a new user would set
# it up: the same recipe the Dockerfile runs (FROM debian:RELEASE; bash scripts/install.sh).
#
#   bash scripts/test-release.sh trixie|bookworm [pytest args...]
#   bash scripts/test-release.sh --gen-constraints trixie|bookworm   # rewrite constraints/RELEASE.txt
#
# 1. Installs mmdebstrap on this machine if it is missing (apt-get; needs root).
# 2. Builds a minimal root of RELEASE with mmdebstrap (variant minbase, like the debian:RELEASE
#    image) from this machine's Debian mirrors with the suite swapped (RELEASE, RELEASE-updates,
#    RELEASE-security), trusting this machine's CA certificates and using its local apt.conf.d
#    settings and pip configuration, so the root reaches exactly the registries this machine reaches.
#    Inside it, `scripts/install.sh --apt-only` installs the Debian packages; that root is cached as a
#    folder in $SUTURE_FEM_ROOT_CACHE (default /var/tmp/suture_fem-roots, outside the work tree so
#    every clone on this machine shares it; about 3 GB per release), keyed by the release, the
#    mirrors and install.sh's package list, and rebuilt after $SUTURE_FEM_ROOT_MAX_AGE_DAYS days
#    (default 7). Each run writes into an overlay over it (or a copy), never into the cache.
#    Force a rebuild: SUTURE_FEM_REBUILD_ROOT=1 bash scripts/test-release.sh trixie
#    (or delete /var/tmp/suture_fem-roots).
# 3. Clones this repository's HEAD into the root (/work/suture_fem; uncommitted changes are NOT
#    included: commit first) with ../shared beside it, and runs the README's two commands inside a
#    chroot: the main job at a small force (bash scripts/run-paper.sh --set loading.force_n=0.5),
#    then bash scripts/test.sh with the given pytest arguments (default: tests/unit, tests/contact,
#    tests/integration and one quick MPI test). Both always run; the exit code is non-zero if either
#    failed.
#
# If the root cannot be built for a reason outside the project (the Debian mirror cannot be reached:
# a download failure of mmdebstrap or apt), it prints a line starting with "SKIPPED:" and exits 0.
# Every other failure exits non-zero. Set SUTURE_FEM_KEEP_ROOT=1 to keep the root for a look
# (it stays mounted; the script prints how to remove it).
set -euo pipefail

say() { printf 'test-release: %s\n' "$*"; }
started=$SECONDS
took() { printf '%dm%02ds' $(( (SECONDS - $1) / 60 )) $(( (SECONDS - $1) % 60 )); }

gen=0
if [ "${1:-}" = --gen-constraints ]; then gen=1; shift; fi
release="${1:-}"
case "$release" in
  bookworm|trixie) shift ;;
  *) echo "usage: scripts/test-release.sh [--gen-constraints] bookworm|trixie [pytest args...]" >&2; exit 2 ;;
esac
if [ "$(id -u)" -ne 0 ]; then
  echo "test-release: needs root (mmdebstrap --mode=root, chroot, mounts)" >&2; exit 2
fi
here="$(git -C "$(dirname "${BASH_SOURCE[0]}")" rev-parse --show-toplevel)"
cache="${SUTURE_FEM_ROOT_CACHE:-/var/tmp/suture_fem-roots}"
max_age_days="${SUTURE_FEM_ROOT_MAX_AGE_DAYS:-7}"
work="$(mktemp -d /var/tmp/suture_fem-release.XXXXXX)"
root="$work/root"
log="$work/build.log"

. "$here/scripts/debian-root.sh"  # network_failure, host_mirrors, ..., mounted_under, remove_work
skip() {
  echo "================================================================================"
  echo "SKIPPED: Debian $release root could not be built: $1"
  echo "SKIPPED: (a download from the Debian mirror failed; nothing of the project was tested)"
  echo "================================================================================"
  exit 0
}

cleanup() {
  local rc=$?
  # The chroot's mounts live in a private mount namespace and end with it; unmount anything left
  # (e.g. after a kill) before deleting, and never delete through a mount.
  local m
  if [ "${SUTURE_FEM_KEEP_ROOT:-0}" = 1 ]; then
    say "kept the root, still mounted: $root (when done: umount $root; rm -rf --one-file-system $work)"
    say "total time $(took "$started") (exit code $rc)"
    exit "$rc"
  fi
  for m in $(mounted_under "$work"); do
    umount -l "$m" 2>/dev/null || true
  done
  remove_work "$work"
  say "total time $(took "$started") (exit code $rc)"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# Run a command line inside the root: /proc, /sys, a private /dev (null, zero, random, ..., pts,
# shm for Open MPI's shared-memory transport) mounted in a private mount namespace, a clean
# environment (plus this machine's proxy and pip settings), no standard input.
in_root() {
  local envs=(HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
    LANG=C.UTF-8 TERM=dumb DEBIAN_FRONTEND=noninteractive "CI=${CI:-}")
  local v
  for v in http_proxy https_proxy no_proxy HTTP_PROXY HTTPS_PROXY NO_PROXY PIP_INDEX_URL \
    PIP_EXTRA_INDEX_URL PIP_TRUSTED_HOST PIP_CERT PIP_DEFAULT_TIMEOUT SSL_CERT_FILE REQUESTS_CA_BUNDLE; do
    if [ -n "${!v:-}" ]; then envs+=("$v=${!v}"); fi
  done
  # Local folders the host's pip configuration names (find-links, file:// indexes), read-only.
  local pipdirs
  pipdirs="$(cat /etc/pip.conf /etc/xdg/pip/*.conf /root/.config/pip/*.conf /root/.pip/*.conf 2>/dev/null |
    grep -oE '(file://)?/[^[:space:]]+' | sed 's|^file://||; s|/simple/*$||' | sort -u |
    while read -r d; do if [ -d "$d" ]; then echo "$d"; fi; done | tr '\n' ' ')"
  PIPDIRS="$pipdirs" unshare --mount --propagation private -- /bin/bash -euc '
    r=$1; shift
    for d in $PIPDIRS; do
      mkdir -p "$r$d"; mount --bind "$d" "$r$d"; mount -o remount,bind,ro "$r$d"
    done
    mount -t proc proc "$r/proc"
    mount -t sysfs -o ro sysfs "$r/sys"
    mount -t tmpfs -o mode=755,size=1m tmpfs "$r/dev"
    for n in null zero full random urandom tty; do
      touch "$r/dev/$n"; mount --bind "/dev/$n" "$r/dev/$n"
    done
    mkdir "$r/dev/pts" "$r/dev/shm"
    mount -t devpts -o newinstance,ptmxmode=0666,mode=620 devpts "$r/dev/pts"
    mount -t tmpfs -o mode=1777,size=4g tmpfs "$r/dev/shm"
    ln -s pts/ptmx "$r/dev/ptmx"; ln -s /proc/self/fd "$r/dev/fd"
    ln -s /proc/self/fd/0 "$r/dev/stdin"; ln -s /proc/self/fd/1 "$r/dev/stdout"; ln -s /proc/self/fd/2 "$r/dev/stderr"
    exec chroot "$r" /usr/bin/env -i "$@"
  ' _ "$root" "${envs[@]}" /bin/bash -c "$1" </dev/null
}

# --- 1. mmdebstrap --------------------------------------------------------------------------------
if ! command -v mmdebstrap >/dev/null; then
  say "installing mmdebstrap on this machine"
  if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      mmdebstrap; } >"$log" 2>&1 </dev/null; then
    cat "$log"
    if network_failure "$log"; then skip "mmdebstrap could not be installed on this machine"; fi
    say "FAILED: installing mmdebstrap"; exit 1
  fi
fi

# --- 2. the Debian root ---------------------------------------------------------------------------
mirrors="$(host_mirrors "$release")"
say "Debian $release from:"; sed "s/^/    /" <<<"$mirrors"

git clone -q "$here" "$work/src"
say "testing $(git -C "$work/src" log -1 --format='%h %s' | cut -c1-90) (HEAD; uncommitted changes are not included)"
if [ "$gen" = 1 ]; then  # the working tree's scripts decide what the constraints are
  cp "$here/scripts/install.sh" "$here/scripts/gen-constraints.sh" "$work/src/scripts/"
fi
packages="$(bash "$work/src/scripts/install.sh" --print-apt-packages)"
key="$(printf '%s\n%s\n%s\n' "$release" "$mirrors" "$packages" | sha256sum | cut -c1-12)"
cached="$cache/$release-$key"
mkdir -p "$cache"
# One build at a time per release; runs hold the lock shared, so a rebuild never removes a root in use.
exec 9>"$cache/$release.lock"
flock 9
if [ ! -f "$cached.ready" ] || [ "${SUTURE_FEM_REBUILD_ROOT:-0}" = 1 ] ||
   [ -n "$(find "$cached.ready" -mtime +"$max_age_days")" ]; then
  # Remove this release's older roots (other keys, or this one when rebuilding).
  for old in "$cache/$release"-*; do
    [ -e "$old" ] || continue
    rm -f "$old.ready"; [ -d "$old" ] && rm -rf --one-file-system "$old"
    rm -f "$old"
  done
  t=$SECONDS
  say "building a fresh Debian $release root with mmdebstrap"
  mapfile -t mirror_lines <<<"$mirrors"
  root="$cached.tmp"
  mapfile -t aptopts < <(host_aptopts)
  if ! mmdebstrap --mode=root --variant=minbase "${aptopts[@]}" \
      "$release" "$root" "${mirror_lines[@]}" >"$log" 2>&1 </dev/null; then
    tail -n 30 "$log"
    rm -rf --one-file-system "$root"
    if network_failure "$log"; then skip "mmdebstrap could not download Debian $release"; fi
    say "FAILED: mmdebstrap (not a download failure; see above)"; exit 1
  fi
  say "minimal root built ($(took $t))"
  copy_host_settings "$root"
  t=$SECONDS
  mkdir -p "$root/tmp/suture_fem/scripts"
  cp "$work/src/scripts/install.sh" "$root/tmp/suture_fem/scripts/"
  say "installing the Debian packages of scripts/install.sh inside the root"
  if ! in_root "bash /tmp/suture_fem/scripts/install.sh --apt-only" >"$log" 2>&1; then
    tail -n 30 "$log"
    rm -rf --one-file-system "$root"
    if network_failure "$log"; then skip "apt could not download the Debian $release packages"; fi
    say "FAILED: scripts/install.sh --apt-only inside the Debian $release root"; exit 1
  fi
  tail -n 1 "$log"
  rm -rf "$root/tmp/suture_fem" "$root/var/cache/apt/archives/"*.deb
  mv "$root" "$cached" && touch "$cached.ready"
  say "Debian packages installed ($(took $t)); root cached in $cached ($(du -sh "$cached" | cut -f1))"
else
  say "root from the cache $cached (built $(date -r "$cached.ready" '+%F %R'); SUTURE_FEM_REBUILD_ROOT=1 rebuilds it)"
fi
flock -s 9
# Each run writes into a throw-away layer over the cached root (a copy where overlayfs is missing).
root="$work/root"
mkdir -p "$root" "$work/upper" "$work/overlay-work"
t=$SECONDS
if ! mount -t overlay overlay -o "lowerdir=$cached,upperdir=$work/upper,workdir=$work/overlay-work" "$root" 2>/dev/null; then
  cp -a "$cached/." "$root/"
  say "copied the cached root ($(took $t); no overlayfs here)"
fi

# --- 3. the project inside it ---------------------------------------------------------------------
copy_host_settings "$root"  # again: a package installed above may have rewritten the CA bundle
mkdir -p "$root/work"
mv "$work/src" "$root/work/suture_fem"
shared="$(cd "$here/.." && pwd)/shared"
if [ -d "$shared" ]; then
  cp -a "$shared" "$root/work/shared"
else
  say "warning: no $shared beside the repository; the root has no ../shared either"
fi

if [ "$gen" = 1 ]; then
  mkdir -p "$here/constraints"
  in_root "cd /work/suture_fem && bash scripts/gen-constraints.sh" >"$work/constraints.txt"
  mv "$work/constraints.txt" "$here/constraints/$release.txt"
  cat "$here/constraints/$release.txt"
  say "wrote constraints/$release.txt"
  exit 0
fi

if [ "$#" -eq 0 ]; then  # the fast subset: unit, integration, contact and one quick MPI test
  mpi_test="$(cd "$root/work/suture_fem" &&
    grep -rl --include='test_*.py' 'def test_a_bad_scene_stops_every_rank_with_one_line' tests | head -n 1)"
  subset=()
  for d in tests/unit tests/integration tests/contact; do
    if [ -d "$root/work/suture_fem/$d" ]; then subset+=("$d"); fi
  done
  set -- -rfE "${subset[@]}" ${mpi_test:+"$mpi_test::test_a_bad_scene_stops_every_rank_with_one_line"}
fi
pytest_args="$(printf '%q ' "$@")"

rc=0
t=$SECONDS
say "inside Debian $release: bash scripts/run-paper.sh --set loading.force_n=0.5"
in_root "cd /work/suture_fem && bash scripts/run-paper.sh --set loading.force_n=0.5" || rc=$?
say "main job: exit code $rc ($(took $t), install included)"
t=$SECONDS
say "inside Debian $release: bash scripts/test.sh $pytest_args"
trc=0
in_root "cd /work/suture_fem && bash scripts/test.sh $pytest_args" || trc=$?
say "tests: exit code $trc ($(took $t))"
if [ "$rc" -ne 0 ] || [ "$trc" -ne 0 ]; then
  say "FAILED on Debian $release (main job exit $rc, tests exit $trc)"
  exit 1
fi
say "passed on Debian $release"
