#include "core/config/settings.h"

#include <filesystem>

namespace dygslam {
namespace {

Settings ReadSettings(ConfigReader reader) {
  Settings s;
  s.path = reader.path();
  const ConfigReader camera = reader.Section("Camera");
  s.camera.fx = camera.Require<double>("fx");
  s.camera.fy = camera.Require<double>("fy");
  s.camera.cx = camera.Require<double>("cx");
  s.camera.cy = camera.Require<double>("cy");
  s.camera.k1 = camera.Require<double>("k1");
  s.camera.k2 = camera.Require<double>("k2");
  s.camera.p1 = camera.Require<double>("p1");
  s.camera.p2 = camera.Require<double>("p2");
  camera.ReadIfPresent("k3", &s.camera.k3);
  camera.ReadIfPresent("width", &s.camera.width);
  camera.ReadIfPresent("height", &s.camera.height);
  camera.ReadIfPresent("fps", &s.sensor.fps);
  camera.ReadIfPresent("bf", &s.sensor.bf);
  reader.ReadIfPresent("ThDepth", &s.sensor.th_depth);
  reader.ReadIfPresent("DepthMapFactor", &s.sensor.depth_map_factor);
  const ConfigReader orb = reader.Section("ORBextractor");
  orb.ReadIfPresent("nFeatures", &s.orb.num_features);
  orb.ReadIfPresent("scaleFactor", &s.orb.scale_factor);
  orb.ReadIfPresent("nLevels", &s.orb.num_levels);
  orb.ReadIfPresent("iniThFAST", &s.orb.ini_th_fast);
  orb.ReadIfPresent("minThFAST", &s.orb.min_th_fast);
  reader.CheckOptions(s.camera);
  reader.CheckOptions(s.sensor);
  reader.CheckOptions(s.orb);
  s.reader = std::move(reader);
  return s;
}

}  // namespace

Settings LoadSettings(const std::string& path) {
  return ReadSettings(ConfigReader::FromFile(path));
}

Settings ParseSettings(const std::string& text, const std::string& name) {
  return ReadSettings(ConfigReader::FromString(text, name));
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
