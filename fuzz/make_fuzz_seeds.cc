// Writes seed corpora for the fuzz targets: make_fuzz_seeds OUT_DIR [SOURCE_DIR]
//   OUT_DIR/dds_sample/   valid serialized samples of every message type (selector byte first)
//   OUT_DIR/png/          small valid colour / depth PNGs
//   OUT_DIR/png_decoder/  small PNGs of every layout the fast decoder handles (and two it does
//                         not), each after a mode byte (fuzz/png_decoder_fuzzer.cc), and rows
//   OUT_DIR/tum_list/     rgb.txt \f depth.txt \f associations.txt examples
//   OUT_DIR/trajectory/   TUM trajectory snippets
//   OUT_DIR/settings/     SOURCE_DIR/config/*.yaml (the presets)
//   OUT_DIR/map_file/     a tiny SLAM map file (fuzz/map_file_seed.h), as is and re-wrapped
//   OUT_DIR/darknet_cfg/  the .cfg files of $DYGSLAM_MODELS_DIR (or ../shared/models) when present
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/base/paths.h"
#ifndef DYGSLAM_FUZZ_NO_DDS
#include "fuzz/dds_decoders.h"
#endif
#include "fuzz/map_file_seed.h"

namespace {
namespace fs = std::filesystem;
using namespace dygslam;

void Write(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}
#ifndef DYGSLAM_FUZZ_NO_DDS
using namespace dygslam::fuzz;
template <class PubSubType>
void WriteSample(const fs::path& dir, SampleKind kind, const std::string& name,
                 const typename PubSubType::type& message) {
  const std::vector<uint8_t> bytes = Serialize<PubSubType>(message);
  std::string out(1, static_cast<char>(kind));
  out.append(bytes.begin(), bytes.end());
  Write(dir / (std::string(ToString(kind)) + "_" + name), out);
}

PinholeCamera Camera(int w, int h) {
  PinholeCamera c;
  c.fx = c.fy = 50;
  c.cx = w / 2.0;
  c.cy = h / 2.0;
  c.k1 = 0.01;
  c.width = w;
  c.height = h;
  return c;
}

void DdsSeeds(const fs::path& dir) {
  fs::create_directories(dir);
  RgbdFrameData f;
  f.stamp = Timestamp::FromNanoseconds(1548339823898123000);
  f.seq = 3;
  f.camera = Camera(8, 6);
  f.rgb = cv::Mat(6, 8, CV_8UC3, cv::Scalar(10, 20, 30));
  f.depth = cv::Mat(6, 8, CV_16UC1, cv::Scalar(5000));
  WriteSample<msg::RgbdFramePubSubType>(dir, SampleKind::kRgbdFrame, "16uc1", RgbdFrameToMsg(f));
  f.depth = cv::Mat(6, 8, CV_32FC1, cv::Scalar(1.5));
  f.depth_scale = 1;
  WriteSample<msg::RgbdFramePubSubType>(dir, SampleKind::kRgbdFrame, "32fc1", RgbdFrameToMsg(f));

  std::vector<Detection> dets(2);
  dets[0].box = cv::Rect2f(1, 2, 3, 4);
  dets[0].label = "person";
  dets[0].score = 0.9f;
  dets[1].box = cv::Rect2f(0, 0, 8, 6);
  dets[1].label = "chair";
  dets[1].class_id = 56;
  dets[1].score = 0.4f;
  WriteSample<msg::DetectionsPubSubType>(dir, SampleKind::kDetections, "two", DetectionsToMsg(dets, f.stamp, 3, 7.5));

  Rigid3d pose(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3), Eigen::Vector3d(1, -2, 0.5));
  msg::CameraPose cp;
  cp.header().stamp(TimeToMsg(f.stamp));
  cp.has_pose(true);
  cp.tracking_state(1);
  cp.world_from_cam(PoseToMsg(pose));
  cp.is_keyframe(true);
  WriteSample<msg::CameraPosePubSubType>(dir, SampleKind::kCameraPose, "ok", cp);

