// Soak benchmark: a dataset looped through the System for a fixed wall time, recording memory
// (RSS) and per-frame time over time. Each loop's stamps continue after the previous loop (+1 s),
// so every loop starts with a jump back to the first camera pose: tracking loss ->
// relocalisation, reported in the CSV.
//
//   reliability_soak DATASET_DIR --minutes M [--config FILE] [--filter MODE] [--out DIR]
//                    [--frames N] [--sample-every N]
// Writes OUT/soak.csv (one row per frame: wall_s, loop, frame, state, total_ms, rss_mb,
// keyframes) and OUT/trajectory.txt, prints a summary (RSS at start / 1 min / end, growth per
// minute over the second half, frame time median / p95 / p99 per window, states).
// SIGINT / SIGTERM stop the loop early; the outputs are still written.
#include <malloc.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/base/log.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "mapping/keyframe_mapper.h"
#include "run/dataset_runner.h"
#include "run/run_settings.h"

namespace {
namespace fs = std::filesystem;
using namespace dygslam;

volatile std::sig_atomic_t g_stop = 0;
extern "C" void OnSignal(int) { g_stop = 1; }

double RssMb() {
  std::ifstream statm("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  statm >> pages_total >> pages_resident;
  return pages_resident * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

// Bytes handed out by malloc and not freed (in-use heap): separates real growth from RSS that
// glibc keeps around after frees (fragmentation, per-thread arenas).
double HeapInUseMb() {
  const struct mallinfo2 mi = mallinfo2();
  return (mi.uordblks + mi.hblkhd) / (1024.0 * 1024.0);
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

struct Row {
  double wall_s, total_ms, rss_mb, heap_mb;
  int loop;
  size_t frame;
  TrackingState state;
  MapStatistics map;
};

int Usage() {
  std::cerr << "usage: reliability_soak DATASET_DIR --minutes M [--config FILE] [--filter MODE] "
               "[--out DIR]"
               " [--frames N] [--sample-every N] [--no-map]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return Usage();
  std::string dataset_dir = argv[1], config, out = "out/soak", filter = "full";
  double minutes = 1;
  size_t max_frames = 0;
  int sample_every = 30;
  bool with_map = true;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--no-map") {
      with_map = false;
      continue;
    }
    if (i + 1 >= argc) return Usage();
    const std::string v = argv[++i];
    if (a == "--minutes")
      minutes = std::stod(v);
    else if (a == "--config")
      config = v;
    else if (a == "--filter")
      filter = v;
    else if (a == "--out")
      out = v;
    else if (a == "--frames")
      max_frames = std::stoul(v);
    else if (a == "--sample-every")
      sample_every = std::max(1, std::stoi(v));
    else
      return Usage();
  }
  try {
    if (config.empty()) config = std::string(DYGSLAM_SOURCE_DIR) + "/config/bonn.yaml";
    RunSettingsRequest request;
    request.settings_path = config;
    request.filter = filter;
    const SystemOptions options = LoadRunConfiguration(request).system;
    const RgbdDataset dataset = RgbdDataset::Open(dataset_dir);
    const size_t n = max_frames > 0 ? std::min(max_frames, dataset.size()) : dataset.size();
    if (n < 2) throw InputError(dataset_dir, 0, "need at least 2 frames");
    const int64_t period_ns = dataset.frame(n - 1).rgb_stamp.nanoseconds() -
                              dataset.frame(0).rgb_stamp.nanoseconds() + 1000000000;
    fs::create_directories(out);

    struct sigaction sa {};
    sa.sa_handler = OnSignal;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);

    SetLogLevel(LogLevel::kWarning);
    std::vector<Row> rows;
    std::ofstream csv(fs::path(out) / "soak.csv.tmp");
    csv << "wall_s,loop,frame,state,total_ms,rss_mb,heap_mb,keyframes,culled_keyframes,map_points,"
           "live_keyframes,"
           "live_points\n";
    const double rss_start = RssMb();
    System system(options);
    // The OctoMap of the keyframes, as the mapper component builds it (culled keyframes removed).
    std::unique_ptr<KeyframeMapper> mapper;
    if (with_map) {
      mapper = std::make_unique<KeyframeMapper>(options.camera, OctoMapOptions());
      system.SetKeyframeCallback([&mapper](const KeyframeData& k) { mapper->Submit(k); });
    }
    struct LoopMap {
      double wall_s;
      OctoMapStats octree;
    };
    std::vector<LoopMap> loop_maps;
    const auto t0 = std::chrono::steady_clock::now();
    auto wall = [&] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    };
    MapStatistics map_sizes;
    double heap_mb = HeapInUseMb();
    int loop = 0;
    std::map<TrackingState, size_t> states;
    size_t relocalisations_after_loop = 0;
    for (; !g_stop && wall() < minutes * 60; ++loop) {
      if (mapper && loop > 0) {  // once per loop: the octree's size (the read rebuilds if due)
        mapper->WithBuilder([&](OctoMapBuilder& b) { loop_maps.push_back({wall(), b.Stats()}); });
        const OctoMapStats& o = loop_maps.back().octree;
        std::fprintf(
            stderr,
            "[soak] loop %d: octree %zu keyframes, %zu leaves, %.1f MB, %zu stored points\n", loop,
            o.num_keyframes, o.num_leaves, o.memory_bytes / 1048576.0, o.num_stored_points);
      }
      bool relocalised = false;
      // The first n frames of the sequence, stamps shifted by one period per loop.
      DatasetRunOptions run;
      run.first_entry = 0;
      run.last_entry = dataset.num_rgb_entries();
      run.image_width = options.camera.width;
      run.image_height = options.camera.height;
      run.prefetch_detections = false;
      run.stamp_offset_ns = loop * period_ns;
      size_t fed = 0;
      run.stop = [&] { return g_stop || fed >= n || wall() >= minutes * 60; };
      RunDatasetFrames(dataset, system, run, [&](size_t entry, const FrameResult& r) {
        const size_t i = *dataset.FrameForRgbEntry(entry);
        ++fed;
        ++states[r.state];
        if (r.state == TrackingState::kRelocalized && loop > 0 && !relocalised) {
          relocalised = true;
          ++relocalisations_after_loop;
        }
        if (rows.size() % sample_every == 0) {
          map_sizes = system.MapSizes();
          heap_mb = HeapInUseMb();
        }
        rows.push_back({wall(), r.times.total_ms, RssMb(), heap_mb, loop, i, r.state, map_sizes});
        const Row& w = rows.back();
        char line[256];
        std::snprintf(line, sizeof(line), "%.3f,%d,%zu,%s,%.3f,%.1f,%.1f,%zu,%zu,%zu,%lld,%lld\n",
                      w.wall_s, w.loop, w.frame, ToString(w.state), w.total_ms, w.rss_mb, w.heap_mb,
                      w.map.keyframes, w.map.culled_keyframes, w.map.map_points,
                      static_cast<long long>(w.map.live_keyframe_objects),
                      static_cast<long long>(w.map.live_point_objects));
        csv << line;
        if (rows.size() % 300 == 0) {
          csv.flush();
          std::fprintf(stderr,
                       "[soak] %.1f min  loop %d  rss %.0f MB  heap %.0f MB  keyframes %zu  points "
                       "%zu  last %.1f ms\n",
                       w.wall_s / 60, loop, w.rss_mb, w.heap_mb, w.map.keyframes, w.map.map_points,
                       w.total_ms);
        }
      });
    }
    system.Shutdown();
    if (mapper) {
      mapper->Flush();
      mapper->WithBuilder([&](OctoMapBuilder& b) {
        loop_maps.push_back({wall(), b.Stats()});
        b.WriteBinary((fs::path(out) / "map.bt").string());
      });
    }
    csv.close();
    fs::rename(fs::path(out) / "soak.csv.tmp", fs::path(out) / "soak.csv");
    WriteTumTrajectory((fs::path(out) / "trajectory.txt").string(), system.Trajectory());
    WriteTumTrajectory((fs::path(out) / "keyframes.txt").string(), system.KeyframeTrajectory());

    // Summary.
    if (rows.empty()) throw std::runtime_error("no frames processed");
    const double total_s = rows.back().wall_s;
    auto rss_at = [&](double s) {
      for (const Row& r : rows)
        if (r.wall_s >= s) return r.rss_mb;
      return rows.back().rss_mb;
    };
    // Growth over the second half: least-squares slope of RSS vs time.
    auto second_half_slope = [&](auto value) {
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      size_t m = 0;
      for (const Row& r : rows) {
        if (r.wall_s < total_s / 2) continue;
        const double y = value(r);
        sx += r.wall_s;
        sy += y;
        sxx += r.wall_s * r.wall_s;
        sxy += r.wall_s * y;
        ++m;
      }
      return m > 1 ? (m * sxy - sx * sy) / (m * sxx - sx * sx) * 60.0 : 0.0;
    };
    const double slope = second_half_slope([](const Row& r) { return r.rss_mb; });
    const double heap_slope = second_half_slope([](const Row& r) { return r.heap_mb; });
    double peak = 0;
    for (const Row& r : rows) peak = std::max(peak, r.rss_mb);
    std::printf("soak: %s, filter %s, %.1f min, %zu frames, %d loops of %zu frames\n",
                dataset_dir.c_str(), filter.c_str(), total_s / 60, rows.size(), loop, n);
    std::printf(
        "rss MB: before System %.0f, 1 min %.0f, half %.0f, end %.0f, peak %.0f; second-half slope "
        "%.2f MB/min\n",
        rss_start, rss_at(60), rss_at(total_s / 2), rows.back().rss_mb, peak, slope);
    std::printf(
        "heap in use MB: 1 min %.0f, end %.0f; second-half slope %.2f MB/min\n",
        [&] {
          for (const Row& r : rows)
            if (r.wall_s >= 60) return r.heap_mb;
          return rows.back().heap_mb;
        }(),
        rows.back().heap_mb, heap_slope);
    const MapStatistics end = system.MapSizes();
    std::printf(
        "map at end: %zu keyframes (%zu culled kept as pose only), %zu points; live objects %lld "
        "keyframes, %lld points; trajectory %zu frames\n",
        end.keyframes, end.culled_keyframes, end.map_points,
        static_cast<long long>(end.live_keyframe_objects),
        static_cast<long long>(end.live_point_objects), system.Trajectory().size());
    const double window = std::max(60.0, total_s / 6);
    for (double w0 = 0; w0 < total_s; w0 += window) {
      std::vector<double> t;
      for (const Row& r : rows)
        if (r.wall_s >= w0 && r.wall_s < w0 + window) t.push_back(r.total_ms);
      if (t.empty()) continue;
      std::printf(
          "  window %5.1f-%5.1f min: %6zu frames, frame ms median %.1f p95 %.1f p99 %.1f max %.1f, "
          "rss %.0f MB\n",
          w0 / 60, std::min(total_s, w0 + window) / 60, t.size(), Percentile(t, 0.5),
          Percentile(t, 0.95), Percentile(t, 0.99), *std::max_element(t.begin(), t.end()),
          rss_at(std::min(total_s, w0 + window)));
    }
    if (!loop_maps.empty()) {
      std::printf("octree (per loop):");
      for (const LoopMap& m : loop_maps)
        std::printf(" %.1f min %zu kf %.1f MB;", m.wall_s / 60, m.octree.num_keyframes,
                    m.octree.memory_bytes / 1048576.0);
      std::printf("\noctree stored points at end: %zu, leaves %zu, rebuilds %zu\n",
                  loop_maps.back().octree.num_stored_points, loop_maps.back().octree.num_leaves,
                  loop_maps.back().octree.num_rebuilds);
    }
    std::printf("states:");
    for (const auto& [s, c] : states) std::printf(" %s %zu", ToString(s), c);
    std::printf("; loops that relocalised after the jump back: %zu of %d\n",
                relocalisations_after_loop, std::max(0, loop - 1));
    // Loop closing: every loop back to the start should be closed as a loop, not only
    // relocalized. Frame ids count the frames fed, so id / n is the soak loop, id % n the frame.
    const LoopClosingStats lc = system.LoopClosingStatistics();
    std::set<int64_t> soak_loops_closed;
    for (const auto& [frame, loop_frame] : lc.loop_frames)
      soak_loops_closed.insert(frame / static_cast<int64_t>(n));
    std::printf(
        "loop closing: %d loops closed in %zu of %d soak loops (%d consistent candidates, %d "
        "keyframes whose candidates all failed the geometry), %d global BAs (%d discarded)\n",
        lc.loops_closed, soak_loops_closed.size(), loop, lc.candidates_detected, lc.loops_rejected,
        lc.global_ba_runs, lc.global_ba_discarded);
    std::printf("loop closing: %d keyframes checked\n", lc.keyframes_checked);
    if (const std::string line = LoopRejectionSummary(lc); !line.empty())
      std::printf("%s\n", line.c_str());
    for (size_t k = 0; k < lc.loop_frames.size(); ++k) {
      if (k == 40) {
        std::printf("  ... %zu more\n", lc.loop_frames.size() - k);
        break;
      }
      const auto [frame, loop_frame] = lc.loop_frames[k];
      const int64_t m = static_cast<int64_t>(n);
      std::printf("  loop: soak loop %lld frame %lld closed with soak loop %lld frame %lld\n",
                  static_cast<long long>(frame / m), static_cast<long long>(frame % m),
                  static_cast<long long>(loop_frame / m), static_cast<long long>(loop_frame % m));
    }
    std::printf("outputs: %s/{soak.csv,trajectory.txt,keyframes.txt%s}\n", out.c_str(),
                mapper ? ",map.bt" : "");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reliability_soak: %s\n", e.what());
    return 1;
  }
  return 0;
}
