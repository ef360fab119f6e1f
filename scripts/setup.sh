#!/usr/bin/env bash
# The one place that lists the Debian packages dygslam needs (build, test, run).
# Installs only what is missing. Used by the Makefile, .ci/run and docker/Dockerfile.
#   scripts/setup.sh            build + test dependencies
#   scripts/setup.sh --runtime  print runtime package names only (for the Docker runtime stage)
set -euo pipefail

BUILD_PACKAGES=(
  build-essential cmake pkg-config git ca-certificates
  libopencv-dev libeigen3-dev libceres-dev liboctomap-dev libyaml-cpp-dev libdeflate-dev
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools
  libgtest-dev googletest
  cyclonedds-dev cyclonedds-tools
  iproute2 python3 python3-matplotlib python3-numpy
  docker-compose
  clang libclang-rt-14-dev
)

# Runtime (docker/Dockerfile): the packages of the shared libraries `dygslam` links (readelf
# NEEDED; their own dependencies come with them; Ceres is linked statically, so its libraries glog,
# cholmod, cxsparse, ATLAS instead of libceres3). No python3-matplotlib: in Debian 12 it pulls
# scipy -> pythran -> g++ and -dev packages (`dygslam eval` prints the numbers without the plot).
# Checked against the built binary by the test docker/RuntimePackagesCoverBinary.
RUNTIME_PACKAGES=(
  libopencv-core406 libopencv-imgproc406 libopencv-imgcodecs406 libopencv-features2d406
  libopencv-calib3d406 libopencv-dnn406 libopencv-contrib406
  libgoogle-glog0v6 libcholmod3 libcxsparse3 libatlas3-base
  liboctomap1.9 libyaml-cpp0.7 libfastrtps2.9 libfastcdr1 libdeflate0
)

if [[ "${1:-}" == "--runtime" ]]; then
  echo "${RUNTIME_PACKAGES[@]}"
  exit 0
fi

missing=()
for p in "${BUILD_PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed"; then
    missing+=("$p")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "setup: all ${#BUILD_PACKAGES[@]} Debian packages present"
  exit 0
fi

echo "setup: installing ${#missing[@]} missing packages: ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