  KeyframeData k;
  k.id = 4;
  k.stamp = f.stamp;
  k.world_from_cam = pose;
  k.rgb = cv::Mat(6, 8, CV_8UC3, cv::Scalar(1, 2, 3));
  k.depth = cv::Mat(6, 8, CV_32FC1, cv::Scalar(2.0));
  k.dynamic_mask = cv::Mat::zeros(6, 8, CV_8UC1);
  k.keypoints = {cv::KeyPoint(1, 2, 7, 30, 0.5f, 1), cv::KeyPoint(5, 4, 7, 60, 0.2f, 0)};
  k.keypoint_dynamic = {0, 1};
  k.detections = dets;
  WriteSample<msg::KeyframePubSubType>(dir, SampleKind::kKeyframe, "full", KeyframeToMsg(k, Camera(8, 6)));
  KeyframeData update;
  update.id = 4;
  update.stamp = f.stamp;
  update.world_from_cam = pose;
  update.pose_update_only = true;
  WriteSample<msg::KeyframePubSubType>(dir, SampleKind::kKeyframe, "update", KeyframeToMsg(update, Camera(8, 6)));

  WriteSample<msg::GroundTruthPosePubSubType>(dir, SampleKind::kGroundTruth, "one",
                                              GroundTruthToMsg(StampedPose{f.stamp, pose}, 3));
  std::vector<StampedPose> traj = {{f.stamp, pose},
                                   {Timestamp::FromNanoseconds(f.stamp.nanoseconds() + 33000000), pose}};
  WriteSample<msg::TrajectoryPubSubType>(dir, SampleKind::kTrajectory, "two", TrajectoryToMsg(traj, false));
  msg::StreamStatus s;
  s.kind(1);
  s.source("player");
  s.num_frames(360);
  WriteSample<msg::StreamStatusPubSubType>(dir, SampleKind::kStreamStatus, "eos", s);
  msg::MapUpdate m;
  WriteSample<msg::MapUpdatePubSubType>(dir, SampleKind::kMapUpdate, "empty", m);
}

#endif  // DYGSLAM_FUZZ_NO_DDS

// png_decoder_fuzzer: mode byte 0 (as is) and 1 (CRCs repaired) before PNGs of the layouts
// the fast decoder takes (8-bit grey / BGR / BGRA, 16-bit grey) with different row filters,
// a 16-bit colour and a 1-bit one it hands to OpenCV; mode 2 before a few fuzzed-row headers.
void PngDecoderSeeds(const fs::path& dir) {
  fs::create_directories(dir);
  cv::RNG rng(20);
  struct Layout {
    const char* name;
    int type;
  };
  const Layout layouts[] = {{"gray8", CV_8UC1},
                            {"bgr8", CV_8UC3},
                            {"bgra8", CV_8UC4},
                            {"gray16", CV_16UC1},
                            {"bgr16", CV_16UC3}};
  for (const Layout& layout : layouts) {
    cv::Mat m(5, 7, layout.type);
    rng.fill(m, cv::RNG::UNIFORM, 0,
             layout.type == CV_16UC1 || layout.type == CV_16UC3 ? 65535 : 255);
    for (int strategy : {cv::IMWRITE_PNG_STRATEGY_DEFAULT, cv::IMWRITE_PNG_STRATEGY_FILTERED}) {
      std::vector<uchar> buf;
      cv::imencode(".png", m, buf, {cv::IMWRITE_PNG_STRATEGY, strategy});
      for (char mode : {'\0', '\1'}) {
        Write(dir / (std::string(layout.name) + "_s" + std::to_string(strategy) + "_m" +
                     std::to_string(int(mode)) + ".seed"),
              std::string(1, mode) + std::string(buf.begin(), buf.end()));
      }
    }
  }
  std::vector<uchar> bilevel;
  cv::imencode(".png", cv::Mat(3, 9, CV_8UC1, cv::Scalar(255)), bilevel,
               {cv::IMWRITE_PNG_BILEVEL, 1});
  Write(dir / "bilevel_m0.seed",
        std::string(1, '\0') + std::string(bilevel.begin(), bilevel.end()));
  // Mode 2: width-1, height-1, bit depth index, colour type index (16-bit grey, 8-bit RGB,
  // 8-bit RGBA), then rows with the five filter types.
  const std::string rows = std::string("\0\1\2\3\4", 5) + "some row bytes to unfilter";
  Write(dir / "built_gray16_m2.seed", std::string("\2\3\2\4\0", 5) + rows);
  Write(dir / "built_rgb8_m2.seed", std::string("\2\2\1\3\1", 5) + rows);
  Write(dir / "built_rgba8_m2.seed", std::string("\2\4\4\3\4", 5) + rows);
}

