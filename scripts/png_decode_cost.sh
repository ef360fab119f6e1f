#!/bin/bash
# CPU cost of decoding a dataset's PNG images: the part of a dataset run's CPU per frame
# that the player / dataset loop spends on decoding rgb + depth PNGs, which a live camera does
# not pay. Compiles a small OpenCV program (cv::imread of every rgb and depth file listed in
# rgb.txt / depth.txt, as the dataset reader loads them) and prints CPU (user + sys of the
# process) per frame over RUNS runs:
#   scripts/png_decode_cost.sh DATASET_DIR [RUNS [BUILD_DIR]]
#   scripts/png_decode_cost.sh ../shared/data/bonn_crowd_part 3 build
# With BUILD_DIR (a build of this repository with libdeflate), each run also decodes the same
# files with the dataset reader's fast path (core/io/png_reader.h) and prints its CPU per frame
# and the ratio against cv::imread measured just before.
set -euo pipefail
dataset=$1 runs=${2:-3} build=${3:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$work/decode.cc" <<'CC'
#include <sys/resource.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#ifdef WITH_FAST_PNG
#include "core/io/png_reader.h"
#endif

static std::vector<std::string> Files(const std::string& dir, const std::string& list) {
  std::ifstream in(dir + "/" + list);
  std::vector<std::string> files;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string stamp, file;
    if (fields >> stamp >> file) files.push_back(dir + "/" + file);
  }
  return files;
}

static double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  const std::string dir = argv[1];
  const auto rgb = Files(dir, "rgb.txt"), depth = Files(dir, "depth.txt");
  const double t0 = CpuSeconds();
  size_t bytes = 0;
  for (const auto& f : rgb) bytes += cv::imread(f, cv::IMREAD_COLOR).total();
  const double t1 = CpuSeconds();
  for (const auto& f : depth) bytes += cv::imread(f, cv::IMREAD_ANYDEPTH).total();
  const double t2 = CpuSeconds();
  std::printf("%zu rgb + %zu depth files: rgb %.2f s, depth %.2f s CPU; %.2f ms per frame (%zu px)",
              rgb.size(), depth.size(), t1 - t0, t2 - t1, 1000 * (t2 - t0) / rgb.size(), bytes);
#ifdef WITH_FAST_PNG
  cv::Mat image;
  int fast = 0;
  for (const auto& f : rgb) fast += dygslam::ReadPngFast(f, &image) ? 1 : 0;
  for (const auto& f : depth) fast += dygslam::ReadPngFast(f, &image) ? 1 : 0;
  const double t3 = CpuSeconds();
  std::printf("; fast path (%d of %zu files) %.2f ms per frame, %.2fx", fast,
              rgb.size() + depth.size(), 1000 * (t3 - t2) / rgb.size(), (t3 - t2) / (t2 - t0));
#endif
  std::printf("\n");
  return 0;
}
CC
if [ -n "$build" ]; then
  here=$(cd "$(dirname "$0")/.." && pwd)
  g++ -O2 -std=c++17 -DWITH_FAST_PNG -I"$here" "$work/decode.cc" "$build/core/io/libdygslam_io.a" \
    -o "$work/decode" $(pkg-config --cflags --libs opencv4) -ldeflate
else
  g++ -O2 -std=c++17 "$work/decode.cc" -o "$work/decode" $(pkg-config --cflags --libs opencv4)
fi
echo "png_decode_cost: $runs runs on $dataset, $(nproc) cores, load at start: $(cut -d' ' -f1-3 /proc/loadavg)"
for r in $(seq 1 "$runs"); do
  echo "  run $r: $("$work/decode" "$dataset")"
done
