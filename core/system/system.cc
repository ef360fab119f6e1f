#include "core/system/system.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <future>
#include <mutex>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/base/error.h"
#include "core/base/log.h"
#include "core/dynamic/detection_worker.h"
#include "core/slam/frame.h"
#include "core/slam/local_mapping.h"
#include "core/slam/tracking.h"

namespace dygslam {
namespace {
// The dense fallback's view of a frame: static pixels = outside the dynamic mask (boxes refined
// by depth, disks around dynamic features).
std::shared_ptr<const DenseView> MakeDenseView(const cv::Mat& gray, const cv::Mat& depth_m,
                                               const std::vector<Detection>& detections,
                                               const std::vector<cv::KeyPoint>& keypoints,
                                               const std::vector<uint8_t>& dynamic,
                                               const DynamicMaskOptions& options) {
  auto view = std::make_shared<DenseView>();
  view->gray = gray;
  view->depth = depth_m;
  bool any_dynamic = !detections.empty();
  for (uint8_t d : dynamic) any_dynamic = any_dynamic || d;
  if (any_dynamic) {
    cv::Mat dynamic_mask =
        ComputeDynamicMask(gray.size(), depth_m, detections, keypoints, dynamic, options);
    cv::bitwise_not(dynamic_mask, view->static_mask);
  }
  return view;
}

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

const char* ToString(FilterMode mode) {
  switch (mode) {
    case FilterMode::kNone:
      return "none";
    case FilterMode::kBoxes:
      return "boxes";
    case FilterMode::kGeometry:
      return "geometry";
    case FilterMode::kFull:
      return "full";
  }
  return "unknown";
}

FilterMode ParseFilterMode(const std::string& text) {
  if (text == "none") return FilterMode::kNone;
  if (text == "boxes") return FilterMode::kBoxes;
  if (text == "geometry") return FilterMode::kGeometry;
  if (text == "full") return FilterMode::kFull;
  throw InvalidOptions("invalid filter mode '" + text +
                       "': expected none|boxes|geometry|full (or paper, paper+margin, "
                       "paper+margin+demotion)");
}

const std::vector<std::string>& FilterConfigurationNames() {
  static const std::vector<std::string> names = {
      "none", "boxes", "geometry", "paper", "paper+margin", "paper+margin+demotion", "full"};
  return names;
}

void ApplyFilterConfiguration(const std::string& name, SystemOptions* options) {
  const bool paper_family = name.rfind("paper", 0) == 0;
  if (!paper_family) {
    options->filter_mode = ParseFilterMode(name);
    return;
  }
  const auto& names = FilterConfigurationNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : "|") + n;
    throw InvalidOptions("invalid filter configuration '" + name + "': expected " + list);
  }
  options->filter_mode = FilterMode::kFull;
  options->filter.box_margin = 0.0;
  options->filter.box_margin_fraction = 0.0;
  options->demote_in_box_features = false;
  options->static_top_up_fraction = 0.0;
  options->filter.depth_residual = false;  // the paper's epipolar test (F between frames)
  if (name == "paper+margin" || name == "paper+margin+demotion") {
    options->filter.box_margin_fraction = 0.1;
  }
  if (name == "paper+margin+demotion") options->demote_in_box_features = true;
}

void SystemOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!localization || !load_map.empty(), "localization (needs a map to load)");
  DYGSLAM_CHECK_OPTION(detection_every_n_frames >= 1 && detection_every_n_frames <= 1000,
                       "Detector.every_n_frames (1..1000)");
  box_propagation.Check();
  camera.Check();
  sensor.Check();
  orb.Check();
  tracking.Check();
  local_mapping.Check();
  loop_closing.Check();
  filter.Check();
  dynamic_mask.Check();  // used only when a keyframe is made: fail here, not mid-run
}

