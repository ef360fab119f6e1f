// libFuzzer target: TUM / Bonn dataset lists (rgb.txt, depth.txt, associations.txt) through
// RgbdDataset::Open. Input: "<rgb.txt>\f<depth.txt>\f<associations.txt>" (form feeds separate the
// files; an empty associations part means no associations.txt). The images 1.0.png .. 3.0.png
// exist (tiny valid PNGs) so well-formed lists get past the file checks and into association
// and loading. Contract: InputError / InvalidOptions or a dataset whose frames are sorted and
// associated within max_time_difference; never a crash.
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/base/error.h"
#include "core/io/dataset.h"
#include "fuzz/fuzz_util.h"

namespace {
namespace fs = std::filesystem;

const std::string& Dir() {
  static const std::string dir = [] {
    const std::string d = dygslam::fuzz::ScratchDir() + "/tum";
    fs::create_directories(d + "/rgb");
    fs::create_directories(d + "/depth");
    for (const char* name : {"1.0", "2.0", "3.0"}) {
      cv::imwrite(d + "/rgb/" + name + ".png", cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 2, 3)));
      cv::imwrite(d + "/depth/" + name + ".png", cv::Mat(4, 6, CV_16UC1, cv::Scalar(5000)));
    }
    return d;
  }();
  return dir;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dygslam;
  const std::string& dir = Dir();
  const auto parts = fuzz::Split(data, size, '\f', 3);
  fuzz::WriteFile(dir + "/rgb.txt", parts[0]);
  fuzz::WriteFile(dir + "/depth.txt", parts[1]);
  std::error_code ec;
  if (parts[2].empty()) {
    fs::remove(dir + "/associations.txt", ec);
  } else {
    fuzz::WriteFile(dir + "/associations.txt", parts[2]);
  }
  try {
    const RgbdDataset d = RgbdDataset::Open(dir);
    for (size_t i = 0; i < d.size(); ++i) {
      const RgbdFrameEntry& f = d.frame(i);
      if (i > 0 && !(d.frame(i - 1).rgb_stamp < f.rgb_stamp)) std::abort();  // unsorted output
      if (std::abs(SecondsBetween(f.rgb_stamp, f.depth_stamp)) > 0.02 + 1e-9 &&
          !fs::exists(dir + "/associations.txt")) {
        std::abort();  // associated beyond max_time_difference
      }
      try {
        d.LoadRgb(i);
        d.LoadDepth(i);
      } catch (const InputError&) {
      }
    }
    for (size_t k = 0; k < d.num_rgb_entries(); ++k) {
      const auto idx = d.FrameForRgbEntry(k);
      if (idx && *idx >= d.size()) std::abort();
    }
  } catch (const InputError&) {
  } catch (const InvalidOptions&) {
  }
  return 0;
}
