// Benchmark of the dynamic-object stage on Bonn RGB-D frames (not a test; speed is never
// pass/fail):
//   1. detector time per model and input size, with OpenCV's default threads and with 1 thread;
//   2. detector (1 thread) concurrently with ORB extraction on another thread vs sequentially;
//   3. the dynamic filter per frame (matching, probability) over the sequence with detections.
// Usage: dygslam_dynamic_benchmark [dataset_dir] [--frames N] [--annotate out.png] [--filter-only]
// --annotate: frame 250 with boxes and features (red dynamic, yellow kept in a box, green static)
// and <out>_mask.png with the keyframe dynamic mask.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/paths.h"
#include "core/dynamic/dynamic_filter.h"
#include "core/dynamic/dynamic_mask.h"
#include "core/dynamic/yolo_detector.h"

namespace {
using Clock = std::chrono::steady_clock;
double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

std::vector<std::string> RgbFiles(const std::string& dataset) {
  std::ifstream in(dataset + "/rgb.txt");
  if (!in) throw dygslam::InputError(dataset + "/rgb.txt", 0, "cannot open");
  std::vector<std::string> files;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string stamp, rel;
    ss >> stamp >> rel;
    files.push_back(dataset + "/" + rel);
  }
  return files;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}
}  // namespace

