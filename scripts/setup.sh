#!/usr/bin/env bash
# One-command set-up on a fresh Debian 12 machine (run as root, or with sudo available).
# Installs the Debian PETSc/MPI/HDF5 stack, makes .venv from /usr/bin/python3 with
# --system-site-packages, and installs the project with its PyPI dependencies (which also
# compiles the C assembly kernel app/assembly/_kernel.c and the signal handler
# app/_hard_stop.c with gcc).
# Running it twice is harmless.
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
PKGS="python3-petsc4py python3-mpi4py python3-h5py-mpi python3-numpy python3-scipy \
  python3-venv python3-pip python3-dev gcc openmpi-bin libopenmpi-dev \
  libglu1-mesa libxcursor1 libxft2 libxinerama1 libxrender1 libxext6 libx11-6 libgl1 libxi6 libxfixes3 libxmu6"
missing=""
for p in $PKGS; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends $missing
fi
if [ ! -x .venv/bin/python ]; then
  /usr/bin/python3 -m venv --system-site-packages .venv
fi
# Debian's python3-petsc4py lives under /usr/lib/petscdir and is found through the
# /usr/lib/petsc alternative, which only the PETSc -dev packages register: point the
# virtual environment at it directly with a .pth file instead.
petsc_py=$(ls -d /usr/lib/petscdir/petsc3.*/x86_64-linux-gnu-real/lib/python3/dist-packages | sort -V | tail -n 1)
site=$(.venv/bin/python -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
echo "$petsc_py" > "$site/debian_petsc4py.pth"
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -e ".[dev]"
.venv/bin/python -c "import petsc4py, mpi4py, h5py, gmsh, meshio
from app.assembly.compiled import kernel
from app import hard_stop
print('set-up OK: petsc4py', petsc4py.__version__, 'gmsh', gmsh.__version__,
      '; assembly kernel', 'built' if kernel() else 'NOT built (numpy fallback)',
      '; signal handler', 'built' if hard_stop.available() else 'NOT built')"
