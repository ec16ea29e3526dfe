#!/usr/bin/env bash
# Set everything up (scripts/install.sh) and run the main job: the built-in `paper` scene
# (4 hollow cones pulled to 4 N). Extra arguments go to `suture-fem run`.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/install.sh"
cd "$here"
exec "$here/.venv/bin/suture-fem" run paper --out "${SUTURE_FEM_OUT:-results/paper}" "$@"