int main(int argc, char** argv) {
  using namespace dygslam;
  std::string dataset = DataDir().empty() ? "" : DataDir() + "/bonn_crowd_part";
  int frames = 360;
  std::string annotate;
  bool filter_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--frames" && i + 1 < argc)
      frames = std::stoi(argv[++i]);
    else if (a == "--annotate" && i + 1 < argc)
      annotate = argv[++i];
    else if (a == "--filter-only")
      filter_only = true;
    else
      dataset = a;
  }
  const std::vector<std::string> files = RgbFiles(dataset);
  frames = std::min<int>(frames, files.size());
  std::vector<cv::Mat> images;
  for (int k = 0; k < frames; ++k) images.push_back(cv::imread(files[k], cv::IMREAD_COLOR));
  std::printf("dataset %s, %d frames, OpenCV threads %d\n", dataset.c_str(), frames,
              cv::getNumThreads());
  const int default_threads = cv::getNumThreads();

  // 1. Detector time per model / input / threads on 40 frames with people (from entry 200).
  const int first = std::min(200, frames - 1), count = std::min(40, frames - first);
  if (!filter_only)
    for (const char* model : {"yolo-fastest-1.1", "yolo-fastest-1.1-xl", "yolo-fastest-1.1_body"}) {
      for (int size : {320, 416}) {
        for (int threads : {default_threads, 1}) {
          cv::setNumThreads(threads);
          DetectorOptions o = DetectorOptionsForModel(model);
          o.input_width = o.input_height = size;
          auto det = YoloDetector::Create(o);
          det->Detect(images[first]);  // warm-up
          std::vector<double> t;
          int boxes = 0;
          for (int k = first; k < first + count; ++k) {
            const auto t0 = Clock::now();
            boxes += det->Detect(images[k]).size();
            t.push_back(Ms(t0, Clock::now()));
          }
          std::printf(
              "detector %-22s %dx%d threads %d: median %.1f ms mean %.1f ms, %.2f boxes/frame\n",
              model, size, size, threads, Median(t), Mean(t), double(boxes) / count);
        }
      }
    }

  // 2. Concurrency: detector on a worker thread (1 OpenCV thread) while the main thread extracts
  // ORB features, vs the two one after the other.
  if (!filter_only) {
    cv::setNumThreads(1);
    auto det = YoloDetector::Create(DetectorOptionsForModel("yolo-fastest-1.1"));
    cv::Ptr<cv::ORB> orb = cv::ORB::create(1000);
    std::vector<double> seq, par, orb_t, det_t;
    for (int k = first; k < first + count; ++k) {
      cv::Mat gray;
      auto t0 = Clock::now();
      cv::cvtColor(images[k], gray, cv::COLOR_BGR2GRAY);
      std::vector<cv::KeyPoint> kps;
      cv::Mat desc;
      orb->detectAndCompute(gray, cv::noArray(), kps, desc);
      auto t1 = Clock::now();
      det->Detect(images[k]);
      auto t2 = Clock::now();
      orb_t.push_back(Ms(t0, t1));
      det_t.push_back(Ms(t1, t2));
      seq.push_back(Ms(t0, t2));
      t0 = Clock::now();
      std::vector<Detection> dets;
      std::thread worker([&] { dets = det->Detect(images[k]); });
      cv::cvtColor(images[k], gray, cv::COLOR_BGR2GRAY);
      orb->detectAndCompute(gray, cv::noArray(), kps, desc);
      worker.join();
      par.push_back(Ms(t0, Clock::now()));
    }
    std::printf(
        "concurrency (1 OpenCV thread): ORB %.1f ms + detector %.1f ms sequential %.1f ms, "
        "concurrent %.1f ms (medians)\n",
        Median(orb_t), Median(det_t), Median(seq), Median(par));
    cv::setNumThreads(default_threads);
  }

  // 3. Filter over the sequence (full mode, yolo-fastest-1.1 boxes, cv::ORB 1000 features).
  for (FilterMode mode : {FilterMode::kFull, FilterMode::kGeometry}) {
    auto det = YoloDetector::Create(DetectorOptionsForModel("yolo-fastest-1.1"));
    cv::Ptr<cv::ORB> orb = cv::ORB::create(1000);
    DynamicFilterOptions fo;
    fo.mode = mode;
    DynamicFilter filter(fo);
    std::vector<double> match_ms, prob_ms;
    double region = 0, dynamic = 0, matched = 0, in_region_kept = 0, homography = 0, model_ok = 0;
    int people_frames = 0;
    for (int k = 0; k < frames; ++k) {
      cv::Mat gray;
      cv::cvtColor(images[k], gray, cv::COLOR_BGR2GRAY);
      std::vector<cv::KeyPoint> kps;
      cv::Mat desc;
      orb->detectAndCompute(gray, cv::noArray(), kps, desc);
      const std::vector<Detection> dets = det->Detect(images[k]);
      const FilterResult r = filter.Process(FilterInput(kps, desc, dets));
      if (k == 0) continue;
      if (std::getenv("DYN_DEBUG") && mode == FilterMode::kFull && !dets.empty() && k % 10 == 0) {
        std::vector<double> d;
        int unmatched = 0, dyn = 0;
        for (const FeatureStatus& f : r.features) {
          if (!f.in_dynamic_region) continue;
          if (f.has_observation)
            d.push_back(f.epipolar_distance);
          else
            ++unmatched;
          dyn += f.is_dynamic;
        }
        std::sort(d.begin(), d.end());
        std::printf(
            "k %d region %d obs %zu unmatched %d dyn %d  d p25 %.2f p50 %.2f p75 %.2f p90 %.2f  "
            "F-in %d/%d H %d\n",
            k, r.num_in_dynamic_region, d.size(), unmatched, dyn, d.empty() ? -1 : d[d.size() / 4],
            d.empty() ? -1 : d[d.size() / 2], d.empty() ? -1 : d[3 * d.size() / 4],
            d.empty() ? -1 : d[9 * d.size() / 10], r.num_f_inliers, r.num_static_matches_used_for_f,
            r.used_homography);
      }
      match_ms.push_back(r.matching_ms);
      prob_ms.push_back(r.probability_ms);
      matched += r.num_matched;
      homography += r.used_homography;
      model_ok += r.motion_model_ok;
      if (!dets.empty() || mode == FilterMode::kGeometry) {
        ++people_frames;
        region += r.num_in_dynamic_region;
        dynamic += r.num_dynamic;
        in_region_kept += r.num_in_dynamic_region - r.num_dynamic;
      }
      if (!annotate.empty() && k == std::min(250, frames - 1) && mode == FilterMode::kFull) {
        cv::Mat vis = images[k].clone();
        for (const Detection& d : dets) cv::rectangle(vis, d.box, cv::Scalar(0, 0, 255), 2);
        for (size_t i = 0; i < kps.size(); ++i) {
          const FeatureStatus& f = r.features[i];
          const cv::Scalar c = f.is_dynamic          ? cv::Scalar(0, 0, 255)
                               : f.in_dynamic_region ? cv::Scalar(0, 255, 255)
                                                     : cv::Scalar(0, 255, 0);
          cv::circle(vis, kps[i].pt, 3, c, cv::FILLED);
        }
        cv::imwrite(annotate, vis);
        // Keyframe dynamic mask from the boxes refined by depth + dynamic-feature disks.
        // Nearest depth image in time (TUM association).
        std::string depth_file;
        {
          const double stamp = std::stod(files[k].substr(files[k].rfind('/') + 1));
          std::ifstream in(dataset + "/depth.txt");
          std::string line;
          double best = 1e9;
          while (std::getline(in, line)) {
            if (line.empty() || line[0] == '#') continue;
            std::istringstream ss(line);
            double t;
            std::string rel;
            ss >> t >> rel;
            if (std::abs(t - stamp) < best) {
              best = std::abs(t - stamp);
              depth_file = dataset + "/" + rel;
            }
          }
        }
        cv::Mat depth16 = cv::imread(depth_file, cv::IMREAD_UNCHANGED), depth;
        if (!depth16.empty()) {
          depth16.convertTo(depth, CV_32F, 1.0 / 5000.0);
          const cv::Mat mask = ComputeDynamicMask(depth.size(), depth, dets, kps, r.DynamicFlags());
          cv::Mat overlay = images[k].clone();
          overlay.setTo(cv::Scalar(255, 0, 255), mask);
          cv::addWeighted(images[k], 0.5, overlay, 0.5, 0, overlay);
          const std::string mask_file = annotate.substr(0, annotate.rfind('.')) + "_mask.png";
          cv::imwrite(mask_file, overlay);
        } else {
          std::printf("no depth image %s (mask not drawn)\n", depth_file.c_str());
        }
      }
    }
    const int n = static_cast<int>(match_ms.size());
    std::printf(
        "filter %-8s over %d frames: matching median %.2f ms (mean %.2f), probability median "
        "%.2f ms (mean %.2f); %.0f matches/frame, motion model %.0f %% (H %.0f %%); on %d "
        "frames with a dynamic region: %.0f features in it, %.0f dynamic, %.0f kept\n",
        ToString(mode), n, Median(match_ms), Mean(match_ms), Median(prob_ms), Mean(prob_ms),
        matched / n, 100 * model_ok / n, 100 * homography / n, people_frames,
        region / std::max(1, people_frames), dynamic / std::max(1, people_frames),
        in_region_kept / std::max(1, people_frames));
  }
  return 0;
}
