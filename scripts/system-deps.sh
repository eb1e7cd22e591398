#!/bin/sh
# Debian packages: libraries for pyvista/VTK off-screen rendering (EGL, with
# OSMesa as VTK's fallback), SuiteSparse's headers for the optional CHOLMOD
# build (scikit-sparse) and OpenBLAS for CHOLMOD's dense kernels (Debian's
# reference BLAS made its supernodal factorisations 1.5-2x slower).  Installs
# only what is missing; needs root and apt-get.
set -e
missing=""
packages=""
for pair in libEGL.so.1:libegl1 libGL.so.1:libgl1 libOSMesa.so:libosmesa6 \
            libopenblas.so.0:libopenblas0-pthread; do
    lib=${pair%%:*}
    if ! ldconfig -p 2>/dev/null | grep -q "$lib"; then
        missing="$missing $lib"; packages="$packages ${pair#*:}"
    fi
done
if [ ! -f /usr/include/suitesparse/cholmod.h ]; then
    missing="$missing cholmod.h"; packages="$packages libsuitesparse-dev"
fi
[ -z "$missing" ] && exit 0
if [ "$(id -u)" != "0" ] || ! command -v apt-get >/dev/null 2>&1; then
    echo "system-deps: missing$missing; install$packages (Debian): off-screen rendering and CHOLMOD" >&2
    exit 0
fi
echo "system-deps: installing$packages (missing:$missing)"
apt-get update -qq >/dev/null
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $packages >/dev/null
