// Frame transport benchmark: 640x480 RGB-D frames (bgr8 + 16UC1, 1.5 MB) over the frame topic's
// QoS (reliable keep-last 4, SHM 16 MiB + UDPv4 127.0.0.1), writer -> reader, in one process
// (two participants) or between two processes (fork; steady_clock is CLOCK_MONOTONIC, shared by
// processes). Latency = reader callback time - writer time stamped into the sample.
//   dygslam component bench-transport [--frames 150] [--hz 30] [--inproc] [--domain N]
// Run it inside a network namespace (components/tests/run_in_netns.sh).
#pragma once

#include <string>
#include <vector>

namespace dygslam {

struct TransportBenchOptions {
  int frames = 150;
  double hz = 30;  // 0 = as fast as the writer can (throughput)
  int width = 640, height = 480;
  bool in_process = false;
  int domain_id = 0;
  // Writer waits for the reader's acknowledgement of frame k - window (0 = no back-pressure).
  int window = 0;
};

struct TransportBenchResult {
  int sent = 0, received = 0;
  double median_ms = 0, p99_ms = 0, max_ms = 0;
  double seconds = 0;       // first send -> last receive
  double frames_per_second = 0, megabytes_per_second = 0;
};

TransportBenchResult RunTransportBench(const TransportBenchOptions& options);
std::string FormatTransportBench(const TransportBenchOptions& options,
                                 const TransportBenchResult& result);
// CLI entry (args after "bench-transport").
int RunBenchTransportCommand(const std::vector<std::string>& args);

}  // namespace dygslam