namespace {
DynamicFilterMode ToDynamicMode(FilterMode mode) {
  switch (mode) {
    case FilterMode::kNone:
      return DynamicFilterMode::kNone;
    case FilterMode::kBoxes:
      return DynamicFilterMode::kBoxes;
    case FilterMode::kGeometry:
      return DynamicFilterMode::kGeometry;
    case FilterMode::kFull:
      return DynamicFilterMode::kFull;
  }
  return DynamicFilterMode::kNone;
}
DynamicFilterOptions FilterOptionsOf(const SystemOptions& options) {
  DynamicFilterOptions f = options.filter;
  f.mode = ToDynamicMode(options.filter_mode);
  return f;
}
}  // namespace

namespace {
std::shared_ptr<const Vocabulary> LoadVocabulary(const SystemOptions& options) {
  if (options.loop_closing.vocabulary.empty()) return nullptr;
  return std::make_shared<Vocabulary>(Vocabulary::Load(options.loop_closing.vocabulary));
}
}  // namespace

class SystemImpl {
 public:
  explicit SystemImpl(const SystemOptions& options)
      : options_(options),
        extractor_(options.orb),
        geometry_(std::make_shared<CameraGeometry>(
            CameraGeometry::Create(options.camera, options.sensor, extractor_))),
        vocabulary_(LoadVocabulary(options)),
        map_file_settings_(MapFileSettings::Of(*geometry_, options.orb.scale_factor,
                                               vocabulary_ ? vocabulary_->Checksum() : 0)),
        loaded_(options.load_map.empty()
                    ? LoadedMap{}
                    : LoadMapFile(options.load_map, map_file_settings_, geometry_)),
        map_(loaded_.map ? loaded_.map : std::make_shared<Map>()),
        local_mapper_(map_, options.local_mapping, !options.deterministic),
        tracker_(options.tracking, map_, local_mapper_, options.deterministic),
        filter_(FilterOptionsOf(options)),
        boxes_(options.box_propagation) {
    if (vocabulary_) {
      database_ = std::make_shared<KeyFrameDatabase>();
      for (const auto& [id, kf] : map_->keyframes()) database_->Add(id, kf->bow_vector);
      tracker_.SetPlaceRecognition(vocabulary_, database_);
      loop_closer_ = std::make_unique<LoopCloser>(map_, database_, options.loop_closing,
                                                  options.local_mapping.optimizer,
                                                  options.local_mapping.matcher, !options.deterministic);
      loop_closer_->SetCorrectionCallback(
          [this](const std::vector<int64_t>& moved) { EmitMapChanges(moved, {}); });
      LoopCloser* closer = loop_closer_.get();
      local_mapper_.SetKeyFrameDoneCallback(
          [closer](const std::shared_ptr<KeyFrame>& kf) { closer->InsertKeyFrame(kf); });
    }
    local_mapper_.SetPosesChangedCallback(
        [this](const std::vector<int64_t>& moved, const std::vector<int64_t>& culled) {
          EmitMapChanges(moved, culled);
        });
    if (loaded_.map) {
      first_own_keyframe_id_ = map_->PeekNextKeyFrameId();
      tracker_.StartFromLoadedMap(options.localization);
    }
  }

  MapFileInfo SaveMap(const std::string& path) const {
    return SaveMapFile(path, *map_, map_file_settings_);
  }
  std::optional<MapFileInfo> LoadedMapInfo() const {
    if (!loaded_.map) return std::nullopt;
    return loaded_.info;
  }

  // Keyframe pose corrections (local BA) and culled keyframes, for the map.
  void EmitMapChanges(const std::vector<int64_t>& moved, const std::vector<int64_t>& culled) {
    if (database_)
      for (int64_t id : culled) database_->Erase(id);
    std::function<void(const KeyframeData&)> cb;
    {
      std::lock_guard<std::mutex> lock(callback_mutex_);
      cb = keyframe_callback_;
    }
    if (!cb) return;
    std::vector<KeyframeData> updates;
    {
      std::lock_guard<std::mutex> lock(map_->mutex());
      for (int64_t id : moved) {
        auto kf = map_->GetKeyFrame(id);
        if (!kf || kf->bad) continue;
        KeyframeData d;
        d.id = id;
        d.stamp = kf->stamp;
        d.world_from_cam = kf->cam_from_world.Inverse();
        d.pose_update_only = true;
        updates.push_back(std::move(d));
      }
      for (int64_t id : culled) {
        auto kf = map_->GetKeyFrame(id);
        KeyframeData d;
        d.id = id;
        if (kf) d.stamp = kf->stamp;
        d.removed = true;
        d.pose_update_only = true;
        updates.push_back(std::move(d));
      }
    }
    for (const KeyframeData& d : updates) cb(d);
  }

