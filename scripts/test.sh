#!/usr/bin/env bash
# Set everything up (scripts/install.sh) and run the whole test suite.
# Extra arguments go to pytest, e.g. scripts/test.sh -k scene
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/install.sh"
cd "$here"
# One OpenMP thread per process unless set (MPI ranks are the parallelism; trixie's SuperLU_dist is
# OpenMP-threaded), and shared memory, not TCP, between the MPI ranks of this machine (Open MPI 5
# warns about TCP pairing once per rank in a container; "^tcp" is valid for Open MPI 4.1 and 5).
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}" OMPI_MCA_btl="${OMPI_MCA_btl:-^tcp}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
exec "$here/.venv/bin/python" -m pytest "$@"
