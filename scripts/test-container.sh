#!/usr/bin/env bash
# Build the project's Dockerfile with a real container engine and check the image, as a user would
# run it:
#
#   bash scripts/test-container.sh [bookworm|trixie] [pytest args...]
#                                   (default: the Dockerfile's own DEBIAN_RELEASE)
#
# 1. Installs Debian's docker.io (dockerd, containerd, runc) on this machine if dockerd is missing.
# 2. Starts a private dockerd of its own: its own pid file, socket and exec root under /run, no
#    bridge and no iptables rules (every build and container uses the host's network), data root in
#    $SUTURE_FEM_ROOT_CACHE/docker (default /var/tmp/suture_fem-roots/docker, beside
#    scripts/test-release.sh's cached roots), kept between runs so a rerun reuses the base image and
#    the Dockerfile's Debian-packages layer. One run at a time uses it (a lock).
# 3. No image registry is needed: the base image debian:RELEASE is made here, a minimal Debian root
#    (mmdebstrap --variant=minbase, like the official image) from this machine's Debian mirrors and
#    with its CA certificates, apt and pip settings (scripts/debian-root.sh), imported with
#    `docker import`; it is rebuilt when those change or after $SUTURE_FEM_ROOT_MAX_AGE_DAYS days
#    (default 7). SUTURE_FEM_REBUILD_ROOT=1 forces a rebuild.
# 4. Builds the Dockerfile from a clone of this repository's HEAD (uncommitted changes are NOT
#    included: commit first), then inside the image: the main job at a small force (the image's
#    default command with --set loading.force_n=0.5, results written to a host folder through
#    `docker run -v`), the same job under `mpirun -n 2`, and a test subset (default: tests/unit,
#    tests/integration and one quick MPI test). It checks that both runs converged to 0.5 N with a
#    finite, positive USUM, that 2 ranks give the serial results (relative 1e-6, as tests/mpi) and
#    that Open MPI printed no warning.
#
# Every daemon it starts is stopped by its pid when it ends (failure or interruption included), and
# nothing is left mounted. Exit codes: 0 passed, 1 failed, 2 bad usage, 77 SKIPPED: the machine
# forbids what the check needs (a download from the Debian mirror or PyPI failed, or the kernel does
# not let dockerd run a container); it then prints lines starting with "SKIPPED:" saying why.
set -euo pipefail

say() { printf 'test-container: %s\n' "$*"; }
started=$SECONDS
took() { printf '%dm%02ds' $(( (SECONDS - $1) / 60 )) $(( (SECONDS - $1) % 60 )); }

here="$(git -C "$(dirname "${BASH_SOURCE[0]}")" rev-parse --show-toplevel)"
default_release="$(sed -n 's/^ARG DEBIAN_RELEASE=//p' "$here/Dockerfile")"
release="${1:-$default_release}"
case "$release" in
  bookworm|trixie) [ "$#" -eq 0 ] || shift ;;
  *) echo "usage: scripts/test-container.sh [bookworm|trixie] [pytest args...]" >&2; exit 2 ;;
esac
if [ "$(id -u)" -ne 0 ]; then
  echo "test-container: needs root (dockerd, mmdebstrap --mode=root)" >&2; exit 2
fi
. "$here/scripts/debian-root.sh"  # network_failure, host_mirrors, ..., mounted_under, remove_work
cache="${SUTURE_FEM_ROOT_CACHE:-/var/tmp/suture_fem-roots}"
max_age_days="${SUTURE_FEM_ROOT_MAX_AGE_DAYS:-7}"
data="$cache/docker"
image="suture-fem-test:$release"
work="$(mktemp -d /var/tmp/suture_fem-container.XXXXXX)"
run="$(mktemp -d /run/suture_fem-docker.XXXXXX)"  # short: unix socket paths stay under 108 bytes
log="$work/step.log"
dockerd_pid=""

skip() {
  echo "================================================================================"
  echo "SKIPPED: the Debian $release container check: $1"
  echo "SKIPPED: (this machine does not allow it; nothing of the image was tested)"
  echo "================================================================================"
  exit 77
}
fail() { say "FAILED: $*"; exit 1; }
# A download from a registry (the Debian mirror or PyPI) that failed.
download_failure() {
  network_failure "$1" || grep -Eq 'Max retries exceeded|Read timed out|Temporary failure in name resolution' "$1"
}
# What only the machine decides: the kernel refuses a namespace, mount or cgroup dockerd needs.
machine_forbids() {
  grep -Eiq 'operation not permitted|permission denied|not supported|no such device|cgroup' "$1"
}

