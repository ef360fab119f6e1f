#include "core/config/settings.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

namespace dygslam {
namespace {

// "1e+308" style: short, exact enough for a message.
std::string Short(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

// Values that pass the types and signs but cannot describe a real RGB-D camera (a focal length of
// 1e308 px, a principal point outside the image, k1 = 1e10): tracking would "succeed" on nonsense.
void CheckPlausibleCamera(const ConfigReader& camera, const PinholeCamera& c) {
  const double side = std::max(c.width, c.height);
  const double min_focal = 0.05 * side, max_focal = 100.0 * side;
  for (const auto& [key, value] : {std::pair<const char*, double>{"fx", c.fx}, {"fy", c.fy}}) {
    if (value < min_focal || value > max_focal) {
      camera.Fail(key, "focal length " + Short(value) + " px is implausible for a " +
                           std::to_string(c.width) + "x" + std::to_string(c.height) +
                           " image (expected " + Short(min_focal) + " to " + Short(max_focal) +
                           " px)");
    }
  }
  if (c.cx < 0 || c.cx > c.width) {
    camera.Fail("cx", "principal point " + Short(c.cx) + " px is outside the image (0 to " +
                          std::to_string(c.width) + ", Camera.width)");
  }
  if (c.cy < 0 || c.cy > c.height) {
    camera.Fail("cy", "principal point " + Short(c.cy) + " px is outside the image (0 to " +
                          std::to_string(c.height) + ", Camera.height)");
  }
  for (const auto& [key, value] :
       {std::pair<const char*, double>{"k1", c.k1}, {"k2", c.k2}, {"k3", c.k3}}) {
    if (std::abs(value) > 10.0) {
      camera.Fail(key, "radial distortion " + Short(value) +
                           " is implausible (expected |value| <= 10; real lenses are below 2)");
    }
  }
  for (const auto& [key, value] : {std::pair<const char*, double>{"p1", c.p1}, {"p2", c.p2}}) {
    if (std::abs(value) > 1.0) {
      camera.Fail(
          key, "tangential distortion " + Short(value) + " is implausible (expected |value| <= 1)");
    }
  }
}

// Camera.bf is ORB-SLAM2's stereo baseline times fx (the RGB-D "virtual right camera"): bf / fx is
// a baseline in metres, a few centimetres for a Kinect-class sensor (TUM / Bonn: 40 / 535 =
// 0.075 m). Zero or negative has no meaning; above 1 m no RGB-D sensor exists, and the close/far
// depth threshold ThDepth * bf / fx would put every point "close".
void CheckPlausibleBaseline(const ConfigReader& camera, const PinholeCamera& c,
                            const RgbdSensorOptions& sensor) {
  constexpr double kMaxBaselineM = 1.0;
  const double baseline = sensor.bf / c.fx;
  const std::string what = "Camera.bf is the stereo baseline times Camera.fx (" + Short(sensor.bf) +
                           " / " + Short(c.fx) + " px = " + Short(baseline) + " m)";
  if (!(sensor.bf > 0)) {
    camera.Fail("bf", "must be > 0: " + what + "; RGB-D sensors have a few centimetres (e.g. " +
                          Short(0.075 * c.fx) + " for 0.075 m)");
  }
  if (!(baseline <= kMaxBaselineM)) {
    camera.Fail("bf", "implausible baseline: " + what + ", expected at most " +
                          Short(kMaxBaselineM) + " m (e.g. " + Short(0.075 * c.fx) +
                          " for 0.075 m; is it given in mm or without the factor fx?)");
  }
}

}  // namespace

const SettingsTable<Settings>& CameraSettingsTable() {
  static const SettingsTable<Settings> table = {
      {
          SettingRow<Settings>("Camera.fx", DYGSLAM_SETTING_FIELD(camera.fx),
                               SettingRange::Above(0), "px", "focal length in x")
              .Required(),
          SettingRow<Settings>("Camera.fy", DYGSLAM_SETTING_FIELD(camera.fy),
                               SettingRange::Above(0), "px", "focal length in y")
              .Required(),
          SettingRow<Settings>("Camera.cx", DYGSLAM_SETTING_FIELD(camera.cx), SettingRange::Any(),
                               "px", "principal point x")
              .Required(),
          SettingRow<Settings>("Camera.cy", DYGSLAM_SETTING_FIELD(camera.cy), SettingRange::Any(),
                               "px", "principal point y")
              .Required(),
          SettingRow<Settings>("Camera.k1", DYGSLAM_SETTING_FIELD(camera.k1), SettingRange::Any(),
                               "", "radial distortion (OpenCV order k1 k2 p1 p2 k3)")
              .Required(),
          SettingRow<Settings>("Camera.k2", DYGSLAM_SETTING_FIELD(camera.k2), SettingRange::Any(),
                               "", "radial distortion")
              .Required(),
          SettingRow<Settings>("Camera.p1", DYGSLAM_SETTING_FIELD(camera.p1), SettingRange::Any(),
                               "", "tangential distortion")
              .Required(),
          SettingRow<Settings>("Camera.p2", DYGSLAM_SETTING_FIELD(camera.p2), SettingRange::Any(),
                               "", "tangential distortion")
              .Required(),
          {"Camera.k3", DYGSLAM_SETTING_FIELD(camera.k3), SettingRange::Any(), "",
           "radial distortion"},
          {"Camera.width", DYGSLAM_SETTING_FIELD(camera.width), SettingRange::Closed(1, 16384),
           "px", "image width; images of another size are rejected"},
          {"Camera.height", DYGSLAM_SETTING_FIELD(camera.height), SettingRange::Closed(1, 16384),
           "px", "image height; images of another size are rejected"},
          {"Camera.fps", DYGSLAM_SETTING_FIELD(sensor.fps), SettingRange::AboveAtMost(0, 1000),
           "Hz", "frame rate; RGB-D sensors run at 5 to 90 Hz"},
          {"Camera.bf", DYGSLAM_SETTING_FIELD(sensor.bf), SettingRange::Above(0), "px",
           "stereo baseline times Camera.fx (virtual stereo for RGB-D; TUM / Bonn: 40)"},
          {"ThDepth", DYGSLAM_SETTING_FIELD(sensor.th_depth), SettingRange::AboveAtMost(0, 1000),
           "", "points nearer than ThDepth x Camera.bf / Camera.fx are close (TUM / Bonn: 40)"},
          {"DepthMapFactor", DYGSLAM_SETTING_FIELD(sensor.depth_map_factor),
           SettingRange::Closed(1, 1e5), "",
           "depth image units per metre: 1 for float depth in metres, 1000 for millimetres, "
           "5000 for TUM / Bonn"},
          {"ORBextractor.nFeatures", DYGSLAM_SETTING_FIELD(orb.num_features),
           SettingRange::Closed(1, 100000), "", "features per image"},
          {"ORBextractor.scaleFactor", DYGSLAM_SETTING_FIELD(orb.scale_factor),
           SettingRange::Open(1, 4), "", "scale between pyramid levels"},
          {"ORBextractor.nLevels", DYGSLAM_SETTING_FIELD(orb.num_levels),
           SettingRange::Closed(1, 32), "", "pyramid levels"},
          {"ORBextractor.iniThFAST", DYGSLAM_SETTING_FIELD(orb.ini_th_fast),
           SettingRange::Closed(1, 254), "", "FAST threshold"},
          {"ORBextractor.minThFAST", DYGSLAM_SETTING_FIELD(orb.min_th_fast),
           SettingRange::Closed(1, 254), "",
           "FAST threshold where the first finds too few corners"},
      },
      {{"ORBextractor.minThFAST", "at most ORBextractor.iniThFAST",
        [](const Settings& s) { return s.orb.min_th_fast <= s.orb.ini_th_fast; }}}};
  return table;
}

const std::vector<std::string>& IgnoredSettingsKeys() {
  static const std::vector<std::string> kKeys = {"Camera.RGB", "Camera.type", "File.version",
                                                 "Viewer.*"};
  return kKeys;
}

Settings ReadCameraSettings(ConfigReader reader) {
  Settings s;
  s.path = reader.path();
  CameraSettingsTable().Read(reader, &s);
  const ConfigReader camera = reader.Section("Camera");
  CheckPlausibleCamera(camera, s.camera);
  if (camera.Has("bf")) CheckPlausibleBaseline(camera, s.camera, s.sensor);
  s.reader = std::move(reader);
  return s;
}

void CheckUnknownSettingsKeys(const std::vector<std::string>& known,
                              const std::vector<std::pair<std::string, std::string>>& retired,
                              const SettingsReadOptions& read_options, Settings* settings) {
  const ConfigReader& reader = settings->reader;
  for (const ConfigReader::UnknownKey& u : reader.UnknownKeys(known)) {
    std::string message = reader.UnknownKeyMessage(u);
    for (const auto& [key, reason] : retired) {
      if (u.key == key) {
        message = InputError::Format(
            reader.path(), u.line,
            "key '" + key + "' is no longer a setting (" + reason + "): remove it");
      }
    }
    if (read_options.unknown_keys == UnknownKeyPolicy::kError) {
      throw InputError(message + " [unknown settings keys are errors here]");
    }
    settings->warnings.push_back(message);
    if (read_options.print_warnings) std::fprintf(stderr, "warning: %s\n", message.c_str());
  }
}

std::string DefaultSettingsPath(const std::string& dataset_dir, const std::string& config_dir) {
  namespace fs = std::filesystem;
  const fs::path own = fs::path(dataset_dir) / "camera.yaml";
  std::error_code ec;
  if (fs::is_regular_file(own, ec)) return own.string();
  const std::string name = fs::path(dataset_dir).lexically_normal().filename().string();
  std::string preset = "bonn.yaml";
  if (name.find("freiburg1") != std::string::npos) preset = "tum1.yaml";
  if (name.find("freiburg2") != std::string::npos) preset = "tum2.yaml";
  if (name.find("freiburg3") != std::string::npos) preset = "tum3.yaml";
  return (fs::path(config_dir) / preset).string();
}

}  // namespace dygslam
