// The arguments the dataset benchmarks share (global_ba_benchmark, cpu_per_frame_benchmark):
//   BENCHMARK DATASET_DIR [--config FILE] [--filter MODE] [--runs N] [--deterministic]
// --runs goes through the project's number parser (a clear usage error, not an uncaught std::stoi
// throw). Header-only: the benchmarks link no test library.
#pragma once

#include <exception>
#include <iostream>
#include <string>

#include "core/base/number_option.h"

namespace dygslam {

struct BenchmarkArgs {
  std::string dataset_dir;
  std::string config;  // "" = DATASET_DIR/camera.yaml
  std::string filter = "full";
  int runs = 1;
  bool deterministic = false;
};

// false for a usage error (the caller prints its usage and exits 2); a bad --runs value is printed
// here. `--deterministic` is accepted only when `allow_deterministic`.
inline bool ParseBenchmarkArgs(int argc, char** argv, bool allow_deterministic,
                               BenchmarkArgs* args) {
  if (argc < 2) return false;
  args->dataset_dir = argv[1];
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (allow_deterministic && a == "--deterministic") {
      args->deterministic = true;
      continue;
    }
    if (i + 1 >= argc) return false;
    const std::string v = argv[++i];
    if (a == "--config") {
      args->config = v;
    } else if (a == "--filter") {
      args->filter = v;
    } else if (a == "--runs") {
      try {
        args->runs = static_cast<int>(IntegerOption("runs", v, 1, 1000));
      } catch (const std::exception& e) {
        std::cerr << e.what() << "\n";
        return false;
      }
    } else {
      return false;
    }
  }
  return true;
}

}  // namespace dygslam