void TextSeeds(const fs::path& out, const fs::path& source) {
  fs::create_directories(out / "tum_list");
  Write(out / "tum_list" / "plain",
        "# color images\n1.0 rgb/1.0.png\n2.0 rgb/2.0.png\n3.0 rgb/3.0.png\n\f"
        "# depth\n1.005 depth/1.0.png\n2.005 depth/2.0.png\n3.005 depth/3.0.png\n\f");
  Write(out / "tum_list" / "assoc",
        "1.0 rgb/1.0.png\n2.0 rgb/2.0.png\n\f1.0 depth/1.0.png\n\f"
        "1.0 rgb/1.0.png 1.01 depth/1.0.png\n2.0 rgb/2.0.png 2.01 depth/2.0.png\n");
  fs::create_directories(out / "trajectory");
  Write(out / "trajectory" / "tum",
        "# timestamp tx ty tz qx qy qz qw\n1548339823.898123 0.1 0.2 0.3 0 0 0 1\n"
        "1548339823.931450 0.11 0.2 0.3 0.0087 0 0 0.99996\r\n\n1548339823.964950 1e-3 -2 3 0 0.7071068 0 0.7071068\n");
  fs::create_directories(out / "settings");
  for (const auto& e : fs::directory_iterator(source / "config")) {
    if (e.path().extension() == ".yaml") fs::copy_file(e.path(), out / "settings" / e.path().filename(),
                                                       fs::copy_options::overwrite_existing);
  }
  fs::create_directories(out / "darknet_cfg");
  const std::string models = ModelsDir();
  if (!models.empty() && fs::exists(models)) {
    for (const auto& e : fs::recursive_directory_iterator(models)) {
      if (e.path().extension() == ".cfg") {
        fs::copy_file(e.path(), out / "darknet_cfg" / (e.path().parent_path().filename().string() + ".cfg"),
                      fs::copy_options::overwrite_existing);
      }
    }
  }
  Write(out / "darknet_cfg" / "tiny.cfg",
        "[net]\nwidth=32\nheight=32\nchannels=3\n\n[convolutional]\nbatch_normalize=1\nfilters=4\nsize=3\n"
        "stride=1\npad=1\nactivation=leaky\n\n[maxpool]\nsize=2\nstride=2\n\n[convolutional]\nsize=1\n"
        "stride=1\npad=1\nfilters=18\nactivation=linear\n\n[yolo]\nmask=0,1,2\nanchors=1,1, 2,2, 3,3\n"
        "classes=1\nnum=3\n\n[route]\nlayers=-2\n\n[upsample]\nstride=2\n");
  fs::create_directories(out / "png");
  std::vector<uchar> buf;
  cv::imencode(".png", cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 200, 3)), buf);
  Write(out / "png" / "rgb.png", std::string(buf.begin(), buf.end()));
  cv::Mat depth(4, 6, CV_16UC1);
  cv::randu(depth, 0, 60000);
  cv::imencode(".png", depth, buf);
  Write(out / "png" / "depth.png", std::string(buf.begin(), buf.end()));
  PngDecoderSeeds(out / "png_decoder");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: make_fuzz_seeds OUT_DIR [SOURCE_DIR]\n";
    return 2;
  }
  const fs::path out = argv[1];
  const fs::path source = argc > 2 ? fs::path(argv[2]) : fs::path(DYGSLAM_SOURCE_DIR);
#ifndef DYGSLAM_FUZZ_NO_DDS
  DdsSeeds(out / "dds_sample");
#endif
  TextSeeds(out, source);
  fs::create_directories(out / "map_file");
  std::string map = dygslam::fuzz::MapSeedFile();
  Write(out / "map_file" / "tiny_raw.dygmap", map);  // first byte 'D' (even): decoded as is
  map[0] = 'E';                                      // odd: payload re-wrapped by the fuzzer
  Write(out / "map_file" / "tiny_rewrapped.dygmap", map);
  std::cout << "seeds in " << out.string() << "\n";
  return 0;
}
