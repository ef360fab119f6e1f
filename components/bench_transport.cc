// Frame transport benchmark: 640x480 RGB-D frames (bgr8 + 16UC1, 1.5 MB) over the frame topic's
// QoS (reliable keep-last 4, SHM 16 MiB + UDPv4 127.0.0.1), writer -> reader, in one process
// (two participants) or between two processes (fork; steady_clock is CLOCK_MONOTONIC, shared by
// processes). Latency = reader callback time - writer time stamped into the sample.
//   dygslam_bench_transport [--frames 150] [--hz 30] [--inproc] [--window N] [--domain N]
//                           [--width W --height H]
// Run it inside a network namespace (components/tests/run_in_netns.sh). A tool of its own (not
// part of any library, not a `dygslam` subcommand); a malformed number is a usage error (exit 2).
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <iostream>
#include <mutex>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "components/convert.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "core/base/number_option.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"

namespace dygslam {

namespace {

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
  double seconds = 0;  // first send -> last receive
  double frames_per_second = 0, megabytes_per_second = 0;
};

using Clock = std::chrono::steady_clock;

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
      .count();
}

msg::RgbdFrame MakeFrame(const TransportBenchOptions& o) {
  RgbdFrameData f;
  f.camera.fx = f.camera.fy = 525;
  f.camera.cx = o.width / 2.0;
  f.camera.cy = o.height / 2.0;
  f.camera.width = o.width;
  f.camera.height = o.height;
  f.rgb = cv::Mat(o.height, o.width, CV_8UC3);
  f.depth = cv::Mat(o.height, o.width, CV_16UC1);
  cv::randu(f.rgb, 0, 255);
  cv::randu(f.depth, 0, 20000);
  return RgbdFrameToMsg(f);
}

// Reader side: collects latencies until `frames` received or timeout.
struct Collector {
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<double> latencies_ms;
  int64_t first_send_ns = 0, last_receive_ns = 0;
  int64_t last_seq = -1;
};

void RunWriter(std::shared_ptr<dds::Participant> participant, const TransportBenchOptions& o,
               const std::function<int64_t()>& acked) {
  dds::Writer<msg::RgbdFramePubSubType> writer(participant, dds::topics::kRgbdFrame,
                                               dds::TopicKind::kRgbdFrame);
  writer.WaitForReaders(1, std::chrono::seconds(20));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let discovery settle
  msg::RgbdFrame frame = MakeFrame(o);
  const auto start = Clock::now();
  for (int i = 0; i < o.frames; ++i) {
    if (o.hz > 0)
      std::this_thread::sleep_until(start +
                                    std::chrono::nanoseconds(static_cast<int64_t>(i * 1e9 / o.hz)));
    if (o.window > 0 && acked) {
      const auto deadline = Clock::now() + std::chrono::seconds(5);
      while (acked() < i - o.window && Clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    }
    const int64_t now = NowNs();
    frame.header().stamp().sec(static_cast<int32_t>(now / 1000000000));
    frame.header().stamp().nanosec(static_cast<uint32_t>(now % 1000000000));
    frame.header().seq(static_cast<uint64_t>(i));
    writer.Write(frame);
  }
  writer.WaitForAcknowledgments(std::chrono::seconds(10));
}

TransportBenchResult Collect(Collector& c, int sent, const TransportBenchOptions& o) {
  TransportBenchResult r;
  r.sent = sent;
  std::lock_guard<std::mutex> lock(c.mutex);
  r.received = static_cast<int>(c.latencies_ms.size());
  std::vector<double> v = c.latencies_ms;
  std::sort(v.begin(), v.end());
  if (!v.empty()) {
    r.median_ms = v[v.size() / 2];
    r.p99_ms = v[std::min(v.size() - 1, static_cast<size_t>(0.99 * v.size()))];
    r.max_ms = v.back();
  }
  r.seconds = (c.last_receive_ns - c.first_send_ns) * 1e-9;
  if (r.seconds > 0) {
    r.frames_per_second = r.received / r.seconds;
    const double bytes = o.width * o.height * 5.0;
    r.megabytes_per_second = r.frames_per_second * bytes / 1e6;
  }
  return r;
}

std::unique_ptr<dds::Reader<msg::RgbdFramePubSubType>> MakeReader(
    std::shared_ptr<dds::Participant> participant, Collector& c) {
  return std::make_unique<dds::Reader<msg::RgbdFramePubSubType>>(
      participant, dds::topics::kRgbdFrame, dds::TopicKind::kRgbdFrame, [&c](msg::RgbdFrame&& f) {
        const int64_t now = NowNs();
        const int64_t sent = static_cast<int64_t>(f.header().stamp().sec()) * 1000000000 +
                             f.header().stamp().nanosec();
        std::lock_guard<std::mutex> lock(c.mutex);
        if (c.latencies_ms.empty()) c.first_send_ns = sent;
        c.latencies_ms.push_back((now - sent) * 1e-6);
        c.last_receive_ns = now;
        c.last_seq = static_cast<int64_t>(f.header().seq());
        c.cv.notify_all();
      });
}

void WaitAll(Collector& c, int frames, double seconds) {
  std::unique_lock<std::mutex> lock(c.mutex);
  c.cv.wait_for(lock, std::chrono::duration<double>(seconds),
                [&] { return static_cast<int>(c.latencies_ms.size()) >= frames; });
}

TransportBenchResult RunTransportBench(const TransportBenchOptions& o) {
  const double timeout_s = 30 + (o.hz > 0 ? o.frames / o.hz : o.frames * 0.05);
  dds::ParticipantOptions popts;
  popts.domain_id = o.domain_id;
  if (o.in_process) {
    popts.name = "bench_reader";
    auto reader_participant = dds::Participant::Create(popts);
    popts.name = "bench_writer";
    auto writer_participant = dds::Participant::Create(popts);
    Collector c;
    auto reader = MakeReader(reader_participant, c);
    std::thread writer([&] {
      RunWriter(writer_participant, o, [&c] {
        std::lock_guard<std::mutex> lock(c.mutex);
        return c.last_seq;
      });
    });
    WaitAll(c, o.frames, timeout_s);
    writer.join();
    return Collect(c, o.frames, o);
  }
  // Two processes: fork before any DDS entity exists in this process. The child writes; the
  // back-pressure window is not available across processes here (no ack channel): window 0.
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    int code = 0;
    try {
      popts.name = "bench_writer";
      TransportBenchOptions child = o;
      child.window = 0;
      RunWriter(dds::Participant::Create(popts), child, nullptr);
    } catch (const std::exception& e) {
      std::cerr << "bench writer: " << e.what() << "\n";
      code = 1;
    }
    std::_Exit(code);
  }
  TransportBenchResult r;
  {
    popts.name = "bench_reader";
    auto participant = dds::Participant::Create(popts);
    Collector c;
    auto reader = MakeReader(participant, c);
    WaitAll(c, o.frames, timeout_s);
    r = Collect(c, o.frames, o);
    int status = 0;
    waitpid(pid, &status, 0);
  }
  return r;
}

