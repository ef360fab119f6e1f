#include "core/slam/map/map_file.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <type_traits>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/io/file_util.h"

namespace dygslam {
namespace {

constexpr char kMagic[8] = {'D', 'Y', 'G', 'S', 'L', 'M', 'A', 'P'};  // kMapFileSignature
constexpr size_t kHeaderBytes = 8 + 4 + 8;  // magic, version, payload size
constexpr size_t kTrailerBytes = 8;         // checksum
// Coordinates of keypoints beyond this are not from an image: corrupt.
constexpr double kMaxPixelCoordinate = 1e5;

// FNV-1a, 64 bit. Version 1 files were written with a mistyped offset basis (one digit short);
// they are still read with it. Version 2 uses the standard basis 14695981039346656037.
constexpr uint64_t kFnvOffsetBasis = 14695981039346656037ULL;
constexpr uint64_t kFnvOffsetBasisVersion1 = 1469598103934665603ULL;

uint64_t Fnv1a(const char* data, size_t size, uint64_t basis = kFnvOffsetBasis) {
  uint64_t h = basis;
  for (size_t i = 0; i < size; ++i) {
    h ^= static_cast<uint8_t>(data[i]);
    h *= 1099511628211ULL;
  }
  return h;
}

class Writer {
 public:
  template <typename T>
  void Put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    bytes_.append(raw, sizeof(T));
  }
  void PutPose(const Rigid3d& pose) {
    Put(pose.rotation.w());
    Put(pose.rotation.x());
    Put(pose.rotation.y());
    Put(pose.rotation.z());
    for (int i = 0; i < 3; ++i) Put(pose.translation[i]);
  }
  void PutVector(const Eigen::Vector3d& v) {
    for (int i = 0; i < 3; ++i) Put(v[i]);
  }
  void PutDescriptor(const Descriptor& d) {
    for (uint64_t w : d) Put(w);
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

// Bounds-checked reading of the payload; every failure is an InputError naming the source.
class Reader {
 public:
  Reader(const std::string& bytes, size_t begin, size_t end, const std::string& source)
      : bytes_(bytes), pos_(begin), end_(end), source_(source) {}

  [[noreturn]] void Fail(const std::string& what) const {
    throw InputError(source_, 0,
                     "corrupt map file: " + what + " (at byte " + std::to_string(pos_) + ")");
  }
  template <typename T>
  T Get(const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (end_ - pos_ < sizeof(T)) Fail(std::string("data ends inside ") + what);
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  double GetFinite(const char* what) {
    const double v = Get<double>(what);
    if (!std::isfinite(v)) Fail(std::string(what) + " is not a finite number");
    return v;
  }
  float GetFiniteFloat(const char* what) {
    const float v = Get<float>(what);
    if (!std::isfinite(v)) Fail(std::string(what) + " is not a finite number");
    return v;
  }
  // A count of elements of at least `min_element_bytes` each: never more than the bytes left.
  size_t GetCount(const char* what, size_t min_element_bytes) {
    const uint64_t n = Get<uint64_t>(what);
    if (min_element_bytes > 0 && n > (end_ - pos_) / min_element_bytes)
      Fail(std::string(what) + " " + std::to_string(n) + " exceeds the data left");
    return static_cast<size_t>(n);
  }
  Rigid3d GetPose(const char* what) {
    double q[4];
    for (double& c : q) c = GetFinite(what);
    Rigid3d pose;
    pose.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);  // stored normalised: kept as is
    if (std::abs(pose.rotation.norm() - 1.0) > 1e-6)
      Fail(std::string(what) + " rotation is not a unit quaternion");
    pose.translation = GetVector(what);
    return pose;
  }
  Eigen::Vector3d GetVector(const char* what) {
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = GetFinite(what);
    return v;
  }
  Descriptor GetDescriptor(const char* what) {
    Descriptor d;
    for (uint64_t& w : d) w = Get<uint64_t>(what);
    return d;
  }
  bool AtEnd() const { return pos_ == end_; }

 private:
  const std::string& bytes_;
  size_t pos_, end_;
  const std::string& source_;
};

void PutSettings(Writer& w, const MapFileSettings& s) {
  const PinholeCamera& c = s.camera;
  for (double v : {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3}) w.Put(v);
  w.Put<int32_t>(c.width);
  w.Put<int32_t>(c.height);
  w.Put(s.bf);
  w.Put(s.close_depth);
  w.Put(s.orb_scale_factor);
  w.Put<int32_t>(s.orb_levels);
  w.Put<uint64_t>(s.vocabulary_checksum);
  w.Put(s.depth_map_factor);  // version 3
}

MapFileSettings GetSettings(Reader& r, uint32_t version) {
  MapFileSettings s;
  PinholeCamera& c = s.camera;
  for (double* v : {&c.fx, &c.fy, &c.cx, &c.cy, &c.k1, &c.k2, &c.p1, &c.p2, &c.k3})
    *v = r.GetFinite("camera settings");
  c.width = r.Get<int32_t>("camera settings");
  c.height = r.Get<int32_t>("camera settings");
  s.bf = r.GetFinite("camera settings");
  s.close_depth = r.GetFinite("camera settings");
  s.orb_scale_factor = r.GetFinite("ORB settings");
  s.orb_levels = r.Get<int32_t>("ORB settings");
  s.vocabulary_checksum = r.Get<uint64_t>("vocabulary identity");
  if (version >= 3) {
    s.depth_map_factor = r.GetFinite("depth settings");
    if (s.depth_map_factor < 0) r.Fail("negative DepthMapFactor");
  }
  return s;
}

// Numbers that differ print differently (core/base/echo.h).
std::string Number(double v) { return ExactNumber(v); }

// A keyframe's stored map point slot: the point when it is alive and in the map, else none.
int64_t StoredPointId(const Map& map, const std::shared_ptr<MapPoint>& mp) {
  if (!mp || mp->bad) return -1;
  auto it = map.map_points().find(mp->id);
  return it != map.map_points().end() && it->second == mp ? mp->id : -1;
}

}  // namespace

MapFileSettings MapFileSettings::Of(const CameraGeometry& geometry, double orb_scale_factor,
                                    uint64_t vocabulary_checksum, double depth_map_factor) {
  MapFileSettings s;
  s.depth_map_factor = depth_map_factor;
  s.camera = geometry.camera;
  s.bf = geometry.bf;
  s.close_depth = geometry.close_depth;
  s.orb_scale_factor = orb_scale_factor;
  s.orb_levels = geometry.num_levels;
  s.vocabulary_checksum = vocabulary_checksum;
  return s;
}

std::string MapFileSettings::Difference(const MapFileSettings& run) const {
  const PinholeCamera &a = camera, &b = run.camera;
  const std::pair<const char*, std::pair<double, double>> camera_values[] = {
      {"Camera.fx", {a.fx, b.fx}},
      {"Camera.fy", {a.fy, b.fy}},
      {"Camera.cx", {a.cx, b.cx}},
      {"Camera.cy", {a.cy, b.cy}},
      {"Camera.k1", {a.k1, b.k1}},
      {"Camera.k2", {a.k2, b.k2}},
      {"Camera.p1", {a.p1, b.p1}},
      {"Camera.p2", {a.p2, b.p2}},
      {"Camera.k3", {a.k3, b.k3}},
      {"Camera.width", {a.width, b.width}},
      {"Camera.height", {a.height, b.height}},
      {"Camera.bf", {bf, run.bf}},
      {"ThDepth (close depth, m)", {close_depth, run.close_depth}}};
  for (const auto& [key, values] : camera_values) {
    if (values.first != values.second)
      return std::string("different camera: ") + key + " is " + Number(values.first) +
             " in the map, " + Number(values.second) + " in the settings";
  }
  if (orb_scale_factor != run.orb_scale_factor)
    return "different ORB settings: ORBextractor.scaleFactor is " + Number(orb_scale_factor) +
           " in the map, " + Number(run.orb_scale_factor) + " in the settings";
  if (orb_levels != run.orb_levels)
    return "different ORB settings: ORBextractor.nLevels is " + std::to_string(orb_levels) +
           " in the map, " + std::to_string(run.orb_levels) + " in the settings";
  if (vocabulary_checksum != run.vocabulary_checksum) {
    auto name = [](uint64_t c) {
      if (c == 0) return std::string("none");
      std::ostringstream out;
      out << "checksum " << std::hex << c;
      return out.str();
    };
    return "different vocabulary (LoopClosing.vocabulary): " + name(vocabulary_checksum) +
           " in the map, " + name(run.vocabulary_checksum) + " in the settings";
  }
  // Known on both sides (a map file of version 3 or later, a run's settings).
  if (depth_map_factor > 0 && run.depth_map_factor > 0 && depth_map_factor != run.depth_map_factor)
    return "different depth scale: DepthMapFactor is " + Number(depth_map_factor) +
           " in the map, " + Number(run.depth_map_factor) +
           " in the settings (every point would be at the wrong distance)";
  return {};
}

namespace {

using StoredKeyFrames = std::map<int64_t, std::shared_ptr<KeyFrame>>;

void PutKeypoints(Writer& w, const Map& map, const KeyFrame& kf) {
  const size_t n = kf.size();
  w.Put<uint64_t>(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::KeyPoint& k = kf.keypoints[i];
    w.Put<float>(k.pt.x);
    w.Put<float>(k.pt.y);
    w.Put<float>(k.size);
    w.Put<float>(k.angle);
    w.Put<float>(k.response);
    w.Put<int32_t>(k.octave);
    w.Put<float>(kf.undistorted[i].pt.x);
    w.Put<float>(kf.undistorted[i].pt.y);
    w.PutDescriptor(kf.descriptors[i]);
    w.Put<float>(i < kf.depth.size() ? kf.depth[i] : -1.f);
    w.Put<float>(i < kf.u_right.size() ? kf.u_right[i] : -1.f);
    w.Put<uint8_t>(i < kf.in_dynamic_region.size() ? kf.in_dynamic_region[i] : 0);
    w.Put<int64_t>(i < kf.map_points.size() ? StoredPointId(map, kf.map_points[i]) : -1);
  }
}

void PutKeyFrame(Writer& w, const Map& map, const KeyFrame& kf, const StoredKeyFrames& keyframes) {
  w.Put<int64_t>(kf.id);
  w.Put<int64_t>(kf.frame_id);
  w.Put<int64_t>(kf.stamp.nanoseconds());
  w.PutPose(kf.cam_from_world);
  w.Put<int64_t>(kf.parent_id);
  w.Put<uint8_t>(kf.not_erase ? 1 : 0);
  PutKeypoints(w, map, kf);
  w.Put<uint64_t>(kf.bow_vector.size());
  for (const auto& [word, weight] : kf.bow_vector) {
    w.Put<uint32_t>(word);
    w.Put<double>(weight);
  }
  w.Put<uint64_t>(kf.bow_features.size());
  for (const auto& [node, indices] : kf.bow_features) {
    w.Put<uint32_t>(node);
    w.Put<uint64_t>(indices.size());
    for (int i : indices) w.Put<int32_t>(i);
  }
  // Covisibility among the stored keyframes only.
  std::vector<std::pair<int64_t, int>> connections;
  for (const auto& [other, weight] : kf.connection_weights)
    if (keyframes.count(other)) connections.push_back({other, weight});
  w.Put<uint64_t>(connections.size());
  for (const auto& [other, weight] : connections) {
    w.Put<int64_t>(other);
    w.Put<int32_t>(weight);
  }
  std::vector<int64_t> ordered;
  for (int64_t other : kf.ordered_connections)
    if (keyframes.count(other)) ordered.push_back(other);
  w.Put<uint64_t>(ordered.size());
  for (int64_t other : ordered) w.Put<int64_t>(other);
}

void PutMapPoint(Writer& w, const MapPoint& mp, const StoredKeyFrames& keyframes) {
  w.Put<int64_t>(mp.id);
  w.Put<int64_t>(mp.first_kf_id);
  w.Put<int64_t>(mp.ref_kf_id);
  w.PutVector(mp.position);
  w.PutDescriptor(mp.descriptor);
  w.PutVector(mp.normal);
  w.Put<double>(mp.min_distance);
  w.Put<double>(mp.max_distance);
  w.Put<int32_t>(mp.visible_count);
  w.Put<int32_t>(mp.found_count);
  std::vector<std::pair<int64_t, int>> observations;
  for (const auto& [kf_id, idx] : mp.observations)
    if (keyframes.count(kf_id)) observations.push_back({kf_id, idx});
  w.Put<uint64_t>(observations.size());
  for (const auto& [kf_id, idx] : observations) {
    w.Put<int64_t>(kf_id);
    w.Put<int32_t>(idx);
  }
}

}  // namespace

std::string EncodeMapFile(const Map& map, const MapFileSettings& settings) {
  std::lock_guard<std::mutex> lock(map.mutex());
  Writer w;
  PutSettings(w, settings);
  w.Put<int64_t>(map.PeekNextKeyFrameId());
  w.Put<int64_t>(map.PeekNextMapPointId());
  const auto& keyframes = map.keyframes();
  w.Put<uint64_t>(keyframes.size());
  for (const auto& [id, kf] : keyframes) PutKeyFrame(w, map, *kf, keyframes);
  const auto& points = map.map_points();
  w.Put<uint64_t>(points.size());
  for (const auto& [id, mp] : points) PutMapPoint(w, *mp, keyframes);
  std::string payload = std::move(w.bytes());
  Writer file;
  for (char c : kMagic) file.Put(c);
  file.Put<uint32_t>(kMapFileVersion);
  file.Put<uint64_t>(payload.size());
  std::string bytes = std::move(file.bytes());
  bytes += payload;
  const uint64_t checksum = Fnv1a(bytes.data(), bytes.size());
  char raw[8];
  std::memcpy(raw, &checksum, 8);
  bytes.append(raw, 8);
  return bytes;
}

MapFileInfo SaveMapFile(const std::string& path, const Map& map, const MapFileSettings& settings) {
  // A run stopped before its first keyframe has nothing to save; writing its empty map would
  // replace an earlier map file at the same path with nothing.
  {
    std::lock_guard<std::mutex> lock(map.mutex());
    if (map.NumKeyFrames() == 0) {
      throw InputError(path, 0,
                       "not saved: the map has no keyframe (the run ended before its first); "
                       "the file is left as it was");
    }
  }
  const std::string bytes = EncodeMapFile(map, settings);
  WriteFileAtomically(path, bytes);
  MapFileInfo info;
  info.version = kMapFileVersion;
  std::memcpy(&info.checksum, bytes.data() + bytes.size() - 8, 8);
  {
    std::lock_guard<std::mutex> lock(map.mutex());
    info.keyframes = map.NumKeyFrames();
    info.map_points = map.NumMapPoints();
  }
  info.bytes = bytes.size();
  info.settings = settings;
  return info;
}

uint64_t MapFileChecksum(const char* data, size_t size, uint32_t version) {
  return Fnv1a(data, size, version == 1 ? kFnvOffsetBasisVersion1 : kFnvOffsetBasis);
}

namespace {

// The header (magic, version, payload size) and the trailing checksum of a map file.
struct MapFileFrame {
  uint32_t version = 0;
  uint64_t payload_size = 0;
  uint64_t checksum = 0;
};

MapFileFrame CheckMapFileFrame(const std::string& bytes, const std::string& source) {
  auto fail = [&](const std::string& what) -> InputError { return InputError(source, 0, what); };
  if (bytes.size() < kHeaderBytes + kTrailerBytes) {
    if (bytes.size() < sizeof(kMagic) || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
      throw fail("not a dygslam map file (" + std::to_string(bytes.size()) +
                 " bytes, no \"DYGSLMAP\" header)");
    throw fail("truncated map file: " + std::to_string(bytes.size()) +
               " bytes, shorter than the header");
  }
  if (std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
    throw fail("not a dygslam map file (no \"DYGSLMAP\" header)");
  MapFileFrame frame;
  std::memcpy(&frame.version, bytes.data() + 8, 4);
  std::memcpy(&frame.payload_size, bytes.data() + 12, 8);
  if (frame.version < kOldestReadableMapFileVersion || frame.version > kMapFileVersion)
    throw fail("map file format version " + std::to_string(frame.version) +
               ", this build reads versions " + std::to_string(kOldestReadableMapFileVersion) +
               " to " + std::to_string(kMapFileVersion));
  const uint64_t body = bytes.size() - kHeaderBytes - kTrailerBytes;
  if (frame.payload_size > body)
    throw fail("truncated map file: " + std::to_string(bytes.size()) + " bytes, the header says " +
               std::to_string(frame.payload_size + kHeaderBytes + kTrailerBytes) +
               " (written by an interrupted copy?)");
  if (frame.payload_size < body)
    throw fail("corrupt map file: " + std::to_string(body - frame.payload_size) +
               " bytes after the end of the map");
  std::memcpy(&frame.checksum, bytes.data() + bytes.size() - 8, 8);
  if (frame.checksum != MapFileChecksum(bytes.data(), bytes.size() - 8, frame.version))
    throw fail("corrupt map file: checksum mismatch (the file was changed or damaged)");
  return frame;
}

// What the ids and octaves of a map file must lie in.
struct MapFileLimits {
  int64_t next_kf_id = 0, next_point_id = 0;
  int num_levels = 0;
};

// The keypoints of a keyframe into `frame`; returns the map point id of each (-1: none).
std::vector<int64_t> ReadKeypoints(Reader& r, const MapFileLimits& limits, Frame* frame) {
  constexpr size_t kKeypointBytes = 4 * 5 + 4 + 4 * 2 + 32 + 4 * 2 + 1 + 8;
  const size_t n = r.GetCount("keypoint count", kKeypointBytes);
  frame->keypoints.resize(n);
  frame->undistorted.resize(n);
  frame->descriptors.resize(n);
  frame->depth.resize(n);
  frame->u_right.resize(n);
  frame->in_dynamic_region.resize(n);
  std::vector<int64_t> point_ids(n);
  for (size_t i = 0; i < n; ++i) {
    cv::KeyPoint& kp = frame->keypoints[i];
    kp.pt.x = r.GetFiniteFloat("keypoint");
    kp.pt.y = r.GetFiniteFloat("keypoint");
    kp.size = r.GetFiniteFloat("keypoint");
    kp.angle = r.GetFiniteFloat("keypoint");
    kp.response = r.GetFiniteFloat("keypoint");
    kp.octave = r.Get<int32_t>("keypoint");
    if (kp.octave < 0 || kp.octave >= limits.num_levels)
      r.Fail("keypoint octave " + std::to_string(kp.octave) + " outside the " +
             std::to_string(limits.num_levels) + " pyramid levels");
    frame->undistorted[i] = kp;
    frame->undistorted[i].pt.x = r.GetFiniteFloat("keypoint");
    frame->undistorted[i].pt.y = r.GetFiniteFloat("keypoint");
    for (const cv::Point2f& p : {kp.pt, frame->undistorted[i].pt})
      if (std::abs(p.x) > kMaxPixelCoordinate || std::abs(p.y) > kMaxPixelCoordinate)
        r.Fail("keypoint coordinate outside any image");
    frame->descriptors[i] = r.GetDescriptor("descriptor");
    frame->depth[i] = r.GetFiniteFloat("keypoint depth");
    frame->u_right[i] = r.GetFiniteFloat("keypoint right coordinate");
    frame->in_dynamic_region[i] = r.Get<uint8_t>("keypoint flags");
    if (frame->in_dynamic_region[i] > 1) r.Fail("keypoint flags");
    point_ids[i] = r.Get<int64_t>("keypoint map point");
    if (point_ids[i] < -1 || point_ids[i] >= limits.next_point_id)
      r.Fail("keypoint map point id " + std::to_string(point_ids[i]) + " out of range");
  }
  return point_ids;
}

// The bag of words and its direct index.
void ReadBow(Reader& r, Frame* frame) {
  const size_t num_words = r.GetCount("BoW vector size", 12);
  for (size_t i = 0; i < num_words; ++i) {
    const WordId word = r.Get<uint32_t>("BoW vector");
    const double weight = r.GetFinite("BoW vector");
    if (!frame->bow_vector.emplace(word, weight).second) r.Fail("BoW word given twice");
  }
  const size_t num_nodes = r.GetCount("BoW direct index size", 12);
  for (size_t i = 0; i < num_nodes; ++i) {
    const NodeId node = r.Get<uint32_t>("BoW direct index");
    const size_t m = r.GetCount("BoW direct index entry", 4);
    std::vector<int> indices(m);
    for (int& idx : indices) {
      idx = r.Get<int32_t>("BoW direct index entry");
      if (idx < 0 || static_cast<size_t>(idx) >= frame->keypoints.size())
        r.Fail("BoW feature index out of range");
    }
    if (!frame->bow_features.emplace(node, std::move(indices)).second)
      r.Fail("BoW node given twice");
  }
}

void ReadCovisibility(Reader& r, KeyFrame* kf) {
  const size_t num_connections = r.GetCount("covisibility count", 12);
  for (size_t i = 0; i < num_connections; ++i) {
    const int64_t other = r.Get<int64_t>("covisibility");
    const int weight = r.Get<int32_t>("covisibility");
    if (!kf->connection_weights.emplace(other, weight).second)
      r.Fail("covisible keyframe given twice");
  }
  const size_t num_ordered = r.GetCount("covisibility order count", 8);
  for (size_t i = 0; i < num_ordered; ++i) {
    const int64_t other = r.Get<int64_t>("covisibility order");
    if (!kf->connection_weights.count(other)) r.Fail("covisibility order names an unknown link");
    kf->ordered_connections.push_back(other);
  }
}

// One keyframe (its point slots empty) and the map point id of each keypoint. `previous_id`:
// the id of the keyframe before it (-1 for the first).
std::pair<std::shared_ptr<KeyFrame>, std::vector<int64_t>> ReadKeyFrame(
    Reader& r, const MapFileLimits& limits, const std::shared_ptr<const CameraGeometry>& geometry,
    int64_t previous_id) {
  Frame frame;
  const int64_t kf_id = r.Get<int64_t>("keyframe");
  frame.id = r.Get<int64_t>("keyframe frame id");
  frame.stamp = Timestamp::FromNanoseconds(r.Get<int64_t>("keyframe stamp"));
  frame.geometry = geometry;
  frame.cam_from_world = r.GetPose("keyframe pose");
  frame.has_pose = true;
  const int64_t parent_id = r.Get<int64_t>("keyframe parent");
  const uint8_t not_erase = r.Get<uint8_t>("keyframe flags");
  if (kf_id < 0 || kf_id >= limits.next_kf_id)
    r.Fail("keyframe id " + std::to_string(kf_id) + " outside [0, " +
           std::to_string(limits.next_kf_id) + ")");
  if (previous_id >= 0 && kf_id <= previous_id) r.Fail("keyframe ids not ascending");
  if (not_erase > 1) r.Fail("keyframe flags");
  std::vector<int64_t> point_ids = ReadKeypoints(r, limits, &frame);
  ReadBow(r, &frame);
  frame.grid.Build(frame.undistorted, *geometry);
  frame.map_points.assign(frame.keypoints.size(), nullptr);
  frame.outlier.assign(frame.keypoints.size(), 0);
  auto kf = std::make_shared<KeyFrame>(kf_id, frame);
  kf->parent_id = parent_id;
  kf->not_erase = not_erase != 0;
  ReadCovisibility(r, kf.get());
  return {kf, std::move(point_ids)};
}

// One map point, its observations checked against the keyframes of `map`.
std::shared_ptr<MapPoint> ReadMapPoint(Reader& r, const Map& map, int64_t next_point_id,
                                       int64_t* last_point_id) {
  const int64_t id = r.Get<int64_t>("map point");
  const int64_t first_kf_id = r.Get<int64_t>("map point");
  if (id <= *last_point_id || id >= next_point_id)
    r.Fail("map point ids not ascending or out of range");
  *last_point_id = id;
  auto mp = std::make_shared<MapPoint>(id, Eigen::Vector3d::Zero(), first_kf_id);
  mp->ref_kf_id = r.Get<int64_t>("map point");
  mp->position = r.GetVector("map point position");
  mp->descriptor = r.GetDescriptor("map point descriptor");
  mp->normal = r.GetVector("map point normal");
  mp->min_distance = r.GetFinite("map point distance");
  mp->max_distance = r.GetFinite("map point distance");
  if (!(mp->max_distance > 0) || mp->min_distance < 0)
    r.Fail("map point " + std::to_string(id) + " has no valid scale distance");
  mp->visible_count = r.Get<int32_t>("map point counters");
  mp->found_count = r.Get<int32_t>("map point counters");
  if (mp->visible_count < 1 || mp->found_count < 0)
    r.Fail("map point " + std::to_string(id) + " has invalid counters");
  const size_t num_obs = r.GetCount("observation count", 12);
  for (size_t i = 0; i < num_obs; ++i) {
    const int64_t kf_id = r.Get<int64_t>("observation");
    const int idx = r.Get<int32_t>("observation");
    auto kf = map.GetKeyFrame(kf_id);
    if (!kf) r.Fail("map point " + std::to_string(id) + " observed by an unknown keyframe");
    if (idx < 0 || static_cast<size_t>(idx) >= kf->size())
      r.Fail("map point " + std::to_string(id) + " observation index out of range");
    if (!mp->observations.emplace(kf_id, idx).second) r.Fail("observation given twice");
  }
  return mp;
}

}  // namespace

LoadedMap DecodeMapFile(const std::string& bytes, const std::string& source,
                        const MapFileSettings& run_settings,
                        const std::shared_ptr<const CameraGeometry>& geometry) {
  const MapFileFrame file = CheckMapFileFrame(bytes, source);
  Reader r(bytes, kHeaderBytes, kHeaderBytes + file.payload_size, source);
  LoadedMap loaded;
  loaded.info.version = file.version;
  loaded.info.checksum = file.checksum;
  loaded.info.bytes = bytes.size();
  loaded.info.settings = GetSettings(r, file.version);
  const std::string difference = loaded.info.settings.Difference(run_settings);
  if (!difference.empty()) throw InputError(source, 0, "the map was made with a " + difference);
  auto map = std::make_shared<Map>();
  MapFileLimits limits;
  limits.next_kf_id = r.Get<int64_t>("id counters");
  limits.next_point_id = r.Get<int64_t>("id counters");
  if (limits.next_kf_id < 0 || limits.next_point_id < 0) r.Fail("negative id counter");
  map->SetIdCounters(limits.next_kf_id, limits.next_point_id);
  limits.num_levels = geometry->num_levels;

  // Keyframes (their point slots are resolved once the points are read).
  constexpr size_t kMinKeyFrameBytes = 8 * 3 + 7 * 8 + 8 + 1 + 8 * 4;
  const size_t num_keyframes = r.GetCount("keyframe count", kMinKeyFrameBytes);
  std::vector<std::pair<std::shared_ptr<KeyFrame>, std::vector<int64_t>>> keyframes;
  keyframes.reserve(num_keyframes);
  for (size_t k = 0; k < num_keyframes; ++k) {
    keyframes.push_back(
        ReadKeyFrame(r, limits, geometry, keyframes.empty() ? -1 : keyframes.back().first->id));
    map->AddKeyFrame(keyframes.back().first);
  }
  // Links between keyframes must name stored keyframes.
  for (const auto& [kf, ids] : keyframes) {
    if (kf->parent_id != -1 && !map->GetKeyFrame(kf->parent_id))
      r.Fail("keyframe " + std::to_string(kf->id) + " has an unknown parent");
    for (const auto& [other, weight] : kf->connection_weights)
      if (!map->GetKeyFrame(other) || other == kf->id)
        r.Fail("keyframe " + std::to_string(kf->id) + " is covisible with an unknown keyframe");
  }
  constexpr size_t kMinPointBytes = 8 * 3 + 24 + 32 + 24 + 16 + 8 + 8;
  const size_t num_points = r.GetCount("map point count", kMinPointBytes);
  int64_t last_point_id = -1;
  for (size_t p = 0; p < num_points; ++p)
    map->AddMapPoint(ReadMapPoint(r, *map, limits.next_point_id, &last_point_id));
  if (!r.AtEnd()) r.Fail("data after the last map point");
  for (auto& [kf, ids] : keyframes) {
    for (size_t i = 0; i < ids.size(); ++i) {
      if (ids[i] < 0) continue;
      auto it = map->map_points().find(ids[i]);
      if (it == map->map_points().end())
        r.Fail("keyframe " + std::to_string(kf->id) + " names an unknown map point");
      kf->map_points[i] = it->second;
    }
  }
  loaded.info.keyframes = map->NumKeyFrames();
  loaded.info.map_points = map->NumMapPoints();
  loaded.map = std::move(map);
  return loaded;
}

std::string DescribeMapFile(const MapFileInfo& info) {
  char line[200];
  std::snprintf(line, sizeof(line), "%zu keyframes, %zu map points, %zu bytes, id %016llx",
                info.keyframes, info.map_points, info.bytes,
                static_cast<unsigned long long>(info.checksum));
  return line;
}

void CheckMapFileWritable(const std::string& path) {
  if (path.empty()) throw InputError("--save-map: empty file name");
  struct stat st {};
  if (stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
    throw InputError(path, 0, "--save-map names a folder, not a file");
  const size_t slash = path.find_last_of('/');
  const std::string dir =
      slash == std::string::npos ? "." : path.substr(0, std::max<size_t>(slash, 1));
  if (stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    throw InputError(path, 0, "--save-map: the folder " + dir + " does not exist");
  if (access(dir.c_str(), W_OK) != 0)
    throw InputError(path, 0, "--save-map: the folder " + dir + " is not writable");
}

LoadedMap LoadMapFile(const std::string& path, const MapFileSettings& run_settings,
                      const std::shared_ptr<const CameraGeometry>& geometry) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0)
    throw InputError(path, 0, "cannot open map file (missing or unreadable)");
  if (!S_ISREG(st.st_mode)) throw InputError(path, 0, "map file is not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open map file (missing or unreadable)");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, 0, "cannot read map file");
  return DecodeMapFile(bytes, path, run_settings, geometry);
}

}  // namespace dygslam