  FrameResult Feed(const cv::Mat& rgb, const cv::Mat& depth, Timestamp stamp, const cv::Mat& mask,
                   const std::vector<Detection>* detections);

  std::vector<StampedPose> Trajectory() const { return tracker_.Trajectory(); }
  LocalMappingStats LocalMappingStatistics() const { return local_mapper_.stats(); }
  LoopClosingStats LoopClosingStatistics() const {
    return loop_closer_ ? loop_closer_->stats() : LoopClosingStats{};
  }
  MapStatistics MapSizes() const { return map_->Statistics(); }
  void Prefetch(const cv::Mat& rgb, Timestamp stamp) {
    if (!options_.NeedsDetections() || rgb.empty() || rgb.type() != CV_8UC3) return;
    if (options_.detection_every_n_frames > 1) {
      // Whether the detector runs on this frame is decided when the frame before it is fed.
      deferred_.push_back({stamp, rgb});
      while (deferred_.size() > kMaxPrefetched) deferred_.pop_front();
      return;
    }
    EnsureDetector();
    auto job = std::make_shared<DetectionJob>();
    job->stamp = stamp;
    job->ticket = detection_worker_->Submit(rgb);
    // Several frames may be prefetched ahead (the caller loads t+1 before feeding t); keep them in
    // stamp order, a bounded number (a caller that prefetches and never feeds loses the oldest).
    prefetched_.push_back(job);
    while (prefetched_.size() > kMaxPrefetched) prefetched_.pop_front();
  }
  // Starts the detector on `rgb` ahead of its frame (stamp order kept).
  void SubmitAhead(const cv::Mat& rgb, Timestamp stamp) {
    EnsureDetector();
    auto job = std::make_shared<DetectionJob>();
    job->stamp = stamp;
    job->ticket = detection_worker_->Submit(rgb);
    prefetched_.push_back(job);
    while (prefetched_.size() > kMaxPrefetched) prefetched_.pop_front();
  }
  void EnsureDetector() {
    if (detection_worker_) return;
    DetectorOptions d = options_.detector;
    if (d.cfg_path.empty()) {
      const int threads = d.num_threads;
      d = DetectorOptionsForModel("yolo-fastest-1.1");
      d.num_threads = threads;
    }
    detection_worker_ = std::make_unique<DetectionWorker>(YoloDetector::Create(d));
  }
  void TopUpStaticFeatures(const cv::Mat& gray, const cv::Mat& mask,
                           const std::vector<Detection>& detections, OrbExtractionCache* cache,
                           OrbFeatures* kept) const;
  std::vector<StampedPose> KeyframeTrajectory() const {
    return tracker_.KeyframeTrajectory(first_own_keyframe_id_);
  }
  void SetKeyframeCallback(std::function<void(const KeyframeData&)> cb) {
    std::lock_guard<std::mutex> lock(callback_mutex_);
    keyframe_callback_ = std::move(cb);
  }
  void Shutdown() {
    local_mapper_.Finish();
    if (loop_closer_) loop_closer_->Finish();
  }

