#include "run/run_settings.h"

#include <filesystem>
#include <string>
#include <utility>

#include "core/base/error.h"
#include "core/dynamic/yolo_detector.h"
#include "mapping/octomap_settings.h"
#include "run/settings_table.h"
#include "run/system_config.h"

namespace dygslam {

RunConfiguration LoadRunConfiguration(const RunSettingsRequest& request) {
  RunConfiguration c;
  c.settings = LoadSettings(request.settings_path, request.read);
  c.system = SystemOptionsFromSettings(c.settings);
  ReadOptions(c.settings.reader, &c.octomap);
  ApplyFilterConfiguration(request.filter, &c.system);
  if (request.deterministic) MakeDeterministic(&c.system);
  return c;
}

void MakeDeterministic(SystemOptions* options) {
  options->deterministic = true;
  // One OpenCV thread for the detector in every mode (the pipeline's detector component uses one
  // too): detections are then bit-identical between --direct and the pipeline.
  options->detector.num_threads = 1;
}

void ResolveDetectorModel(SystemOptions* options) {
  if (!options->NeedsDetections()) return;
  if (options->detector.cfg_path.empty()) {
    const int threads = options->detector.num_threads;
    options->detector = DetectorOptionsForModel("yolo-fastest-1.1");
    options->detector.num_threads = threads;
  }
  const DetectorOptions& d = options->detector;
  for (const auto& [file, what] :
       {std::pair{d.cfg_path, "cfg"}, std::pair{d.weights_path, "weights"},
        std::pair{d.names_path, "class names"}}) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
      throw InputError(file, 0,
                       std::string("detector model ") + what +
                           " file not found (Detector.model, default yolo-fastest-1.1; the models "
                           "folder is DYGSLAM_MODELS_DIR or ../shared/models); the filter '" +
                           ToString(options->filter.mode) +
                           "' needs the detector (--filter geometry or none do not)");
    }
  }
}

}  // namespace dygslam