std::string FormatTransportBench(const TransportBenchOptions& o, const TransportBenchResult& r) {
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "%dx%d RGB-D (%.2f MB/frame), %s, %s: received %d/%d, latency median %.2f ms, "
                "p99 %.2f ms, max %.2f ms; throughput %.1f frames/s (%.1f MB/s)",
                o.width, o.height, o.width * o.height * 5.0 / 1e6,
                o.in_process ? "in-process (2 participants)" : "two processes",
                o.hz > 0 ? (std::to_string(static_cast<int>(o.hz)) + " Hz").c_str() : "max rate",
                r.received, r.sent, r.median_ms, r.p99_ms, r.max_ms, r.frames_per_second,
                r.megabytes_per_second);
  return buf;
}

int RunBenchTransportCommand(const std::vector<std::string>& args) {
  TransportBenchOptions o;
  try {
    for (size_t i = 0; i < args.size(); ++i) {
      const std::string& a = args[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= args.size()) throw std::invalid_argument(a + " needs a value");
        return args[++i];
      };
      if (a == "--frames") {
        o.frames = static_cast<int>(IntegerOption(a.substr(2), value(), 1, 1000000));
      } else if (a == "--hz") {
        o.hz = NumberOption(a.substr(2), value(), 0, 10000);
      } else if (a == "--inproc") {
        o.in_process = true;
      } else if (a == "--domain") {
        o.domain_id = static_cast<int>(IntegerOption(a.substr(2), value(), 0, 232));
      } else if (a == "--window") {
        o.window = static_cast<int>(IntegerOption(a.substr(2), value(), 0, 1000));
      } else if (a == "--width") {
        o.width = static_cast<int>(IntegerOption(a.substr(2), value(), 1, 16384));
      } else if (a == "--height") {
        o.height = static_cast<int>(IntegerOption(a.substr(2), value(), 1, 16384));
      } else if (a == "--help") {
        std::cout << "usage: dygslam_bench_transport [--frames N] [--hz HZ (0 = max)] "
                     "[--inproc] [--window N (inproc)] [--domain N] [--width W --height H]\n";
        return 0;
      } else {
        throw std::invalid_argument("unknown argument " + a);
      }
    }
  } catch (const std::invalid_argument& e) {
    std::cerr << "dygslam_bench_transport: error: " << e.what() << "\n";
    return 2;
  }
  const TransportBenchResult r = RunTransportBench(o);
  std::cout << FormatTransportBench(o, r) << std::endl;
  return r.received > 0 ? 0 : 1;
}

}  // namespace
}  // namespace dygslam

int main(int argc, char** argv) {
  return dygslam::RunBenchTransportCommand(std::vector<std::string>(argv + 1, argv + argc));
}
