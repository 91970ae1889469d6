#!/usr/bin/env bash
# Idempotent set-up for a fresh Debian/Ubuntu machine, sourced by scripts/main.sh and
# scripts/test.sh: the CalculiX solver and gmsh's runtime libraries from apt (only when
# missing), then a virtual environment in .venv with the project and its test extras.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

apt_install() {
    local sudo=""
    if [ "$(id -u)" -ne 0 ]; then
        command -v sudo >/dev/null || { echo "setup: need root (or sudo) to apt-get install $*" >&2; exit 1; }
        sudo="sudo"
    fi
    echo "setup: apt-get install $*" >&2
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

# System packages: ccx (Debian's calculix-ccx), gmsh's shared-library needs, python venv.
pkgs=()
command -v ccx >/dev/null || pkgs+=(calculix-ccx)
# CalculiX's own examples with reference results: the readers are validated on them
[ -d /usr/share/doc/calculix-ccx-test/examples ] || pkgs+=(calculix-ccx-test)
# docker-compose (v1, Debian) only validates docker-compose.yml in the tests: no engine
command -v docker-compose >/dev/null || pkgs+=(docker-compose)
declare -A lib_pkg=(
    [libGLU.so.1]=libglu1-mesa [libGL.so.1]=libgl1 [libXcursor.so.1]=libxcursor1
    [libXft.so.2]=libxft2 [libXinerama.so.1]=libxinerama1 [libXrender.so.1]=libxrender1
    [libfontconfig.so.1]=libfontconfig1 [libgomp.so.1]=libgomp1 [libX11.so.6]=libx11-6
)
for lib in "${!lib_pkg[@]}"; do
    ldconfig -p 2>/dev/null | grep -q "$lib" || pkgs+=("${lib_pkg[$lib]}")
done
python3 -c 'import ensurepip, venv' 2>/dev/null || pkgs+=(python3-venv)
[ ${#pkgs[@]} -eq 0 ] || apt_install "${pkgs[@]}"

python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' \
    || { echo "setup: Python >= 3.11 is required (found $(python3 --version))" >&2; exit 1; }

# Virtual environment; reinstall only when pyproject.toml changed.
stamp=".venv/.installed-$(sha256sum pyproject.toml | cut -c1-16)"
if [ ! -f "$stamp" ]; then
    [ -x .venv/bin/python ] || python3 -m venv .venv
    .venv/bin/python -m pip install -q --upgrade pip
    # "compat" editable mode puts the project root on sys.path (a .pth file). The default
    # mode's import hook loses against namespace directories of the same name, and Dask
    # workers put their scratch folder - which holds a "storage" directory - first on
    # sys.path, shadowing our storage package.
    .venv/bin/python -m pip install -q -e ".[test,s3,slurm,docs]" --config-settings editable_mode=compat
    rm -f .venv/.installed-* && touch "$stamp"
fi
export PATH="$root/.venv/bin:$PATH"