stop_engine() {
  [ -n "$dockerd_pid" ] || return 0
  local containerd_pid i m
  containerd_pid="$(cat "$run/exec/containerd/containerd.pid" 2>/dev/null || true)"
  if kill -0 "$dockerd_pid" 2>/dev/null; then
    "$docker_cli" ps -q 2>/dev/null | xargs -r "$docker_cli" kill >/dev/null 2>&1 || true
    kill -TERM "$dockerd_pid" 2>/dev/null || true
    for i in $(seq 60); do kill -0 "$dockerd_pid" 2>/dev/null || break; sleep 1; done
    if kill -0 "$dockerd_pid" 2>/dev/null; then say "dockerd $dockerd_pid ignored TERM: KILL"; kill -KILL "$dockerd_pid"; fi
  fi
  wait "$dockerd_pid" 2>/dev/null || true
  # dockerd stops the containerd it started; one left behind (dockerd killed) is stopped here.
  if [ -n "$containerd_pid" ] && kill -0 "$containerd_pid" 2>/dev/null; then
    say "stopping containerd $containerd_pid left by dockerd"; kill -TERM "$containerd_pid" || true
    for i in $(seq 20); do kill -0 "$containerd_pid" 2>/dev/null || break; sleep 1; done
    kill -KILL "$containerd_pid" 2>/dev/null || true
  fi
  for m in $(mounted_under "$run") $(mounted_under "$data"); do
    say "unmounting $m (left by the engine)"; umount -l "$m" || true
  done
  dockerd_pid=""
}
cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  stop_engine
  rm -rf --one-file-system "$run"
  remove_work "$work"
  say "total time $(took "$started") (exit code $rc)"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# --- 1. the engine --------------------------------------------------------------------------------
