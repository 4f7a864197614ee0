#!/usr/bin/env bash
# Install the Debian/Ubuntu packages pipeflex needs, only those missing.
set -euo pipefail
packages=(build-essential cmake ninja-build libeigen3-dev libsundials-dev pybind11-dev
  python3-pybind11 python3-dev python3-numpy python3-scipy python3-matplotlib python3-pytest
  python3-pytest-timeout python3-nbclient python3-nbformat python3-ipykernel python3-tqdm
  python3-venv python3-pip python3-setuptools python3-wheel python3-sphinx python3-myst-parser
  libopenblas0-pthread python3-distributed python3-xarray python3-netcdf4 python3-threadpoolctl
  python3-hypothesis python3-yaml python3-meshio
  python3-jedi jupyter-notebook jupyter-nbconvert)  # jedi: the editor test; the front end: `jupyter notebook`, `jupyter nbconvert`
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "Installing missing system packages: ${missing[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
