#!/bin/sh
# Debian libraries for pyvista/VTK off-screen rendering (EGL, with OSMesa as
# VTK's fallback).  Installs only what is missing; needs root and apt-get.
set -e
missing=""
for lib in libEGL.so.1 libGL.so.1 libOSMesa.so; do
    if ! ldconfig -p 2>/dev/null | grep -q "$lib"; then missing="$missing $lib"; fi
done
[ -z "$missing" ] && exit 0
if [ "$(id -u)" != "0" ] || ! command -v apt-get >/dev/null 2>&1; then
    echo "system-deps: missing$missing; install libegl1 libgl1 libosmesa6 (Debian) for off-screen rendering" >&2
    exit 0
fi
echo "system-deps: installing libegl1 libgl1 libosmesa6 (missing:$missing)"
apt-get update -qq >/dev/null
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libegl1 libgl1 libosmesa6 >/dev/null
