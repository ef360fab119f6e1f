// One long-lived thread that runs a YoloDetector on submitted images, in submission order.
//
//   DetectionWorker worker(YoloDetector::Create(options));
//   DetectionWorker::Ticket t = worker.Submit(rgb);   // returns at once
//   ...                                              // extract features meanwhile
//   std::vector<Detection> boxes = t.result.get();   // rethrows the detector's exception
//
// A thread per image (std::async) would cost a thread start per frame and, worse, leaks OpenCV's
// per-thread parallel_for_ state of every thread that ends (~0.7 KB per frame, found by the soak
// benchmark); one worker keeps that state once.
#pragma once

#include <condition_variable>
#include <deque>
#include <future>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <thread>
#include <vector>

#include "core/base/types.h"
#include "core/dynamic/yolo_detector.h"

namespace dygslam {

class DetectionWorker {
 public:
  struct Ticket {
    std::future<std::vector<Detection>> result;
    std::shared_ptr<const double> detect_ms;  // inference time, valid once result is ready
  };

  explicit DetectionWorker(std::unique_ptr<YoloDetector> detector);
  // Finishes the queued images, then stops the thread.
  ~DetectionWorker();
  DetectionWorker(const DetectionWorker&) = delete;
  DetectionWorker& operator=(const DetectionWorker&) = delete;

  // `bgr` is shared (not copied): the caller must not write into it until the result is ready.
  Ticket Submit(const cv::Mat& bgr);

 private:
  struct Job {
    cv::Mat bgr;
    std::promise<std::vector<Detection>> promise;
    std::shared_ptr<double> ms;
  };
  void Run();

  std::unique_ptr<YoloDetector> detector_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> queue_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace dygslam