 private:
  SystemOptions options_;
  OrbExtractor extractor_;
  std::shared_ptr<const CameraGeometry> geometry_;
  std::shared_ptr<const Vocabulary> vocabulary_;  // null without a vocabulary file
  MapFileSettings map_file_settings_;             // what a saved map depends on
  LoadedMap loaded_;                              // SystemOptions::load_map (map null: none)
  std::shared_ptr<Map> map_;
  int64_t first_own_keyframe_id_ = 0;  // keyframes of a loaded map come before it
  std::shared_ptr<KeyFrameDatabase> database_;
  std::unique_ptr<LoopCloser> loop_closer_;  // declared before the mapper: outlives its callback
  LocalMapper local_mapper_;
  Tracker tracker_;
  DynamicFilter filter_;
  std::unique_ptr<DetectionWorker> detection_worker_;  // created on first use
  struct DetectionJob {
    Timestamp stamp;
    DetectionWorker::Ticket ticket;
  };
  static constexpr size_t kMaxPrefetched = 4;
  std::deque<std::shared_ptr<DetectionJob>> prefetched_;
  // detection_every_n_frames > 1: frames announced by Prefetch, not yet submitted.
  struct DeferredFrame {
    Timestamp stamp;
    cv::Mat rgb;
  };
  std::deque<DeferredFrame> deferred_;
  int64_t own_detector_frames_ = 0;               // frames fed that needed the internal detector
  BoxPropagator boxes_;                           // boxes carried between detector frames
  std::vector<cv::KeyPoint> previous_keypoints_;  // the filter's previous frame (all features)
  int64_t next_frame_id_ = 0;
  Timestamp last_stamp_;
  bool has_last_stamp_ = false;
  std::mutex callback_mutex_;
  std::function<void(const KeyframeData&)> keyframe_callback_;
};

void SystemImpl::TopUpStaticFeatures(const cv::Mat& gray, const cv::Mat& mask,
                                     const std::vector<Detection>& detections,
                                     OrbExtractionCache* cache, OrbFeatures* kept) const {
  const int budget = options_.orb.num_features;
  const int shortfall = budget - static_cast<int>(kept->keypoints.size());
  if (kept->keypoints.size() >= options_.static_top_up_fraction * budget) return;
  cv::Mat box_mask = mask.empty() ? cv::Mat::zeros(gray.size(), CV_8UC1) : mask.clone();
  const cv::Rect image(0, 0, gray.cols, gray.rows);
  for (const Detection& d : detections) {
    const cv::Rect r = cv::Rect(DynamicRegion(d, options_.filter)) & image;
    box_mask(r).setTo(255);
  }
  OrbFeatures extra =
      extractor_.Extract(gray, box_mask, shortfall, cache);  // pyramid and corners reused
  // Skip corners already kept (same level, within 2 px).
  constexpr int kCell = 8;
  const int cols = gray.cols / kCell + 1, rows = gray.rows / kCell + 1;
  std::vector<std::vector<int>> grid(cols * rows);
  auto cell_of = [&](const cv::Point2f& p) {
    return std::clamp(int(p.y) / kCell, 0, rows - 1) * cols +
           std::clamp(int(p.x) / kCell, 0, cols - 1);
  };
  for (size_t i = 0; i < kept->keypoints.size(); ++i)
    grid[cell_of(kept->keypoints[i].pt)].push_back(int(i));
  const size_t original = kept->keypoints.size();
  for (size_t j = 0; j < extra.keypoints.size(); ++j) {
    const cv::KeyPoint& kp = extra.keypoints[j];
    bool duplicate = false;
    const int cx = std::clamp(int(kp.pt.x) / kCell, 0, cols - 1),
              cy = std::clamp(int(kp.pt.y) / kCell, 0, rows - 1);
    for (int y = std::max(0, cy - 1); y <= std::min(rows - 1, cy + 1) && !duplicate; ++y) {
      for (int x = std::max(0, cx - 1); x <= std::min(cols - 1, cx + 1) && !duplicate; ++x) {
        for (int i : grid[y * cols + x]) {
          if (i >= static_cast<int>(original)) continue;
          const cv::KeyPoint& other = kept->keypoints[i];
          if (other.octave == kp.octave && cv::norm(other.pt - kp.pt) < 2.0) {
            duplicate = true;
            break;
          }
        }
      }
    }
    if (duplicate) continue;
    kept->keypoints.push_back(kp);
    kept->descriptors.push_back(extra.descriptors[j]);
  }
}

