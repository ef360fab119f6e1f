// Benchmark of the dynamic-object stage on Bonn RGB-D frames (not a test; speed is never
// pass/fail):
//   1. detector time per model and input size, with OpenCV's default threads and with 1 thread;
//   2. detector (1 thread) concurrently with ORB extraction on another thread vs sequentially;
//   3. the dynamic filter per frame (matching, probability) over the sequence with detections.
// Usage: dygslam_dynamic_benchmark [dataset_dir] [--frames N] [--annotate out.png] [--filter-only]
// (a TUM/Bonn folder; default: bonn_crowd_part of the data folder; depth in units of 1/5000 m)
// --annotate: frame 250 with boxes and features (red dynamic, yellow kept in a box, green static)
// and <out>_mask.png with the keyframe dynamic mask.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <thread>
#include <vector>

#include "core/base/paths.h"
#include "core/dynamic/dynamic_filter.h"
#include "core/dynamic/dynamic_mask.h"
#include "core/dynamic/yolo_detector.h"
#include "core/io/dataset.h"

namespace {
using namespace dygslam;
using Clock = std::chrono::steady_clock;

// Depth units per metre of the Bonn and TUM sequences (their DepthMapFactor).
constexpr double kDepthUnitsPerMetre = 5000.0;

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
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

struct Options {
  std::string dataset;
  int frames = 360;
  std::string annotate;
  bool filter_only = false;
};

Options ParseOptions(int argc, char** argv) {
  Options o;
  o.dataset = DataDir().empty() ? "" : DataDir() + "/bonn_crowd_part";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--frames" && i + 1 < argc)
      o.frames = std::stoi(argv[++i]);
    else if (a == "--annotate" && i + 1 < argc)
      o.annotate = argv[++i];
    else if (a == "--filter-only")
      o.filter_only = true;
    else if (!a.empty() && a[0] == '-')
      throw InvalidOptions("unknown option " + a +
                           " (expected --frames N, --annotate FILE, --filter-only)");
    else
      o.dataset = a;
  }
  return o;
}

// A grey image's ORB features (cv::ORB, 1000 features).
struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};
Features Extract(cv::ORB& orb, const cv::Mat& bgr) {
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  Features f;
  orb.detectAndCompute(gray, cv::noArray(), f.keypoints, f.descriptors);
  return f;
}

// 1. Detector time per model / input / threads on `count` frames from `first`.
void DetectorTimes(const std::vector<cv::Mat>& images, int first, int count, int default_threads) {
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
  cv::setNumThreads(default_threads);
}

// 2. Concurrency: the detector on a worker thread (1 OpenCV thread) while this thread extracts
// ORB features, against the two one after the other.
void Concurrency(const std::vector<cv::Mat>& images, int first, int count, int default_threads) {
  cv::setNumThreads(1);
  auto det = YoloDetector::Create(DetectorOptionsForModel("yolo-fastest-1.1"));
  cv::Ptr<cv::ORB> orb = cv::ORB::create(1000);
  std::vector<double> seq, par, orb_t, det_t;
  for (int k = first; k < first + count; ++k) {
    auto t0 = Clock::now();
    Extract(*orb, images[k]);
    const auto t1 = Clock::now();
    det->Detect(images[k]);
    const auto t2 = Clock::now();
    orb_t.push_back(Ms(t0, t1));
    det_t.push_back(Ms(t1, t2));
    seq.push_back(Ms(t0, t2));
    t0 = Clock::now();
    std::vector<Detection> dets;
    std::thread worker([&] { dets = det->Detect(images[k]); });
    Extract(*orb, images[k]);
    worker.join();
    par.push_back(Ms(t0, Clock::now()));
  }
  std::printf(
      "concurrency (1 OpenCV thread): ORB %.1f ms + detector %.1f ms sequential %.1f ms, "
      "concurrent %.1f ms (medians)\n",
      Median(orb_t), Median(det_t), Median(seq), Median(par));
  cv::setNumThreads(default_threads);
}

