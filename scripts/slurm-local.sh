#!/usr/bin/env bash
# A single-node Slurm cluster on 127.0.0.1, for trying and testing `suture-fem sweep --slurm` (docs/slurm.md).
#
#   scripts/slurm-local.sh up       install slurm-wlm, munge and libpmix-dev if missing (apt-get), start munged,
#                                   slurmctld and slurmd as root, wait until the node is idle
#   scripts/slurm-local.sh down     stop the daemons `up` started (by their pid files) and unmount what it mounted
#   scripts/slurm-local.sh status   print the node's state (sinfo)
#   scripts/slurm-local.sh env      print the export line the Slurm commands need (SLURM_CONF)
#
# No systemd and no cgroups are used (ProctrackType=proctrack/linuxproc, TaskPlugin=task/none), but
# slurmd refuses to start without a cgroup file system, so `up` mounts one on /sys/fs/cgroup when
# nothing is mounted there (and `down` unmounts it; see ensure_cgroup_fs). Everything else lives in one folder,
# $SUTURE_SLURM_DIR (default /var/tmp/suture_fem-slurm): slurm.conf, munge's key and socket, the spool,
# the logs and the pid files. Slurm's commands find the configuration through SLURM_CONF (`env` prints
# it); when /etc/slurm/slurm.conf does not exist, `up` links it there as well and `down` removes the link.
# Exit code 77 ("skipped") when the machine forbids what the cluster needs (not root, no apt, no
# packages, no cgroup file system can be mounted), 1 for any other failure.
set -euo pipefail

DIR="${SUTURE_SLURM_DIR:-/var/tmp/suture_fem-slurm}"
CONF="$DIR/slurm.conf"
SKIP=77

say() { echo "slurm-local: $*" >&2; }
skip() { say "SKIPPED: $*"; exit "$SKIP"; }

install_packages() {
  if command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v munged >/dev/null \
      && command -v sbatch >/dev/null && dpkg -s libpmix-dev >/dev/null 2>&1; then
    return 0
  fi
  command -v apt-get >/dev/null || skip "slurm-wlm is not installed and there is no apt-get to install it"
  say "installing slurm-wlm munge libpmix-dev"
  apt-get update -qq || skip "apt-get update failed (no package mirror reachable?)"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    slurm-wlm munge libpmix-dev >"$DIR/apt.log" 2>&1 || { tail -5 "$DIR/apt.log" >&2; skip "apt-get install failed"; }
}

# slurmd needs a cgroup file system even with the cgroup plugins unused: Slurm 22.05 stops with "Unable
# to initialize cgroup plugin" when /sys/fs/cgroup is empty, and with "Hybrid mode is not supported" when
# cgroup2 is mounted there while the kernel also runs cgroup v1 hierarchies (/proc/self/cgroup lists
# them). So where nothing is mounted (a chroot, some containers): on such a hybrid kernel a tmpfs with a
# named v1 hierarchy at systemd/ (what 22.05's cgroup/v1 plugin looks for), else cgroup2. Every mount is
# recorded in $DIR/mounted and `down` unmounts them in reverse order.
ensure_cgroup_fs() {
  local fstype
  fstype="$(stat -f -c %T /sys/fs/cgroup 2>/dev/null || true)"
  case "$fstype" in
    cgroup2fs | tmpfs) [ -n "$(ls -A /sys/fs/cgroup 2>/dev/null)" ] && return 0 ;;
  esac
  mkdir -p /sys/fs/cgroup 2>/dev/null || true
  : >"$DIR/mounted"
  if grep -qv '^0::' /proc/self/cgroup; then
    mount_recorded -t tmpfs -o mode=755,size=1m cgroup_root /sys/fs/cgroup
    mkdir -p /sys/fs/cgroup/systemd
    mount_recorded -t cgroup -o none,name=systemd cgroup /sys/fs/cgroup/systemd
  else
    mount_recorded -t cgroup2 none /sys/fs/cgroup
  fi
  say "mounted $(awk '$2 ~ "^/sys/fs/cgroup" {print $3 " on " $2}' /proc/mounts | tail -n 2 | paste -sd, -)" \
    "(down unmounts it)"
}

mount_recorded() {
  local target="${*: -1}"
  if ! mount "$@" 2>"$DIR/mount.log"; then
    unmount_recorded
    skip "no cgroup file system on /sys/fs/cgroup and mounting one is not allowed: $(head -n 1 "$DIR/mount.log")"
  fi
  echo "$target" >>"$DIR/mounted"
}

unmount_recorded() {
  [ -s "$DIR/mounted" ] || { rm -f "$DIR/mounted"; return 0; }
  local target
  for target in $(tac "$DIR/mounted"); do
    umount "$target" || { say "could not unmount $target"; return 1; }
  done
  rm -f "$DIR/mounted"
}