FrameResult SystemImpl::Feed(const cv::Mat& rgb, const cv::Mat& depth, Timestamp stamp,
                             const cv::Mat& mask, const std::vector<Detection>* detections) {
  const auto t_start = std::chrono::steady_clock::now();
  const PinholeCamera& cam = options_.camera;
  if (rgb.empty() || (rgb.type() != CV_8UC3 && rgb.type() != CV_8UC1))
    throw InputError("rgb image: expected CV_8UC3 (or CV_8UC1), got type " +
                     std::to_string(rgb.type()));
  if (rgb.cols != cam.width || rgb.rows != cam.height)
    throw InputError("rgb image: size " + std::to_string(rgb.cols) + "x" +
                     std::to_string(rgb.rows) + " does not match Camera.width/height " +
                     std::to_string(cam.width) + "x" + std::to_string(cam.height));
  if (depth.empty() || (depth.type() != CV_16UC1 && depth.type() != CV_32FC1))
    throw InputError("depth image: expected CV_16UC1 or CV_32FC1");
  if (depth.size() != rgb.size()) throw InputError("depth image: size differs from the rgb image");
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != rgb.size()))
    throw InputError("mask: expected CV_8UC1 " + std::to_string(rgb.cols) + "x" +
                     std::to_string(rgb.rows) + ", got type " + std::to_string(mask.type()) + " " +
                     std::to_string(mask.cols) + "x" + std::to_string(mask.rows));
  if (has_last_stamp_ && stamp <= last_stamp_)
    throw InputError("frame stamp " + stamp.ToString() + " is not after the previous frame " +
                     last_stamp_.ToString());
  last_stamp_ = stamp;
  has_last_stamp_ = true;

  FrameResult result;
  result.stamp = stamp;
  cv::Mat gray;
  if (rgb.channels() == 3) {
    cv::cvtColor(rgb, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = rgb;
  }
  cv::Mat depth_m;
  if (depth.type() == CV_16UC1) {
    depth.convertTo(depth_m, CV_32F, 1.0 / options_.sensor.depth_map_factor);
  } else {
    depth_m = depth;
  }
  // Detection runs on another thread while ORB features are extracted.
  std::vector<Detection> own_detections;
  const bool need_detections = options_.NeedsDetections();
  std::shared_ptr<DetectionJob> detection_job;
  // Prefetched detections of this frame; those of earlier stamps were never fed: dropped.
  while (!prefetched_.empty() && prefetched_.front()->stamp < stamp) prefetched_.pop_front();
  if (!prefetched_.empty() && prefetched_.front()->stamp == stamp) {
    detection_job = prefetched_.front();
    prefetched_.pop_front();
  }
  const bool own_detector = need_detections && detections == nullptr;
  const int every_n = options_.detection_every_n_frames;
  bool detect_now = true;
  if (own_detector) {
    detect_now = own_detector_frames_ % every_n == 0;
    ++own_detector_frames_;
    if (every_n > 1) {
      while (!deferred_.empty() && deferred_.front().stamp <= stamp) deferred_.pop_front();
      // The next announced frame: start its detection now if it is a detector frame, so it
      // overlaps this frame's tracking.
      if (!deferred_.empty() && own_detector_frames_ % every_n == 0) {
        SubmitAhead(deferred_.front().rgb, deferred_.front().stamp);
        deferred_.pop_front();
      }
    }
  }
  if (own_detector && !detect_now) detection_job.reset();
  if (own_detector && detect_now && !detection_job) {
    if (rgb.channels() != 3)
      throw InputError("rgb image: the detector needs CV_8UC3 BGR, got one channel");
    EnsureDetector();
    detection_job = std::make_shared<DetectionJob>();
    detection_job->stamp = stamp;
    detection_job->ticket = detection_worker_->Submit(rgb);
  }
  const auto t_orb = std::chrono::steady_clock::now();
  OrbExtractionCache extraction_cache;
  OrbFeatures features = extractor_.Extract(gray, mask, -1, &extraction_cache);
  result.times.orb_extraction_ms = MsSince(t_orb);
  result.num_features = static_cast<int>(features.keypoints.size());
  if (own_detector && detect_now) {
    const auto t_wait = std::chrono::steady_clock::now();
    own_detections = detection_job->ticket.result.get();
    result.times.detection_wait_ms = MsSince(t_wait);
    result.times.detection_ms = *detection_job->ticket.detect_ms;
    detections = &own_detections;
    if (every_n > 1) boxes_.SetDetections(own_detections);
  } else if (own_detector) {
    own_detections = boxes_.Predict();
    detections = &own_detections;
    result.detections_carried = true;
  }
  result.detections_used = need_detections && detections != nullptr;

  // Dynamic filter in front of tracking.
  static const std::vector<Detection> kNoDetections;
  const cv::Mat descriptor_matrix = features.DescriptorMatrix();
  FilterInput input(features.keypoints, descriptor_matrix,
                    detections ? *detections : kNoDetections);
  std::vector<cv::Point2f> undistorted;
  if (options_.camera.HasDistortion() && !features.keypoints.empty()) {
    std::vector<cv::Point2f> points(features.keypoints.size());
    for (size_t i = 0; i < points.size(); ++i) points[i] = features.keypoints[i].pt;
    cv::undistortPoints(points, undistorted, options_.camera.K(), options_.camera.DistCoeffs(),
                        cv::noArray(), options_.camera.K());
    input.undistorted_points = &undistorted;
  }
  // Depth of each keypoint (at its image position, like Frame) for the depth-residual test.
  std::vector<float> keypoint_depths(features.keypoints.size(), 0.f);
  for (size_t i = 0; i < keypoint_depths.size(); ++i) {
    const cv::Point p(cvRound(features.keypoints[i].pt.x), cvRound(features.keypoints[i].pt.y));
    if (p.x < 0 || p.y < 0 || p.x >= depth_m.cols || p.y >= depth_m.rows) continue;
    const float z = depth_m.at<float>(p);
    if (std::isfinite(z) && z > 0) keypoint_depths[i] = z;
  }
  const cv::Matx33d camera_matrix(options_.camera.K());
  input.depths = &keypoint_depths;
  input.camera_matrix = &camera_matrix;
  input.depth_image = &depth_m;  // box_depth_band: each box's object depth
  const FilterResult filtered = filter_.Process(input);
  if (own_detector && every_n > 1) {
    boxes_.Observe(previous_keypoints_, features.keypoints, filtered);
    previous_keypoints_ = features.keypoints;
  }
  result.times.matching_ms = filtered.matching_ms;
  result.times.probability_ms = filtered.probability_ms;
  std::vector<uint8_t> dynamic = filtered.DynamicFlags();
  OrbFeatures kept;
  std::vector<uint8_t> kept_in_region;
  for (size_t i = 0; i < features.keypoints.size(); ++i) {
    if (dynamic[i]) continue;
    kept.keypoints.push_back(features.keypoints[i]);
    kept.descriptors.push_back(features.descriptors[i]);
    // Inside a detection box (geometry mode treats the whole image as one region: no boxes).
    kept_in_region.push_back(filtered.features[i].in_dynamic_region &&
                                     options_.filter_mode != FilterMode::kGeometry &&
                                     options_.demote_in_box_features
                                 ? 1
                                 : 0);
  }
  result.num_dynamic = filtered.num_dynamic;
  if (detections && !detections->empty() && options_.static_top_up_fraction > 0) {
    const auto t_top_up = std::chrono::steady_clock::now();
    TopUpStaticFeatures(gray, mask, *detections, &extraction_cache, &kept);
    result.times.top_up_ms = MsSince(t_top_up);
  }

  const auto t_track = std::chrono::steady_clock::now();
  kept_in_region.resize(kept.keypoints.size(), 0);  // top-up features lie outside the boxes
  Frame frame(next_frame_id_++, stamp, std::move(kept), depth_m, geometry_,
              std::move(kept_in_region));
  if (options_.tracking.dense_fallback && options_.filter_mode != FilterMode::kNone)
    frame.dense = MakeDenseView(gray, depth_m, detections ? *detections : kNoDetections,
                                features.keypoints, dynamic, options_.dynamic_mask);
  TrackResult tracked = tracker_.Track(std::move(frame));
  result.times.tracking_ms = MsSince(t_track);
  result.state = tracked.state;
  if (tracked.cam_from_world) result.world_from_cam = tracked.cam_from_world->Inverse();
  result.num_tracked = tracked.num_inliers;
  result.is_keyframe = tracked.new_keyframe != nullptr;
  if (tracked.new_keyframe) {
    std::function<void(const KeyframeData&)> cb;
    {
      std::lock_guard<std::mutex> lock(callback_mutex_);
      cb = keyframe_callback_;
    }
    if (cb) {
      KeyframeData data;
      data.id = tracked.new_keyframe->id;
      data.stamp = stamp;
      data.world_from_cam = *result.world_from_cam;
      data.rgb = rgb;
      data.depth = depth_m;
      data.dynamic_mask =
          ComputeDynamicMask(rgb.size(), depth_m, detections ? *detections : kNoDetections,
                             features.keypoints, dynamic, options_.dynamic_mask);
      data.keypoints = features.keypoints;
      data.keypoint_dynamic = dynamic;
      if (detections) data.detections = *detections;
      cb(data);
    }
  }
  if (tracked.new_keyframe) {
    const auto t_map = std::chrono::steady_clock::now();
    tracker_.HandOffKeyFrame(tracked.new_keyframe);
    result.times.local_mapping_ms = MsSince(t_map);  // deterministic mode: local mapping runs here
  }
  result.times.total_ms = MsSince(t_start);
  return result;
}

