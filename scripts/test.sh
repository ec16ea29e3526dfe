#!/usr/bin/env bash
# Set everything up (scripts/install.sh) and run the whole test suite.
# Extra arguments go to pytest, e.g. scripts/test.sh -k scene
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/install.sh"
cd "$here"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
exec "$here/.venv/bin/python" -m pytest "$@"
