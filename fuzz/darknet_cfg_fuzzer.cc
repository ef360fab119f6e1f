// libFuzzer target: Darknet .cfg files through ParseDarknetCfg. Contract: InputError naming the
// file, or a description with non-negative counts; never a crash, never an integer overflow
// (UBSan) in the parameter count.
#include <cstdlib>

#include "core/base/error.h"
#include "core/dynamic/yolo_detector.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dygslam;
  const std::string path = dygslam::fuzz::ScratchDir() + "/model.cfg";
  dygslam::fuzz::WriteFile(path, std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    const DarknetCfgInfo info = ParseDarknetCfg(path);
    if (info.num_parameters < 0 || info.num_conv_layers < 0) std::abort();
  } catch (const InputError&) {
  }
  return 0;
}
