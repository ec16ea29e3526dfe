#!/usr/bin/env bash
# The Slurm tests (tests/mpi/test_slurm.py, marker "slurm") on a one-node cluster of this machine:
# scripts/slurm-local.sh up, the tests, then down (also when they fail or the script is stopped).
# Passes as "SKIPPED" only when slurm-local.sh reports that the machine forbids the cluster (exit 77:
# not root, no packages, no cgroup file system); then the tests cannot run here. Extra arguments go to pytest.
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
rc=0
bash scripts/slurm-local.sh up >/dev/null || rc=$?
if [ "$rc" -eq 77 ]; then
  echo "test-slurm: SKIPPED: this machine cannot run a Slurm cluster (see the line above); the Slurm tests did not run" >&2
  exit 0
fi
[ "$rc" -eq 0 ] || { echo "test-slurm: the cluster did not come up (exit $rc)" >&2; exit "$rc"; }
pytest_pid=""
finish() {
  [ -n "$pytest_pid" ] && kill -TERM "$pytest_pid" 2>/dev/null && wait "$pytest_pid" 2>/dev/null
  bash scripts/slurm-local.sh down || true
}
trap finish EXIT
trap 'exit 143' TERM INT
eval "$(bash scripts/slurm-local.sh env)"
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}" OMPI_MCA_btl="${OMPI_MCA_btl:-^tcp}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export SUTURE_SLURM_REQUIRED=1  # from here on an unreachable cluster fails the tests instead of skipping them
# In the background, so that a TERM (CI's timeout) reaches the trap at once and the cluster still goes down.
"$here/.venv/bin/python" -m pytest -m slurm tests/mpi/test_slurm.py "$@" &
pytest_pid=$!
rc=0
wait "$pytest_pid" || rc=$?
pytest_pid=""
exit "$rc"
