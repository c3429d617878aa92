#!/usr/bin/env bash
# The GPU suite in one command, for a lent NVIDIA machine (Debian/Ubuntu, root, perhaps no internet):
#   bash bench/gpu_suite.sh [--quick] [--out DIR] [any option of bench/gpu_suite.py]
# 1. Python: .venv (or out/gpu-venv) if it imports caustica's dependencies; else a wheel folder
#    ($CAUSTICA_WHEELS, wheels/ or shared/wheels/: pip install --no-index into out/gpu-venv, no internet
#    needed); else `make setup` (needs the internet; a .venv that does not work is moved aside first);
#    else the system python3. caustica runs from src/ (PYTHONPATH), so a moved or copied .venv still works.
# 2. The machine: nvidia-smi, the EGL vendor files and libraries (system.txt).
# 3. bench/gpu_suite.py: `caustica info` per EGL device (the first that is not llvmpipe is used), then every
#    GPU technique and auto on every preset at 512x512 and 1920x1080 within the time left of
#    $GPU_SUITE_SECONDS (default 450: done in under 8 minutes), results.json and results.md written after
#    every run under --out (default $OUT, else out/gpu_suite). `timeout` kills it 30 s past its budget.
set -u
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
OUT_DIR="${OUT:-out/gpu_suite}"
QUICK=0
BUDGET_GIVEN=0
ARGS=()
while [ $# -gt 0 ]; do
    case "$1" in
        --out) OUT_DIR="$2"; shift 2 ;;
        --out=*) OUT_DIR="${1#--out=}"; shift ;;
        --quick) QUICK=1; ARGS+=("$1"); shift ;;
        --budget-s|--budget-s=*) BUDGET_GIVEN=1; ARGS+=("$1"); shift ;;
        *) ARGS+=("$1"); shift ;;
    esac
done
mkdir -p "$OUT_DIR" || { echo "gpu_suite: cannot create $OUT_DIR" >&2; exit 2; }
OUT_DIR="$(cd "$OUT_DIR" && pwd)"
TOTAL="${GPU_SUITE_SECONDS:-450}"
export PYTHONPATH="$ROOT/src${PYTHONPATH:+:$PYTHONPATH}"
# The shared data (the bunny): $CAUSTICA_DATA, else shared/data in the checkout, else caustica's ../shared/data.
if [ -z "${CAUSTICA_DATA:-}" ] && [ -d "$ROOT/shared/data" ]; then export CAUSTICA_DATA="$ROOT/shared/data"; fi
export PIP_DEFAULT_TIMEOUT=15 PIP_RETRIES=1 PIP_DISABLE_PIP_VERSION_CHECK=1  # no internet: fail in seconds
CHECK='import numpy, moderngl, trimesh, embreex, PIL, scipy, caustica.renderer'

say() { echo "gpu_suite: $*"; }
works() { [ -x "$1" ] && "$1" -c "$CHECK" >/dev/null 2>&1; }
why() { "$1" -c "$CHECK" 2>&1 | tail -1; }

PY=""
for venv in .venv out/gpu-venv; do
    if [ -z "$PY" ] && works "$venv/bin/python"; then
        PY="$venv/bin/python"
        say "using $venv ($("$PY" --version 2>&1))"
    elif [ -z "$PY" ] && [ -e "$venv" ]; then
        say "$venv does not work: $(why "$venv/bin/python")"
    fi
