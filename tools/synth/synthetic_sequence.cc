#include "tools/synth/synthetic_sequence.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <system_error>
#include <vector>

#include "core/base/error.h"

namespace dygslam {
namespace {

namespace fs = std::filesystem;

void WriteBytesAtomically(const std::string& path, const char* data, size_t size) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream file(temporary, std::ios::binary | std::ios::trunc);
    if (!file) throw InputError(path, 0, "cannot open for writing");
    file.write(data, static_cast<std::streamsize>(size));
    file.flush();
    if (!file) throw InputError(path, 0, "write failed");
  }
  std::error_code error;
  fs::rename(temporary, path, error);
  if (error) {
    fs::remove(temporary, error);
    throw InputError(path, 0, "cannot rename temporary file into place");
  }
}

void WriteTextAtomically(const std::string& path, const std::string& text) {
  WriteBytesAtomically(path, text.data(), text.size());
}

void WritePng(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> buffer;
  if (!cv::imencode(".png", image, buffer, {cv::IMWRITE_PNG_COMPRESSION, 1})) {
    throw InputError(path, 0, "PNG encoding failed");
  }
  WriteBytesAtomically(path, reinterpret_cast<const char*>(buffer.data()), buffer.size());
}

std::string Number(double value, int precision) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", precision, value);
  return buffer;
}

std::string PoseFields(const Rigid3d& pose) {
  const Eigen::Quaterniond q = pose.rotation.normalized();
  std::string line;
  for (int i = 0; i < 3; ++i) line += " " + Number(pose.translation[i], 6);
  line += " " + Number(q.x(), 7) + " " + Number(q.y(), 7) + " " + Number(q.z(), 7) + " " +
          Number(q.w(), 7);
  return line;
}

}  // namespace

std::string SyntheticCameraYaml(const SyntheticOptions& options) {
  const PinholeCamera& c = options.camera;
  const RgbdSensorOptions& s = options.sensor;
  std::ostringstream out;
  out << "%YAML:1.0\n"
      << "# Synthetic dygslam sequence (seed " << options.seed << ", " << options.num_frames
      << " frames, " << options.num_moving_objects << " moving objects)\n"
      << "Camera.fx: " << Number(c.fx, 6) << "\n"
      << "Camera.fy: " << Number(c.fy, 6) << "\n"
      << "Camera.cx: " << Number(c.cx, 6) << "\n"
      << "Camera.cy: " << Number(c.cy, 6) << "\n"
      << "Camera.k1: " << Number(c.k1, 6) << "\n"
      << "Camera.k2: " << Number(c.k2, 6) << "\n"
      << "Camera.p1: " << Number(c.p1, 6) << "\n"
      << "Camera.p2: " << Number(c.p2, 6) << "\n"
      << "Camera.k3: " << Number(c.k3, 6) << "\n"
      << "Camera.width: " << c.width << "\n"
      << "Camera.height: " << c.height << "\n"
      << "Camera.fps: " << Number(s.fps, 6) << "\n"
      << "Camera.bf: " << Number(s.bf, 6) << "\n"
      << "Camera.RGB: 1\n"
      << "ThDepth: " << Number(s.th_depth, 6) << "\n"
      << "DepthMapFactor: " << Number(s.depth_map_factor, 6) << "\n"
      << "ORBextractor.nFeatures: 1000\n"
      << "ORBextractor.scaleFactor: 1.2\n"
      << "ORBextractor.nLevels: 8\n"
      << "ORBextractor.iniThFAST: 20\n"
      << "ORBextractor.minThFAST: 7\n";
  return out.str();
}

void WriteSyntheticSequence(const std::string& directory, const SyntheticOptions& options,
                            const SyntheticProgress& progress) {
  const SyntheticScene scene(options);  // checks the options
  std::error_code error;
  for (const char* sub : {"", "rgb", "depth", "mask"}) {
    const fs::path path = fs::path(directory) / sub;
    fs::create_directories(path, error);
    if (error || !fs::is_directory(path)) {
      throw InputError(path.string(), 0, "cannot create directory: " + error.message());
    }
  }
  const std::string header =
      "# dygslam synthetic sequence, seed " + std::to_string(options.seed) + "\n";
  std::string rgb_txt = "# color images\n" + header + "# timestamp filename\n";
  std::string depth_txt = "# depth maps\n" + header + "# timestamp filename\n";
  std::string mask_txt =
      "# ground-truth dynamic masks (255 = moving object)\n" + header + "# timestamp filename\n";
  std::string groundtruth_txt = "# ground truth trajectory (world_from_cam)\n" + header +
                                "# timestamp tx ty tz qx qy qz qw\n";
  std::string detections_txt = "# ground-truth boxes of visible moving objects\n" + header +
                               "# timestamp x y w h class_id score\n";
  std::string objects_txt = "# moving-object poses (world_from_object, box centre)\n" + header +
                            "# timestamp object_id tx ty tz qx qy qz qw size_x size_y size_z\n";

  for (int i = 0; i < scene.num_frames(); ++i) {
    const SyntheticFrame frame = scene.RenderFrame(i);
    const std::string stamp = frame.stamp.ToString();
    const std::string depth_stamp = frame.depth_stamp.ToString();
    const std::string rgb_name = "rgb/" + stamp + ".png";
    const std::string depth_name = "depth/" + depth_stamp + ".png";
    const std::string mask_name = "mask/" + stamp + ".png";
    WritePng((fs::path(directory) / rgb_name).string(), frame.rgb);
    WritePng((fs::path(directory) / depth_name).string(), frame.depth);
    WritePng((fs::path(directory) / mask_name).string(), frame.dynamic_mask);
    rgb_txt += stamp + " " + rgb_name + "\n";
    depth_txt += depth_stamp + " " + depth_name + "\n";
    mask_txt += stamp + " " + mask_name + "\n";
    groundtruth_txt += stamp + PoseFields(frame.world_from_cam) + "\n";
    for (const Detection& d : frame.boxes) {
      detections_txt += stamp + " " + Number(d.box.x, 1) + " " + Number(d.box.y, 1) + " " +
                        Number(d.box.width, 1) + " " + Number(d.box.height, 1) + " " +
                        std::to_string(d.class_id) + " " + Number(d.score, 3) + "\n";
    }
    for (int k = 0; k < scene.num_moving_objects(); ++k) {
      if (!scene.IsObjectPresent(k, i)) continue;
      const OrientedBox box = scene.MovingObjectBox(k, i);
      objects_txt += stamp + " " + std::to_string(k) + PoseFields(box.world_from_box) + " " +
                     Number(2 * box.half_extents.x(), 3) + " " +
                     Number(2 * box.half_extents.y(), 3) + " " +
                     Number(2 * box.half_extents.z(), 3) + "\n";
    }
    if (progress) progress(i + 1, scene.num_frames());
  }
  const fs::path dir(directory);
  WriteTextAtomically((dir / "rgb.txt").string(), rgb_txt);
  WriteTextAtomically((dir / "depth.txt").string(), depth_txt);
  WriteTextAtomically((dir / "mask.txt").string(), mask_txt);
  WriteTextAtomically((dir / "groundtruth.txt").string(), groundtruth_txt);
  WriteTextAtomically((dir / "detections.txt").string(), detections_txt);
  WriteTextAtomically((dir / "objects.txt").string(), objects_txt);
  WriteTextAtomically((dir / "camera.yaml").string(), SyntheticCameraYaml(options));
}

}  // namespace dygslam