write_conf() {
  local node cpus mem
  node="$(hostname -s)"
  cpus="$(nproc)"
  mem="$(awk '/MemTotal/ {print int($2 / 1024 * 0.8)}' /proc/meminfo)"
  mkdir -p "$DIR/state" "$DIR/spool" "$DIR/log" "$DIR/munge"
  cat >"$CONF" <<EOF
# written by scripts/slurm-local.sh: one node on 127.0.0.1, no systemd, no cgroups
ClusterName=suturefem
SlurmctldHost=$node(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$DIR/munge/munge.socket
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
SlurmctldPort=${SUTURE_SLURM_PORT:-6817}
SlurmdPort=$(( ${SUTURE_SLURM_PORT:-6817} + 1 ))
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
KillWait=10
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
EOF
  # Slurm 24.05 and later (Debian 13: 24.11) detect the cgroup version when slurmd starts and stop on a
  # hybrid v1/v2 hierarchy ("Hybrid mode is not supported"); "disabled" (new in 24.05) skips cgroups.
  local version
  version="$(slurmd -V | grep -oE '[0-9]+\.[0-9]+' | head -n 1)"
  if [ "$(printf '%s\n' 24.05 "$version" | sort -V | head -n 1)" = 24.05 ]; then
    echo "CgroupPlugin=disabled" >"$DIR/cgroup.conf"
  else
    rm -f "$DIR/cgroup.conf"
  fi
}

start_munge() {
  if [ ! -s "$DIR/munge/munge.key" ]; then
    (umask 077 && dd if=/dev/urandom of="$DIR/munge/munge.key" bs=1024 count=1 status=none)
  fi
  chmod 700 "$DIR/munge"
  munged --force --socket="$DIR/munge/munge.socket" --key-file="$DIR/munge/munge.key" \
    --pid-file="$DIR/munged.pid" --log-file="$DIR/log/munged.log" --seed-file="$DIR/munge/munged.seed"
}

alive() { [ -s "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

up() {
  [ "$(id -u)" -eq 0 ] || skip "needs root (it starts the daemons and may install packages)"
  mkdir -p "$DIR"
  if alive "$DIR/slurmctld.pid" && alive "$DIR/slurmd.pid"; then
    say "already up ($DIR)"
    print_env
    return 0
  fi
  local t0=$SECONDS
  install_packages
  ensure_cgroup_fs
  write_conf
  if [ ! -e /etc/slurm/slurm.conf ] && [ ! -L /etc/slurm/slurm.conf ]; then
    mkdir -p /etc/slurm
    ln -s "$CONF" /etc/slurm/slurm.conf
    echo /etc/slurm/slurm.conf >"$DIR/linked"
  fi
  export SLURM_CONF="$CONF"
  alive "$DIR/munged.pid" || start_munge
  alive "$DIR/slurmctld.pid" || slurmctld -f "$CONF"
  alive "$DIR/slurmd.pid" || slurmd -f "$CONF" -N "$(hostname -s)"
  local i
  for i in $(seq 1 60); do
    if sinfo -h -o %t 2>/dev/null | grep -qx idle; then
      say "up in $((SECONDS - t0)) s: $(sinfo -h -o '%P %D %c %t' | head -1) ($DIR)"
      print_env
      return 0
    fi
    sleep 1
  done
  say "the node did not become idle in 60 s; the logs:"
  tail -n 20 "$DIR"/log/*.log >&2 || true
  down
  exit 1
}

stop_pid() {
  local name=$1 file="$DIR/$1.pid" pid i
  [ -s "$file" ] || return 0
  pid="$(cat "$file")"
  if kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid" 2>/dev/null || true
    for i in $(seq 1 30); do kill -0 "$pid" 2>/dev/null || break; sleep 0.5; done
    if kill -0 "$pid" 2>/dev/null; then
      say "$name (pid $pid) did not stop on SIGTERM; sending SIGKILL"
      kill -KILL "$pid" 2>/dev/null || true
    fi
  fi
  rm -f "$file"
}

down() {
  local t0=$SECONDS
  # Jobs first: their steps (slurmstepd) are slurmd's, cancelled through Slurm and not by name.
  if alive "$DIR/slurmctld.pid"; then
    SLURM_CONF="$CONF" scancel --quiet --user=root 2>/dev/null || true
    local i
    for i in $(seq 1 30); do
      [ -z "$(SLURM_CONF="$CONF" squeue -h -o %i 2>/dev/null)" ] && break
      sleep 1
    done
  fi
  stop_pid slurmd
  stop_pid slurmctld
  stop_pid munged
  if [ -s "$DIR/linked" ]; then
    [ "$(readlink /etc/slurm/slurm.conf 2>/dev/null)" = "$CONF" ] && rm -f /etc/slurm/slurm.conf
    rm -f "$DIR/linked"
  fi
  unmount_recorded
  say "down in $((SECONDS - t0)) s"
}

print_env() { echo "export SLURM_CONF=$CONF"; }

case "${1:-}" in
  up) up ;;
  down) down ;;
  status) SLURM_CONF="$CONF" sinfo ;;
  env) print_env ;;
  *) echo "usage: $0 up|down|status|env" >&2; exit 2 ;;
esac
