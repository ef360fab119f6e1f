#include "core/dynamic/detection_worker.h"

#include <chrono>
#include <exception>
#include <utility>

#include "core/base/thread_setup.h"

namespace dygslam {

DetectionWorker::DetectionWorker(std::unique_ptr<YoloDetector> detector)
    : detector_(std::move(detector)) {
  if (!detector_) throw InvalidOptions("DetectionWorker: no detector");
  thread_ = std::thread([this] {
    SetCurrentThreadName("detector");
    Run();
  });
}

DetectionWorker::~DetectionWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

DetectionWorker::Ticket DetectionWorker::Submit(const cv::Mat& bgr) {
  Job job;
  job.bgr = bgr;
  job.ms = std::make_shared<double>(0.0);
  Ticket ticket{job.promise.get_future(), job.ms};
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back(std::move(job));
  }
  cv_.notify_one();
  return ticket;
}

void DetectionWorker::Run() {
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stop_ and nothing left
      job = std::move(queue_.front());
      queue_.pop_front();
    }
    try {
      const auto t0 = std::chrono::steady_clock::now();
      std::vector<Detection> found = detector_->Detect(job.bgr);
      *job.ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      job.promise.set_value(std::move(found));
    } catch (...) {
      job.promise.set_exception(std::current_exception());
    }
  }
}

}  // namespace dygslam
