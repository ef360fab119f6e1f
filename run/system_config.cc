#include "run/system_config.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <variant>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "run/settings_limits.h"

#ifndef DYGSLAM_DEFAULT_VOCABULARY
#define DYGSLAM_DEFAULT_VOCABULARY ""
#endif

namespace dygslam {
namespace {

// One settings key of a section and the options field it sets when present.
struct SettingsField {
  const char* key;
  std::variant<int*, float*, double*, bool*> field;
};

// A key spelled as its options field (the LoopClosing section).
#define DYGSLAM_SAME_NAME_FIELD(options, name) \
  SettingsField { #name, &(options).name }

// Reads each present key into its field, in the order given (the first bad value is reported).
void ReadFields(const ConfigReader& section, std::initializer_list<SettingsField> fields) {
  for (const SettingsField& f : fields)
    std::visit([&](auto* field) { section.ReadIfPresent(f.key, field); }, f.field);
}

// The class names of a names file (one per line, trimmed, blank lines skipped); empty when the
// file is not a readable regular file (the detector reports that when it is created).
std::vector<std::string> ReadClassNames(const std::string& path) {
  std::error_code ec;
  std::vector<std::string> names;
  if (path.empty() || !std::filesystem::is_regular_file(path, ec)) return names;
  std::ifstream in(path);
  std::string line;
  while (names.size() < 100000 && std::getline(in, line)) {
    const size_t b = line.find_first_not_of(" \t\r");
    const size_t e = line.find_last_not_of(" \t\r");
    if (b != std::string::npos) names.push_back(line.substr(b, e - b + 1));
  }
  return names;
}

// Every Detector.dynamic_classes entry must be a class of the model (after its aliases): a
// misspelt one ("persn") would silently never match, and the detector, created later, could only
// name its names file, not the settings key that asked for the class.
void CheckDynamicClasses(const ConfigReader& detector, const DetectorOptions& options) {
  const std::vector<std::string> names = ReadClassNames(options.names_path);
  if (names.empty()) return;
  std::vector<std::string> canonical;
  for (const std::string& n : names) {
    auto it = options.class_aliases.find(n);
    canonical.push_back(it == options.class_aliases.end() ? n : it->second);
  }
  for (const std::string& wanted : options.dynamic_classes) {
    if (std::find(canonical.begin(), canonical.end(), wanted) != canonical.end()) continue;
    std::string known;
    for (size_t i = 0; i < canonical.size() && i < 8; ++i)
      known += (i == 0 ? "" : ", ") + EchoValue(canonical[i], 40);
    if (canonical.size() > 8) known += ", ... (" + std::to_string(canonical.size()) + " classes)";
    detector.Fail("dynamic_classes", "'" + EchoValue(wanted) + "' is not a class of the model (" +
                                         EchoValue(options.names_path) + ": " + known + ")");
  }
}

// LoopClosing: place recognition and loop closing. vocabulary: a path relative to the settings
// file, "none" (no place recognition: brute-force relocalization, no loops), or absent:
// $DYGSLAM_VOCABULARY, else vocabulary.dygvoc beside the settings file, else the shipped
// config/vocabulary.dygvoc of the source tree. A missing file fails when the system starts.
void ReadLoopClosing(const Settings& settings, LoopClosingOptions* options) {
  const ConfigReader loops = settings.reader.Section("LoopClosing");
  LoopClosingOptions& lc = *options;
  std::string vocabulary;
  if (loops.ReadIfPresent("vocabulary", &vocabulary)) {
    if (vocabulary == "none") {
      lc.vocabulary.clear();
    } else {
      std::filesystem::path path(vocabulary);
      if (path.is_relative() && !settings.path.empty())
        path = std::filesystem::path(settings.path).parent_path() / path;
      lc.vocabulary = path.lexically_normal().string();
      std::error_code ec;
      if (!std::filesystem::exists(lc.vocabulary, ec))
        loops.Fail("vocabulary", "file not found: " + EchoValue(lc.vocabulary));
      // A binary input: a FIFO nobody writes into would block the run forever.
      if (!std::filesystem::is_regular_file(lc.vocabulary, ec))
        loops.Fail("vocabulary", "not a regular file (a FIFO, a device or a folder): " +
                                     EchoValue(lc.vocabulary));
    }
  } else if (const char* env = std::getenv("DYGSLAM_VOCABULARY"); env != nullptr && *env != '\0') {
    lc.vocabulary = env;
  } else {
    // Beside the settings file (the presets in config/, also where the Docker image installs
    // them), else the source tree's (generated sequences carry their own camera.yaml).
    const std::filesystem::path beside =
        settings.path.empty()
            ? std::filesystem::path()
            : std::filesystem::path(settings.path).parent_path() / "vocabulary.dygvoc";
    lc.vocabulary = !beside.empty() && std::filesystem::exists(beside)
                        ? beside.string()
                        : std::string(DYGSLAM_DEFAULT_VOCABULARY);
  }
  ReadFields(loops,
             {DYGSLAM_SAME_NAME_FIELD(lc, enabled), DYGSLAM_SAME_NAME_FIELD(lc, revisit_min_path_m),
              DYGSLAM_SAME_NAME_FIELD(lc, max_correction_m),
              DYGSLAM_SAME_NAME_FIELD(lc, global_bundle_adjustment)});
  loops.CheckOptions(lc);
  CheckSettingAtMost(loops, "revisit_min_path_m", lc.revisit_min_path_m, 1e5, "m");
}

// DynamicFilter: the paper's parameters (defaults in DynamicFilterOptions) and the switches of
// our extensions.
void ReadDynamicFilter(const ConfigReader& root, DynamicFilterOptions* options) {
  const ConfigReader filter = root.Section("DynamicFilter");
  DynamicFilterOptions& f = *options;
  std::string mode;
  if (filter.ReadIfPresent("mode", &mode)) {
    try {
      f.mode = ParseFilterMode(mode);
    } catch (const InvalidOptions& e) {
      filter.Fail("mode", EchoValue(e.what(), 600));
    }
  }
  ReadFields(filter, {{"C1", &f.c1},
                      {"alpha", &f.alpha},
                      {"Q", &f.q},
                      {"R", &f.r},
                      {"P_init", &f.p_init},
                      {"C2", &f.c2},
                      {"delta", &f.delta},
                      {"threshold", &f.threshold},
                      {"box_margin", &f.box_margin},
                      {"box_margin_fraction", &f.box_margin_fraction},
                      {"fundamental_threshold", &f.fundamental_threshold},
                      {"depth_residual", &f.depth_residual},
                      {"world_anchors", &f.world_anchors},
                      {"expand_outside", &f.expand_outside}});
  filter.CheckOptions(f);
  CheckSettingAtMost(filter, "C1", f.c1, 1000, "");
  CheckSettingAtMost(filter, "R", f.r, 1e6, "");
  CheckSettingAtMost(filter, "C2", f.c2, 1000, "");
  CheckSettingAtMost(filter, "delta", f.delta, 16384, "px");
  CheckSettingAtMost(filter, "box_margin", f.box_margin, 16384, "px");
  CheckSettingAtMost(filter, "fundamental_threshold", f.fundamental_threshold, 1000, "px");
}

// Detector: a shipped model by name, or explicit Darknet files; its cadence.
void ReadDetector(const ConfigReader& root, SystemOptions* system) {
  SystemOptions& options = *system;
  const ConfigReader detector = root.Section("Detector");
  std::string model = "yolo-fastest-1.1";
  detector.ReadIfPresent("model", &model);
  // Model files without Detector.cfg were ignored without a word (the named or default model
  // played instead).
  for (const char* key : {"weights", "names"}) {
    if (detector.Has(key) && !detector.Has("cfg")) {
      detector.Fail(key,
                    "given without Detector.cfg: give Detector.cfg, Detector.weights and "
                    "Detector.names together, or a Detector.model");
    }
  }
  if (detector.Has("cfg")) {
    options.detector.cfg_path = detector.Require<std::string>("cfg");
    options.detector.weights_path = detector.Require<std::string>("weights");
    options.detector.names_path = detector.Require<std::string>("names");
  } else if (detector.Has("model")) {
    // A model named in the file must exist: falling back to another one would also drop the
    // input size, thresholds and classes given with it.
    try {
      options.detector = DetectorOptionsForModel(model);
    } catch (const InputError& e) {
      // The name is echoed bounded (a 50 MB value was echoed whole, twice).
      std::string message = e.what();
      if (!model.empty()) {
        const std::string echoed = EchoValue(model);
        for (size_t at = message.find(model); at != std::string::npos;
             at = message.find(model, at + echoed.size()))
          message.replace(at, model.size(), echoed);
      }
      detector.Fail("model", EchoValue(message, 1000));
    }
  } else {
    try {
      options.detector = DetectorOptionsForModel(model);
    } catch (const InputError&) {
      // The default model, resolved lazily: a run without detection (filter none/geometry)
      // needs no model files.
      options.detector = DetectorOptions();
    }
  }
  ReadFields(detector, {{"input_width", &options.detector.input_width},
                        {"input_height", &options.detector.input_height},
                        {"confidence_threshold", &options.detector.confidence_threshold},
                        {"nms_threshold", &options.detector.nms_threshold},
                        {"num_threads", &options.detector.num_threads}});
  // Detector cadence: run on every n-th frame, carry the boxes in between.
  ReadFields(detector, {{"every_n_frames", &options.detection_every_n_frames},
                        {"shift_carried_boxes", &options.box_propagation.shift_boxes}});
  if (options.detection_every_n_frames < 1 || options.detection_every_n_frames > 1000)
    detector.Fail("every_n_frames", "expected an integer in 1..1000 (1: every frame)");
  std::vector<std::string> classes;
  if (detector.ReadIfPresent("dynamic_classes", &classes)) {
    options.detector.dynamic_classes = classes;
    CheckDynamicClasses(detector, options.detector);
  }
  // The values of the file, checked here so that a bad one names its line (model files that are
  // resolved later stand in as placeholders).
  DetectorOptions check = options.detector;
  if (check.cfg_path.empty()) check.cfg_path = check.weights_path = check.names_path = "default";
  detector.CheckOptions(check);
}

}  // namespace

SystemOptions SystemOptionsFromSettings(const Settings& settings) {
  SystemOptions options;
  options.camera = settings.camera;
  options.sensor = settings.sensor;
  options.orb = settings.orb;
  const ConfigReader& root = settings.reader;
  // Keyframe spacing follows the frame rate unless set.
  options.tracking.max_frames_between_keyframes = static_cast<int>(settings.sensor.fps);
  const ConfigReader tracking = root.Section("Tracking");
  ReadFields(tracking,
             {{"init_min_features", &options.tracking.init_min_features},
              {"max_frames_between_keyframes", &options.tracking.max_frames_between_keyframes},
              {"dense_fallback", &options.tracking.dense_fallback},
              {"fallback_smoothing", &options.tracking.fallback_smoothing}});
  tracking.CheckOptions(options.tracking);
  const ConfigReader mapping = root.Section("LocalMapping");
  ReadFields(mapping, {{"cull_keyframes", &options.local_mapping.cull_keyframes}});
  mapping.CheckOptions(options.local_mapping);
  ReadLoopClosing(settings, &options.loop_closing);
  ReadDynamicFilter(root, &options.filter);
  ReadDetector(root, &options);
  return options;
}

}  // namespace dygslam
