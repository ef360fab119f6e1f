#include "run/system_config.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <variant>

#include "core/base/echo.h"
#include "core/base/error.h"

#ifndef DYGSLAM_DEFAULT_VOCABULARY
#define DYGSLAM_DEFAULT_VOCABULARY ""
#endif

namespace dygslam {
namespace {

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

// LoopClosing.vocabulary: a path relative to the settings file, "none" (no place recognition:
// brute-force relocalization, no loops), or absent: $DYGSLAM_VOCABULARY, else vocabulary.dygvoc
// beside the settings file, else the shipped config/vocabulary.dygvoc of the source tree.
void ReadVocabulary(const ConfigReader& root, SystemOptions* options) {
  LoopClosingOptions& lc = options->loop_closing;
  const std::string settings_path = root.path();
  std::string vocabulary;
  if (root.ReadIfPresent("LoopClosing.vocabulary", &vocabulary)) {
    if (vocabulary == "none") {
      lc.vocabulary.clear();
      return;
    }
    std::filesystem::path path(vocabulary);
    if (path.is_relative() && !settings_path.empty())
      path = std::filesystem::path(settings_path).parent_path() / path;
    lc.vocabulary = path.lexically_normal().string();
    std::error_code ec;
    if (!std::filesystem::exists(lc.vocabulary, ec))
      root.Fail("LoopClosing.vocabulary", "file not found: " + EchoValue(lc.vocabulary));
    // A binary input: a FIFO nobody writes into would block the run forever.
    if (!std::filesystem::is_regular_file(lc.vocabulary, ec))
      root.Fail("LoopClosing.vocabulary",
                "not a regular file (a FIFO, a device or a folder): " + EchoValue(lc.vocabulary));
  } else if (const char* env = std::getenv("DYGSLAM_VOCABULARY"); env != nullptr && *env != '\0') {
    lc.vocabulary = env;
  } else {
    // Beside the settings file (the presets in config/, also where the Docker image installs
    // them), else the source tree's (generated sequences carry their own camera.yaml).
    const std::filesystem::path beside =
        settings_path.empty()
            ? std::filesystem::path()
            : std::filesystem::path(settings_path).parent_path() / "vocabulary.dygvoc";
    lc.vocabulary = !beside.empty() && std::filesystem::exists(beside)
                        ? beside.string()
                        : std::string(DYGSLAM_DEFAULT_VOCABULARY);
  }
}

void ReadFilterMode(const ConfigReader& root, SystemOptions* options) {
  std::string mode;
  if (!root.ReadIfPresent("DynamicFilter.mode", &mode)) return;
  try {
    options->filter.mode = ParseFilterMode(mode);
  } catch (const InvalidOptions& e) {
    root.Fail("DynamicFilter.mode", EchoValue(e.what(), 600));
  }
}

// Detector.cfg, .weights, .names: explicit Darknet files, all three or none.
void ReadModelFiles(const ConfigReader& root, SystemOptions* options) {
  const ConfigReader detector = root.Section("Detector");
  // Model files without Detector.cfg were ignored without a word (the named or default model
  // played instead).
  for (const char* key : {"weights", "names"}) {
    if (detector.Has(key) && !detector.Has("cfg")) {
      detector.Fail(key,
                    "given without Detector.cfg: give Detector.cfg, Detector.weights and "
                    "Detector.names together, or a Detector.model");
    }
  }
  if (!detector.Has("cfg")) return;
  options->detector.cfg_path = detector.Require<std::string>("cfg");
  options->detector.weights_path = detector.Require<std::string>("weights");
  options->detector.names_path = detector.Require<std::string>("names");
}

// Detector.model: a shipped model by name (its files, input size, thresholds and classes).
void ReadModel(const ConfigReader& root, SystemOptions* options) {
  const ConfigReader detector = root.Section("Detector");
  if (detector.Has("cfg")) return;  // explicit files (ReadModelFiles)
  std::string model = "yolo-fastest-1.1";
  if (!detector.ReadIfPresent("model", &model)) {
    try {
      options->detector = DetectorOptionsForModel(model);
    } catch (const InputError&) {
      // The default model, resolved lazily: a run without detection (filter none/geometry)
      // needs no model files.
      options->detector = DetectorOptions();
    }
    return;
  }
  // A model named in the file must exist: falling back to another one would also drop the
  // input size, thresholds and classes given with it.
  try {
    options->detector = DetectorOptionsForModel(model);
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
}

void ReadDynamicClasses(const ConfigReader& root, SystemOptions* options) {
  const ConfigReader detector = root.Section("Detector");
  std::vector<std::string> classes;
  if (!detector.ReadIfPresent("dynamic_classes", &classes)) return;
  if (classes.empty()) detector.Fail("dynamic_classes", "expected at least one class name");
  options->detector.dynamic_classes = classes;
  CheckDynamicClasses(detector, options->detector);
}

std::string DefaultClasses() { return FormatSettingValue(DetectorOptions().dynamic_classes); }

using Row = SettingRow<SystemOptions>;

std::vector<Row> TrackingRows() {
  return {
      Row("Tracking.init_min_features", DYGSLAM_SETTING_FIELD(tracking.init_min_features),
          SettingRange::AtLeast(1), "", "features with depth a frame needs to start the map"),
      Row("Tracking.max_frames_between_keyframes",
          DYGSLAM_SETTING_FIELD(tracking.max_frames_between_keyframes), SettingRange::AtLeast(1),
          "", "a keyframe at the latest after this many frames")
          .DefaultText("Camera.fps"),
      Row("Tracking.dense_fallback", DYGSLAM_SETTING_FIELD(tracking.dense_fallback), {}, "",
          "dense pose of frames features cannot hold (state fallback)"),
      Row("Tracking.fallback_smoothing", DYGSLAM_SETTING_FIELD(tracking.fallback_smoothing), {}, "",
          "a stretch of fallback poses is re-anchored when features return"),
      Row("Tracking.motion_prior", DYGSLAM_SETTING_FIELD(tracking.optimizer.pose_motion_prior), {},
          "",
          "a frame's pose is held near the motion model's prediction (1 cm, 3 deg) where its "
          "matches do not fix it"),
      Row("LocalMapping.cull_keyframes", DYGSLAM_SETTING_FIELD(local_mapping.cull_keyframes), {},
          "", "redundant keyframes are removed"),
      Row("LocalMapping.pose_prior",
          DYGSLAM_SETTING_FIELD(local_mapping.optimizer.local_ba_pose_prior), {}, "",
          "the local BA holds each keyframe near its pose (1 cm, 0.2 deg) where its points do "
          "not fix it"),
  };
}

std::vector<Row> LoopClosingRows() {
  return {
      Row("LoopClosing.vocabulary", ReadVocabulary,
          "$DYGSLAM_VOCABULARY, else vocabulary.dygvoc beside the settings file, else "
          "config/vocabulary.dygvoc",
          "the place-recognition vocabulary, relative to the settings file; none: no place "
          "recognition (brute-force relocalization, no loops)"),
      Row("LoopClosing.enabled", DYGSLAM_SETTING_FIELD(loop_closing.enabled), {}, "",
          "detect and close loops"),
      Row("LoopClosing.revisit_min_path_m", DYGSLAM_SETTING_FIELD(loop_closing.revisit_min_path_m),
          SettingRange::AtMost(1e5), "m",
          "a covisible old keyframe is a loop candidate after this much keyframe path; <= 0: "
          "never"),
      Row("LoopClosing.max_correction_m", DYGSLAM_SETTING_FIELD(loop_closing.max_correction_m),
          SettingRange::Closed(0, 10000), "m",
          "a loop may move the camera by at most this plus 0.1 m per metre of path since the "
          "loop keyframe"),
      Row("LoopClosing.global_bundle_adjustment",
          DYGSLAM_SETTING_FIELD(loop_closing.global_bundle_adjustment), {}, "",
          "a global bundle adjustment after each loop, in the background"),
  };
}

std::vector<Row> DynamicFilterRows() {
  return {
      Row("DynamicFilter.mode", ReadFilterMode,
          std::string(ToString(DynamicFilterOptions{}.mode)) + " (--filter)",
          "none | boxes | geometry | paper | full (--filter overrides it)"),
      Row("DynamicFilter.C1", DYGSLAM_SETTING_FIELD(filter.c1), SettingRange::AboveAtMost(0, 1000),
          "", "paper eq. 4: scale of the epipolar probability"),
      Row("DynamicFilter.alpha", DYGSLAM_SETTING_FIELD(filter.alpha),
          SettingRange::Closed(-100, 100), "px", "paper eq. 4: epipolar distance offset"),
      Row("DynamicFilter.Q", DYGSLAM_SETTING_FIELD(filter.q), SettingRange::Closed(0, 100), "",
          "paper eq. 7: process noise of the Kalman filter"),
      Row("DynamicFilter.R", DYGSLAM_SETTING_FIELD(filter.r), SettingRange::AboveAtMost(0, 1e6), "",
          "paper eq. 8: measurement noise of the Kalman filter"),
      Row("DynamicFilter.P_init", DYGSLAM_SETTING_FIELD(filter.p_init), SettingRange::Closed(0, 1),
          "", "probability of a new point in a box"),
      Row("DynamicFilter.C2", DYGSLAM_SETTING_FIELD(filter.c2), SettingRange::Closed(0, 1000), "",
          "paper eq. 11: weight of the neighbours' probability"),
      Row("DynamicFilter.delta", DYGSLAM_SETTING_FIELD(filter.delta),
          SettingRange::AboveAtMost(0, 16384), "px", "paper eq. 12: neighbourhood radius"),
      Row("DynamicFilter.threshold", DYGSLAM_SETTING_FIELD(filter.threshold),
          SettingRange::Closed(0, 1), "", "points above this probability are dynamic"),
      Row("DynamicFilter.box_margin", DYGSLAM_SETTING_FIELD(filter.box_margin),
          SettingRange::Closed(0, 16384), "px", "added to each detection box"),
      Row("DynamicFilter.box_margin_fraction", DYGSLAM_SETTING_FIELD(filter.box_margin_fraction),
          SettingRange::Closed(0, 1), "", "plus this share of the box width"),
      Row("DynamicFilter.fundamental_threshold",
          DYGSLAM_SETTING_FIELD(filter.fundamental_threshold), SettingRange::AboveAtMost(0, 1000),
          "px", "the fundamental matrix's inlier threshold (GC-RANSAC)"),
      Row("DynamicFilter.depth_residual", DYGSLAM_SETTING_FIELD(filter.depth_residual), {}, "",
          "geometry, full: PnP motion and 3-D anchor residual instead of the fundamental matrix"),
      Row("DynamicFilter.planar_residual_to_line",
          DYGSLAM_SETTING_FIELD(filter.planar_residual_to_line), {}, "",
          "an anchor's 2-D residual enters eq. 5 as the 1-D distance of the same noise"),
      Row("DynamicFilter.world_anchors", DYGSLAM_SETTING_FIELD(filter.world_anchors), {}, "",
          "anchors stay where their track started, PnP against them (false: chained)"),
      Row("DynamicFilter.expand_outside", DYGSLAM_SETTING_FIELD(filter.expand_outside), {}, "",
          "full: unmatched features outside the boxes get the expansion (eq. 11)"),
  };
}

std::vector<Row> DetectorRows() {
  return {
      Row("Detector.model", ReadModel, "yolo-fastest-1.1",
          "a model in DYGSLAM_MODELS_DIR, or Detector.cfg / weights / names"),
      Row("Detector.cfg", ReadModelFiles, "the model's", "Darknet cfg file"),
      Row(
          "Detector.weights", [](const ConfigReader&, SystemOptions*) {}, "the model's",
          "Darknet weights file (with Detector.cfg)"),
      Row(
          "Detector.names", [](const ConfigReader&, SystemOptions*) {}, "the model's",
          "class names file, one per line (with Detector.cfg)"),
      Row("Detector.input_width", DYGSLAM_SETTING_FIELD(detector.input_width),
          SettingRange::Closed(32, 4096).MultipleOf(32), "px", "network input width"),
      Row("Detector.input_height", DYGSLAM_SETTING_FIELD(detector.input_height),
          SettingRange::Closed(32, 4096).MultipleOf(32).OrZero(), "px",
          "network input height; 0: from the frame's aspect ratio"),
      Row("Detector.confidence_threshold", DYGSLAM_SETTING_FIELD(detector.confidence_threshold),
          SettingRange::AboveAtMost(0, 1), "", "boxes below this confidence are dropped"),
      Row("Detector.nms_threshold", DYGSLAM_SETTING_FIELD(detector.nms_threshold),
          SettingRange::AboveAtMost(0, 1), "", "overlap above which boxes are merged"),
      Row("Detector.num_threads", DYGSLAM_SETTING_FIELD(detector.num_threads),
          SettingRange::Closed(0, 256), "", "OpenCV threads (process-wide); 0: OpenCV's default"),
      Row("Detector.every_n_frames", DYGSLAM_SETTING_FIELD(detection_every_n_frames),
          SettingRange::Closed(1, 1000), "",
          "the detector runs on every n-th frame; the frames between carry the last boxes"),
      Row("Detector.shift_carried_boxes", DYGSLAM_SETTING_FIELD(box_propagation.shift_boxes), {},
          "", "carried boxes move with their content (false: they stay where detected)"),
      Row("Detector.dynamic_classes", ReadDynamicClasses, DefaultClasses(),
          "the classes whose boxes are dynamic (names of the model's classes)"),
  };
}

}  // namespace

const SettingsTable<SystemOptions>& SystemSettingsTable() {
  static const SettingsTable<SystemOptions> table = [] {
    SettingsTable<SystemOptions> t;
    for (auto rows : {TrackingRows(), LoopClosingRows(), DynamicFilterRows(), DetectorRows()})
      t.rows.insert(t.rows.end(), rows.begin(), rows.end());
    return t;
  }();
  return table;
}

SystemOptions SystemOptionsFromSettings(const Settings& settings) {
  SystemOptions options;
  options.camera = settings.camera;
  options.sensor = settings.sensor;
  options.orb = settings.orb;
  // Keyframe spacing follows the frame rate unless set.
  options.tracking.max_frames_between_keyframes = static_cast<int>(settings.sensor.fps);
  SystemSettingsTable().Read(settings.reader, &options);
  // The rows' ranges hold every single-key condition of the options' Check(); what is left is a
  // check that the table and the options agree (tests/reliability: every value a row accepts
  // passes Check()). Model files that are resolved later stand in as placeholders.
  options.Check();
  DetectorOptions check = options.detector;
  if (check.cfg_path.empty()) check.cfg_path = check.weights_path = check.names_path = "default";
  settings.reader.CheckOptions(check);
  return options;
}

}  // namespace dygslam