done
if [ -z "$PY" ]; then
    WHEELS="${CAUSTICA_WHEELS:-}"
    for dir in wheels shared/wheels; do [ -z "$WHEELS" ] && [ -d "$dir" ] && WHEELS="$dir"; done
    if [ -n "$WHEELS" ]; then
        say "installing the dependencies from $WHEELS into out/gpu-venv, no internet needed (log: $OUT_DIR/setup.log)"
        DEPS="$(python3 -c 'import tomllib; print(" ".join(tomllib.load(open("pyproject.toml", "rb"))["project"]["dependencies"]))' 2>>"$OUT_DIR/setup.log")"
        { python3 -m venv out/gpu-venv && out/gpu-venv/bin/python -m pip install --no-index --find-links "$WHEELS" $DEPS; } \
            >>"$OUT_DIR/setup.log" 2>&1 || say "installing from $WHEELS failed: $(tail -1 "$OUT_DIR/setup.log")"
        works out/gpu-venv/bin/python && PY=out/gpu-venv/bin/python
    fi
fi
if [ -z "$PY" ]; then
    if [ -e .venv ]; then  # make would take its stamp for a finished set-up: moved aside, not deleted
        mkdir -p out; aside="out/venv-broken-$(date +%s)"
        mv .venv "$aside" && say "moved the .venv that does not work to $aside"
    fi
    say "running make setup (needs the internet; at most 5 minutes; log: $OUT_DIR/setup.log)"
    if timeout 300 make setup >>"$OUT_DIR/setup.log" 2>&1 && works .venv/bin/python; then
        PY=.venv/bin/python
    else
        say "make setup FAILED (no internet?); its last lines:"
        tail -5 "$OUT_DIR/setup.log" | sed 's/^/    /'
    fi
fi
if [ -z "$PY" ] && works "$(command -v python3 || echo none)"; then
    PY="$(command -v python3)"
    say "using the system $PY, which has the dependencies"
fi
if [ -z "$PY" ]; then
    say "FAILED: no Python with caustica's dependencies (numpy moderngl trimesh embreex Pillow scipy ...)."
    say "Fix: carry a working .venv, or a wheel folder made where the internet is (python3.11 -m pip download -d wheels"
    say "  numpy moderngl trimesh embreex Pillow OpenEXR pygltflib scipy tqdm), or give the machine the internet for make setup."
    exit 2
fi

{
    echo "date: $(date -Is)"; echo "host: $(uname -a)"; echo "python: $PY ($("$PY" --version 2>&1))"
    if command -v nvidia-smi >/dev/null 2>&1; then
        nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1 | sed 's/^/nvidia-smi: /'
    else
        echo "nvidia-smi: not found (no NVIDIA driver?)"
    fi
    echo "EGL vendor files: $(find /usr/share/glvnd/egl_vendor.d /etc/glvnd/egl_vendor.d -name '*.json' 2>/dev/null | tr '\n' ' ')"
    echo "EGL libraries: $(ldconfig -p 2>/dev/null | grep -oE 'libEGL(_nvidia|_mesa)?\.so[.0-9]*' | sort -u | tr '\n' ' ')"
} | tee "$OUT_DIR/system.txt" | sed 's/^/gpu_suite: /'
ldconfig -p 2>/dev/null | grep -q libEGL_nvidia || say "WARNING: libEGL_nvidia is not installed: EGL will fall back to Mesa's llvmpipe"

EXTRA=()
if [ "$QUICK" = 0 ] && [ "$BUDGET_GIVEN" = 0 ]; then
    LEFT=$(( TOTAL - SECONDS - 30 ))
    [ "$LEFT" -lt 60 ] && LEFT=60
    EXTRA=(--budget-s "$LEFT")
    HARD=$(( LEFT + 30 ))
else
    HARD=$(( TOTAL + 30 ))
fi
say "bench/gpu_suite.py ${ARGS[*]:-} ${EXTRA[*]:-} --out $OUT_DIR (killed after $HARD s at most)"
timeout -k 10 "$HARD" "$PY" -u bench/gpu_suite.py "${ARGS[@]}" "${EXTRA[@]}" --out "$OUT_DIR"
rc=$?
[ "$rc" = 124 ] && say "killed after $HARD s; $OUT_DIR/results.json holds the runs finished before"
say "done in ${SECONDS} s (exit $rc): $OUT_DIR/results.md"
exit "$rc"