need=()
command -v dockerd >/dev/null || need+=(docker.io)
command -v mmdebstrap >/dev/null || need+=(mmdebstrap)
if ((${#need[@]})); then
  say "installing ${need[*]} on this machine"
  if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      "${need[@]}"; } >"$log" 2>&1 </dev/null; then
    tail -n 30 "$log"
    if network_failure "$log"; then skip "${need[*]} could not be downloaded"; fi
    fail "installing ${need[*]}"
  fi
fi
# The client of the same package as the daemon (another docker client may come first on PATH).
docker_cli="$(dirname "$(command -v dockerd)")/../bin/docker"
[ -x "$docker_cli" ] || docker_cli="$(command -v docker)"
docker() { "$docker_cli" "$@"; }
export DOCKER_HOST="unix://$run/docker.sock" DOCKER_BUILDKIT=0  # the classic builder: no buildx, no front-end image

mkdir -p "$data"
exec 8>"$cache/docker.lock"
flock 8  # one dockerd per data root
t=$SECONDS
dockerd --pidfile "$run/dockerd.pid" --data-root "$data" --exec-root "$run/exec" -H "$DOCKER_HOST" \
  --bridge=none --iptables=false --ip-masq=false --ip-forward=false >"$run/dockerd.log" 2>&1 </dev/null &
dockerd_pid=$!
until docker version >/dev/null 2>&1; do
  if ! kill -0 "$dockerd_pid" 2>/dev/null; then
    tail -n 20 "$run/dockerd.log"
    if machine_forbids "$run/dockerd.log"; then skip "dockerd could not start here (its log above)"; fi
    fail "dockerd exited at start (its log above)"
  fi
  [ $((SECONDS - t)) -lt 300 ] || fail "dockerd did not answer on $DOCKER_HOST in 300 s"
  sleep 1
done
[ "$(cat "$run/dockerd.pid")" = "$dockerd_pid" ] || fail "dockerd's pid file does not name the dockerd started here"
say "dockerd $(docker version -f '{{.Server.Version}}') up, pid $dockerd_pid ($(took $t)); data root $data"

# --- 2. the base image debian:RELEASE --------------------------------------------------------------
mirrors="$(host_mirrors "$release")"
key="$(
  { printf '%s\n%s\n' "$release" "$mirrors"; host_aptopts; sed -n '/^# --- 2/,/^# --- 3/p' "${BASH_SOURCE[0]}"
    cat /etc/ssl/certs/ca-certificates.crt /etc/pip.conf /etc/xdg/pip/* /root/.config/pip/* 2>/dev/null || true
  } | sha256sum | cut -c1-12
)"
have="$(docker image inspect -f '{{index .Config.Labels "suture_fem.base"}} {{.Created}}' "debian:$release" 2>/dev/null || true)"
age_days=$(( ($(date +%s) - $(date -d "${have#* }" +%s 2>/dev/null || echo 0)) / 86400 ))
if [ "${have%% *}" != "$key" ] || [ "$age_days" -gt "$max_age_days" ] || [ "${SUTURE_FEM_REBUILD_ROOT:-0}" = 1 ]; then
  t=$SECONDS
  say "making the base image debian:$release with mmdebstrap --variant=minbase from:"; sed "s/^/    /" <<<"$mirrors"
  mapfile -t mirror_lines <<<"$mirrors"
  mapfile -t aptopts < <(host_aptopts)
  if ! mmdebstrap --mode=root --variant=minbase "${aptopts[@]}" \
      "$release" "$work/base" "${mirror_lines[@]}" >"$log" 2>&1 </dev/null; then
    tail -n 30 "$log"
    if network_failure "$log"; then skip "mmdebstrap could not download Debian $release"; fi
    fail "mmdebstrap (not a download failure; see above)"
  fi
  copy_host_settings "$work/base"
  rm -f "$work/base/etc/resolv.conf"  # the engine provides it
  # As in the official debian:RELEASE image: dpkg skips its fsync calls inside a build layer.
  echo force-unsafe-io >"$work/base/etc/dpkg/dpkg.cfg.d/docker-apt-speedup"
  tar --numeric-owner -C "$work/base" -cf - . |
    docker import --change "LABEL suture_fem.base=$key" --change 'CMD ["bash"]' - "debian:$release" >/dev/null
  rm -rf --one-file-system "$work/base"
  say "base image debian:$release imported ($(took $t), $(docker image inspect -f '{{.Size}}' "debian:$release" | numfmt --to=iec))"
else
  say "base image debian:$release from the data root (made $(date -d "${have#* }" '+%F %R'); SUTURE_FEM_REBUILD_ROOT=1 remakes it)"
fi
if ! docker run --rm --network host --pull=never "debian:$release" true >"$log" 2>&1; then
  cat "$log"
  if machine_forbids "$log"; then skip "dockerd cannot start a container here (above)"; fi
  fail "a trivial container did not run (above)"
fi

# --- 3. the Dockerfile ----------------------------------------------------------------------------
git clone -q "$here" "$work/src"
say "building the Dockerfile for $release from $(git -C "$work/src" log -1 --format='%h %s' | cut -c1-80)"
say "(HEAD; uncommitted changes are not included)"
t=$SECONDS
if ! docker build --network host --build-arg "DEBIAN_RELEASE=$release" -t "$image" "$work/src" >"$log" 2>&1; then
  tail -n 40 "$log"
  if download_failure "$log"; then skip "a download from the Debian mirror or PyPI failed during the build"; fi
  fail "docker build (not a download failure; see above)"
fi
docker image prune -f >/dev/null  # the previous build's layers, now untagged
say "built $image ($(took $t), $(docker image inspect -f '{{.Size}}' "$image" | numfmt --to=iec);" \
  "$(grep -c 'Using cache' "$log" || true) of $(grep -c '^Step ' "$log" || true) steps from the layer cache)"

# --- 4. inside the image --------------------------------------------------------------------------
results="$work/results"
mkdir -p "$results"
force=0.5
runargs=(--rm --network host --pull=never -v "$results:/work/results")
mpienv=(--shm-size=1g -e OMPI_MCA_rmaps_base_oversubscribe=1)  # the image turns Open MPI's CMA reads off
rc=0
t=$SECONDS
say "docker run $image run paper --out /work/results/paper --set loading.force_n=$force"
docker run "${runargs[@]}" "$image" run paper --out /work/results/paper --set "loading.force_n=$force" || rc=$?
say "main job: exit code $rc ($(took $t))"
t=$SECONDS
say "docker run --entrypoint mpirun $image -n 2 suture-fem run paper ... (--out /work/results/paper-2ranks)"
mrc=0
docker run "${runargs[@]}" "${mpienv[@]}" --entrypoint mpirun "$image" -n 2 \
  suture-fem run paper --out /work/results/paper-2ranks --set "loading.force_n=$force" >"$work/mpi.out" 2>&1 || mrc=$?
cat "$work/mpi.out"
say "2 ranks: exit code $mrc ($(took $t))"
crc=0
python3 - "$results/paper/results.json" "$results/paper-2ranks/results.json" "$force" "$work/mpi.out" <<'EOF' || crc=$?
import json, math, pathlib, re, sys

serial_path, par_path, force, mpi_log = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
bad = []
runs = {}
for name, path, ranks in (("serial", serial_path, 1), ("2 ranks", par_path, 2)):
    p = pathlib.Path(path)
    if not p.is_file():
        bad.append(f"{name}: no {p.name} on the host (docker run -v)")
        continue
    r = runs[name] = json.loads(p.read_text())
    last = r["at_forces"][-1] if r.get("at_forces") else {}
    usum = last.get("usum_mm")
    print(f"  {name}: status {r['status']}, {r.get('mpi_ranks')} rank(s), {r.get('dofs')} dofs, "
          f"USUM {usum} mm at {last.get('force_n')} N")
    if r["status"] != "converged" or r.get("mpi_ranks") != ranks:
        bad.append(f"{name}: status {r['status']!r}, mpi_ranks {r.get('mpi_ranks')} (want converged, {ranks})")
    if last.get("force_n") != force or not (isinstance(usum, float) and math.isfinite(usum) and usum > 0):
        bad.append(f"{name}: last report at {last.get('force_n')} N, USUM {usum} (want {force} N, finite > 0)")
    fd = r["force_displacement"]
    if any(b[1] < a[1] for a, b in zip(fd, fd[1:])):
        bad.append(f"{name}: the displacement falls along the force ramp")
if len(runs) == 2:
    a, b = runs["serial"], runs["2 ranks"]
    if (a["dofs"], a["cells"]) != (b["dofs"], b["cells"]):
        bad.append("2 ranks solved another mesh than the serial run")
    for ra, rb in zip(a["at_forces"], b["at_forces"]):
        for q in ("usum_mm", "seqv_pa", "eptoeqv", "reaction_force_n", "strain_energy_j"):
            if not math.isclose(ra[q], rb[q], rel_tol=1e-6):
                bad.append(f"at {ra['force_n']} N, {q}: serial {ra[q]!r}, 2 ranks {rb[q]!r} (rel 1e-6)")
# Open MPI's warnings, and the lines its shared-memory transport prints when the single-copy read it
# chose is refused (Open MPI 4.1: "Read -1, expected 5520, errno = 1").
mpi_noise = re.compile(r"\s*WARNING\b|.*\bRead -1, expected \d+, errno = \d+")
warn = [ln for ln in pathlib.Path(mpi_log).read_text().splitlines() if mpi_noise.match(ln)]
if warn:
    bad.append("Open MPI warned under docker run: " + warn[0])
for b in bad:
    print("  bad:", b)
sys.exit(1 if bad else 0)
EOF
say "results check: exit code $crc"

t=$SECONDS
if [ "$#" -eq 0 ]; then
  set -- -q -rfE tests/unit tests/integration \
    tests/mpi/test_parallel.py::test_a_bad_scene_stops_every_rank_with_one_line
fi
shared="$(cd "$here/.." && pwd)/shared"
shared_mount=()
if [ -d "$shared" ]; then shared_mount=(-v "$shared:/opt/shared:ro"); fi  # ../shared, as beside a clone
say "docker run --entrypoint python $image -m pytest $*"
trc=0
docker run "${runargs[@]}" "${mpienv[@]}" "${shared_mount[@]}" -w /opt/suture_fem --entrypoint python "$image" \
  -m pytest -p no:cacheprovider "$@" || trc=$?
say "tests: exit code $trc ($(took $t))"
stop_engine
if [ "$rc" -ne 0 ] || [ "$mrc" -ne 0 ] || [ "$crc" -ne 0 ] || [ "$trc" -ne 0 ]; then
  fail "in the Debian $release image (main job exit $rc, 2 ranks exit $mrc, results check exit $crc, tests exit $trc)"
fi
say "passed: the Dockerfile's Debian $release image"
