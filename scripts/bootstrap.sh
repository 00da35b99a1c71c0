#!/usr/bin/env bash
# Idempotent set-up on a fresh Debian/Ubuntu machine: LLVM >= 16 for Dr.Jit,
# a virtual environment, the CPU build of torch first, then the project.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VENV:-.venv}
PYTHON=${PYTHON:-python3}

have_llvm() {
    # any one match will do (ls of several patterns fails when one of them matches nothing)
    [ -n "${DRJIT_LIBLLVM_PATH:-}" ] && return 0
    for library in /usr/lib/*/libLLVM-1[6-9].so /usr/lib/*/libLLVM-2[0-9].so /usr/lib/llvm-1[6-9]/lib/libLLVM*.so* \
                   /usr/lib/llvm-2[0-9]/lib/libLLVM*.so*; do
        [ -e "$library" ] && return 0
    done
    return 1
}

if ! have_llvm; then
    echo "bootstrap: installing libllvm19 (Dr.Jit needs LLVM >= 16)"
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    # wait for another apt or dpkg run (a second bootstrap started beside this one) instead of failing on its lock
    APT="$SUDO apt-get -o DPkg::Lock::Timeout=600"
    $APT install -y -q libllvm19 >/dev/null 2>&1 || { $APT update -q >/dev/null && $APT install -y -q libllvm19 >/dev/null; }
fi

if [ ! -x "$VENV/bin/python" ]; then
    echo "bootstrap: creating $VENV"
    "$PYTHON" -m venv "$VENV"
fi
PIP="$VENV/bin/python -m pip --disable-pip-version-check -q"

# torch before anything that depends on it: 2.13.0 is the local CPU wheel;
# any other version would pull gigabytes of CUDA packages.
if ! "$VENV/bin/python" -c "import torch, sys; sys.exit(torch.__version__.split('+')[0] != '2.13.0')" 2>/dev/null; then
    echo "bootstrap: installing torch 2.13.0 (CPU)"
    $PIP install torch==2.13.0
fi

echo "bootstrap: installing gmcpt and its dependencies"
$PIP install -e ".[dev,ray]"
touch "$VENV/.bootstrapped"
