// Where shared data and models are found: one setting each.
#pragma once

#include <string>

namespace dygslam {

// DYGSLAM_DATA_DIR if set, else ../shared/data relative to the source tree / working directory
// when present. Returns an empty string when nothing is found.
std::string DataDir();
// DYGSLAM_MODELS_DIR if set, else <DataDir()>/../models, else ../shared/models.
std::string ModelsDir();

}  // namespace dygslam