// Frame `k` with its boxes and features (red dynamic, yellow kept in a box, green static) into
// `path`, and the keyframe dynamic mask (boxes refined by depth + dynamic-feature disks) into
// PATH_mask.png.
void Annotate(const std::string& path, const cv::Mat& bgr, const cv::Mat& depth16,
              const std::vector<Detection>& dets, const Features& features, const FilterResult& r) {
  cv::Mat vis = bgr.clone();
  for (const Detection& d : dets) cv::rectangle(vis, d.box, cv::Scalar(0, 0, 255), 2);
  for (size_t i = 0; i < features.keypoints.size(); ++i) {
    const FeatureStatus& f = r.features[i];
    const cv::Scalar c = f.is_dynamic          ? cv::Scalar(0, 0, 255)
                         : f.in_dynamic_region ? cv::Scalar(0, 255, 255)
                                               : cv::Scalar(0, 255, 0);
    cv::circle(vis, features.keypoints[i].pt, 3, c, cv::FILLED);
  }
  cv::imwrite(path, vis);
  cv::Mat depth;
  depth16.convertTo(depth, CV_32F, 1.0 / kDepthUnitsPerMetre);
  const cv::Mat mask =
      ComputeDynamicMask(depth.size(), depth, dets, features.keypoints, r.DynamicFlags());
  cv::Mat overlay = bgr.clone();
  overlay.setTo(cv::Scalar(255, 0, 255), mask);
  cv::addWeighted(bgr, 0.5, overlay, 0.5, 0, overlay);
  cv::imwrite(path.substr(0, path.rfind('.')) + "_mask.png", overlay);
}

// 3. The filter over the sequence (yolo-fastest-1.1 boxes, cv::ORB 1000 features) in `mode`.
void FilterOverSequence(FilterMode mode, const RgbdDataset& dataset,
                        const std::vector<cv::Mat>& images, const std::string& annotate) {
  const int frames = static_cast<int>(images.size());
  auto det = YoloDetector::Create(DetectorOptionsForModel("yolo-fastest-1.1"));
  cv::Ptr<cv::ORB> orb = cv::ORB::create(1000);
  DynamicFilterOptions fo;
  fo.mode = mode;
  DynamicFilter filter(fo);
  std::vector<double> match_ms, prob_ms;
  double region = 0, dynamic = 0, matched = 0, in_region_kept = 0, homography = 0, model_ok = 0;
  int people_frames = 0;
  for (int k = 0; k < frames; ++k) {
    const Features features = Extract(*orb, images[k]);
    const std::vector<Detection> dets = det->Detect(images[k]);
    const FilterResult r =
        filter.Process(FilterInput(features.keypoints, features.descriptors, dets));
    if (k == 0) continue;
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
    if (!annotate.empty() && k == std::min(250, frames - 1) && mode == FilterMode::kFull)
      Annotate(annotate, images[k], dataset.LoadDepth(k), dets, features, r);
  }
  const int n = std::max(1, static_cast<int>(match_ms.size()));
  std::printf(
      "filter %-8s over %d frames: matching median %.2f ms (mean %.2f), probability median "
      "%.2f ms (mean %.2f); %.0f matches/frame, motion model %.0f %% (H %.0f %%); on %d "
      "frames with a dynamic region: %.0f features in it, %.0f dynamic, %.0f kept\n",
      ToString(mode), static_cast<int>(match_ms.size()), Median(match_ms), Mean(match_ms),
      Median(prob_ms), Mean(prob_ms), matched / n, 100 * model_ok / n, 100 * homography / n,
      people_frames, region / std::max(1, people_frames), dynamic / std::max(1, people_frames),
      in_region_kept / std::max(1, people_frames));
}

int Run(const Options& o) {
  const RgbdDataset dataset = RgbdDataset::Open(o.dataset);
  const int frames = std::min<int>(o.frames, static_cast<int>(dataset.size()));
  if (frames < 2) throw InvalidOptions("--frames: at least 2 frames with depth are needed");
  std::vector<cv::Mat> images;
  for (int k = 0; k < frames; ++k) images.push_back(dataset.LoadRgb(k));
  const int default_threads = cv::getNumThreads();
  std::printf("dataset %s, %d frames, OpenCV threads %d\n", o.dataset.c_str(), frames,
              default_threads);
  // Timings on 40 frames with people (from entry 200).
  const int first = std::min(200, frames - 1), count = std::min(40, frames - first);
  if (!o.filter_only) {
    DetectorTimes(images, first, count, default_threads);
    Concurrency(images, first, count, default_threads);
  }
  for (FilterMode mode : {FilterMode::kFull, FilterMode::kGeometry})
    FilterOverSequence(mode, dataset, images, o.annotate);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(ParseOptions(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dygslam_dynamic_benchmark: error: %s\n", e.what());
    return 1;
  }
}
