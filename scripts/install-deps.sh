#!/usr/bin/env bash
# Installs every Debian 12 package SpacetreeMesh needs to build, test and run.
# find_package(ParaView) pulls in the find modules of every bundled VTK/ParaView module,
# so it needs -dev packages that paraview-dev does not depend on; they are all listed here.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(
  # toolchain and test frameworks
  build-essential cmake ninja-build pkg-config clang-format
  libgtest-dev libbenchmark-dev
  # the fuzz targets and the core's sanitizer build (scripts/fuzz.sh): clang with libFuzzer
  clang libclang-rt-14-dev
  # ParaView 5.11 (bundles VTK 9.2); never libvtk9-dev / python3-vtk9 (they conflict)
  paraview paraview-dev python3-paraview python3-dev python3-numpy
  # find_package(ParaView) dependencies not pulled in by paraview-dev
  qtbase5-dev libqt5opengl5-dev libqt5svg5-dev qttools5-dev qttools5-dev-tools
  libqt5xmlpatterns5-dev qtxmlpatterns5-dev-tools libqt5x11extras5-dev
  libhdf5-openmpi-dev libnetcdf-dev libopenmpi-dev mpi-default-dev python3-mpi4py
  libavcodec-dev libavformat-dev libavutil-dev libswscale-dev
  libgdal-dev libtheora-dev libogg-dev libutfcpp-dev libeigen3-dev libboost-dev
  libexpat1-dev libfreetype-dev libgl2ps-dev libglew-dev libjpeg-dev liblz4-dev liblzma-dev
  libxml2-dev libpng-dev libtiff-dev libx11-dev libxt-dev libgl-dev zlib1g-dev
  libdouble-conversion-dev
  # real test data: NIfTI brain atlases under /usr/share/mricron/templates
  mricron-data
  # independent readers of the finite-element exports in the tests: Gmsh and meshio
  gmsh python3-gmsh python3-meshio
  # the visual quality report (stmesh --report, spacetreemesh.report): headless pictures
  python3-matplotlib
  # offscreen GUI runs
  xvfb xauth
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
echo "install-deps: all ${#packages[@]} packages present"
