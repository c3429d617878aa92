#!/bin/sh
# Install the system libraries caustica needs when they are missing:
# Mesa's EGL and llvmpipe (headless OpenGL 4.5 on the CPU), Python's venv, and
# LLVM 19 for the Mitsuba reference renderer, Xvfb for the viewer's tests.
set -e
need=""
ldconfig -p | grep -q 'libEGL_mesa.so' || need="$need libegl1 libegl-mesa0 libgl1-mesa-dri"
ldconfig -p | grep -q 'libEGL.so.1' || need="$need libegl1"
python3 -c 'import ensurepip, venv' 2>/dev/null || need="$need python3-venv"
# Mitsuba 3's llvm variants need LLVM 19 (Debian's default LLVM 15 crashes them).
ldconfig -p | grep -q 'libLLVM.so.19\|libLLVM-19' || need="$need libllvm19"
# The viewer tests open a real window on a virtual X server.
command -v Xvfb >/dev/null 2>&1 || need="$need xvfb"
if [ -n "$need" ]; then
    if [ "$(id -u)" != 0 ]; then
        echo "caustica: missing system packages:$need; run: sudo apt-get install -y$need" >&2
        exit 2
    fi
    echo "caustica: installing system packages:$need"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq $need >/dev/null
fi
