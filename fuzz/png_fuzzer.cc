// libFuzzer target: image files as the dataset loads them (RgbdDataset::LoadRgb / LoadDepth on
// a fuzzed PNG): truncated, corrupt or absurd images must give an InputError naming the file,
// or an image of the expected type and size.
#include <cstdlib>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/base/error.h"
#include "core/io/dataset.h"
#include "fuzz/fuzz_util.h"

namespace {
const std::string& Dir() {
  static const std::string dir = [] {
    namespace fs = std::filesystem;
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    const std::string d = dygslam::fuzz::ScratchDir() + "/png";
    fs::create_directories(d + "/rgb");
    fs::create_directories(d + "/depth");
    dygslam::fuzz::WriteFile(d + "/rgb.txt", "1.0 rgb/1.0.png\n");
    dygslam::fuzz::WriteFile(d + "/depth.txt", "1.0 depth/1.0.png\n");
    cv::imwrite(d + "/rgb/1.0.png", cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::imwrite(d + "/depth/1.0.png", cv::Mat(4, 6, CV_16UC1, cv::Scalar(5000)));
    return d;
  }();
  return dir;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dygslam;
  static const RgbdDataset dataset = RgbdDataset::Open(Dir());
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  fuzz::WriteFile(dataset.frame(0).rgb_path, bytes);
  fuzz::WriteFile(dataset.frame(0).depth_path, bytes);
  try {
    const cv::Mat rgb = dataset.LoadRgb(0, 6, 4);
    if (rgb.type() != CV_8UC3 || rgb.cols != 6 || rgb.rows != 4) std::abort();
  } catch (const InputError&) {
  }
  try {
    const cv::Mat depth = dataset.LoadDepth(0);
    if (depth.type() != CV_16UC1 || depth.empty()) std::abort();
  } catch (const InputError&) {
  }
  return 0;
}
