#include "run/run_settings.h"

#include "run/mapping_config.h"
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

}  // namespace dygslam
