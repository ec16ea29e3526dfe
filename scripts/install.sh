#!/usr/bin/env bash
# Install everything suture_fem needs on a fresh Debian 12 (bookworm) machine.
#
#   scripts/install.sh            Debian packages + .venv + suture_fem and its test tools
#   SUTURE_FEM_EXTRAS=demos scripts/install.sh   also Jupyter for the demos
#
# Running it twice is harmless: apt and pip skip what is already there.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${SUTURE_FEM_VENV:-$here/.venv}"
extras="${SUTURE_FEM_EXTRAS:-test}"

apt_packages=(
  python3-dolfinx python3-gmsh python3-mpi4py python3-petsc4py python3-venv
  python3-dev python3-matplotlib python3-scipy openmpi-bin
  # off-screen rendering for pyvista's VTK wheel
  libgl1 libegl1 libosmesa6 libxrender1 libxcursor1 libxft2 libxinerama1 libglu1-mesa
)

missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  echo "install.sh: installing Debian packages: ${missing[*]}"
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

if [ ! -x "$venv/bin/python" ]; then
  echo "install.sh: creating $venv from Debian's /usr/bin/python3"
  /usr/bin/python3 -m venv --system-site-packages "$venv"
fi

# Keep pip away from the compiled packages Debian's dolfinx/petsc4py were built against.
"$venv/bin/python" -m pip install -q --disable-pip-version-check \
  -c "$here/constraints.txt" -e "$here[$extras]"
# The Jupyter kernel "suture-fem" runs this environment's Python (the demos name it; ipykernel
# comes with the test and demos extras). Installed inside the venv, so it shadows nothing else.
if "$venv/bin/python" -c "import ipykernel" 2>/dev/null; then
  "$venv/bin/python" -m ipykernel install --sys-prefix --name suture-fem \
    --display-name "Python (suture_fem)" >/dev/null
fi
echo "install.sh: ready ($venv)"