MapFileInfo CheckMapFile(const std::string& path, const SystemOptions& options) {
  const OrbExtractor extractor(options.orb);
  auto geometry = std::make_shared<CameraGeometry>(
      CameraGeometry::Create(options.camera, options.sensor, extractor));
  const auto vocabulary = LoadVocabulary(options);
  const MapFileSettings settings = MapFileSettings::Of(*geometry, options.orb.scale_factor,
                                                       vocabulary ? vocabulary->Checksum() : 0);
  return LoadMapFile(path, settings, geometry).info;
}

void System::PrefetchDetections(const cv::Mat& rgb, Timestamp stamp) {
  impl_->Prefetch(rgb, stamp);
}

System::System(const SystemOptions& options) {
  options.Check();
  impl_ = std::make_unique<SystemImpl>(options);
}
System::~System() {
  if (impl_) impl_->Shutdown();
}
FrameResult System::FeedRgbdFrame(const cv::Mat& rgb, const cv::Mat& depth, Timestamp stamp,
                                  const cv::Mat& mask, const std::vector<Detection>* detections) {
  return impl_->Feed(rgb, depth, stamp, mask, detections);
}
std::vector<StampedPose> System::Trajectory() const { return impl_->Trajectory(); }
LocalMappingStats System::LocalMappingStatistics() const { return impl_->LocalMappingStatistics(); }
LoopClosingStats System::LoopClosingStatistics() const { return impl_->LoopClosingStatistics(); }
MapStatistics System::MapSizes() const { return impl_->MapSizes(); }
std::vector<StampedPose> System::KeyframeTrajectory() const { return impl_->KeyframeTrajectory(); }
void System::SetKeyframeCallback(std::function<void(const KeyframeData&)> callback) {
  impl_->SetKeyframeCallback(std::move(callback));
}
void System::Shutdown() { impl_->Shutdown(); }
MapFileInfo System::SaveMap(const std::string& path) const { return impl_->SaveMap(path); }
std::optional<MapFileInfo> System::LoadedMapInfo() const { return impl_->LoadedMapInfo(); }

}  // namespace dygslam
