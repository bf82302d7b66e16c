#!/usr/bin/env bash
# Installs every Debian 12 package snowsim needs to build, run, test and chart.
# Idempotent; run as root. Nothing is fetched from anywhere but Debian's archive.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config clang-format
  # sim/: linear algebra (OpenMP comes with g++); zlib's CRC-32 for the checkpoints
  libeigen3-dev zlib1g-dev
  # meshes and volumes: assimp reads OBJ, STL and PLY meshes (sim/geometry/); OpenVDB turns a
  # mesh into a signed distance field and writes the --vdb volumes (its headers need Boost's)
  libassimp-dev libopenvdb-dev libboost-dev
  # scene files and the command line
  nlohmann-json3-dev libcli11-dev
  # render/: off-screen OpenGL, maths, image and video files
  libosmesa6-dev libglm-dev libstb-dev libpng-dev
  libavcodec-dev libavformat-dev libswscale-dev libavutil-dev
  # tests (ffmpeg gives ffprobe for reading videos back)
  libgtest-dev libgmock-dev ffmpeg
  # charts for the speed/accuracy study; OpenMPI: the launcher for its shards and for one run
  # across ranks (its headers for SNOWSIM_MPI)
  gnuplot-nox openmpi-bin libopenmpi-dev
  # fuzzing (scripts/fuzz.sh): clang, libFuzzer's runtime (libclang_rt.fuzzer), llvm-symbolizer
  clang libclang-rt-14-dev llvm
  # tests/sim/io/export_test.cpp: the Blender loader script and the VDB import in Debian's
  # Blender 3.4.1 (about 30 s to install; the test skips itself without it); the script reads PLY
  # through numpy, which Debian's Blender only recommends
  blender python3-numpy
  # python/: the snowsim Python module (pybind11 binds it to Debian's python3.11, numpy holds its
  # arrays), its pytest tests and the plots of examples/python/
  python3-dev pybind11-dev python3-pytest python3-matplotlib
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]})); then
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup.sh: missing packages (${missing[*]}); run this script as root" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
