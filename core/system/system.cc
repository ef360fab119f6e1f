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
#include "core/base/work_queue.h"
#include "core/dynamic/detection_worker.h"
#include "core/slam/feature/frame_preparation.h"
#include "core/slam/local_mapping/local_mapping.h"
#include "core/slam/map/frame.h"
#include "core/slam/optimize/optimizer.h"
#include "core/slam/tracking/tracking.h"

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
    // Made when the frame is first aligned (few are): from copies of what it needs.
    view->make_static_mask = [size = gray.size(), depth_m, detections, keypoints, dynamic,
                              options] {
      cv::Mat static_mask;
      cv::bitwise_not(ComputeDynamicMask(size, depth_m, detections, keypoints, dynamic, options),
                      static_mask);
      return static_mask;
    };
  }
  return view;
}

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

const std::vector<std::string>& FilterConfigurationNames() {
  static const std::vector<std::string> names = {"none", "boxes", "geometry", "paper", "full"};
  return names;
}

void ApplyFilterConfiguration(const std::string& name, SystemOptions* options) {
  const auto& names = FilterConfigurationNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : "|") + n;
    throw InvalidOptions("invalid filter configuration '" + name + "': expected " + list);
  }
  if (name != "paper") {
    options->filter.mode = ParseFilterMode(name);
    return;
  }
  options->filter.mode = FilterMode::kFull;
  options->filter.box_margin = 0.0;
  options->filter.box_margin_fraction = 0.0;
  options->demote_in_box_features = false;
  options->static_top_up_fraction = 0.0;
  options->filter.depth_residual = false;  // the paper's epipolar test (F between frames)
  options->dynamic_points.enabled = false;
}

void SystemOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!localization || !load_map.empty(), "localization (needs a map to load)");
  DYGSLAM_CHECK_OPTION(detection_every_n_frames >= 1 && detection_every_n_frames <= 1000,
                       "Detector.every_n_frames (1..1000)");
  DYGSLAM_CHECK_OPTION(static_top_up_fraction >= 0 && static_top_up_fraction <= 1,
                       "static_top_up_fraction (0..1)");
  box_propagation.Check();
  dynamic_points.Check();
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
                                               vocabulary_ ? vocabulary_->Checksum() : 0,
                                               options.sensor.depth_map_factor)),
        loaded_(options.load_map.empty()
                    ? LoadedMap{}
                    : LoadMapFile(options.load_map, map_file_settings_, geometry_)),
        map_(loaded_.map ? loaded_.map : std::make_shared<Map>()),
        local_mapper_(map_, options.local_mapping, !options.deterministic),
        tracker_(options.tracking, map_, local_mapper_),
        filter_(options.filter),
        boxes_(options.box_propagation),
        dynamic_points_(options.dynamic_points) {
    if (vocabulary_) {
      database_ = std::make_shared<KeyFrameDatabase>();
      for (const auto& [id, kf] : map_->keyframes()) database_->Add(id, kf->bow_vector);
      tracker_.SetPlaceRecognition(vocabulary_, database_);
      loop_closer_ = std::make_unique<LoopCloser>(
          map_, database_, options.loop_closing, options.local_mapping.optimizer,
          options.local_mapping.matcher, !options.deterministic, /*threaded_checks=*/false);
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
    if (options.filter.mode != FilterMode::kNone) tracker_.PrepareDenseFallback(geometry_->camera);
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
    Post([cb, updates = std::move(updates)] {
      for (const KeyframeData& d : updates) cb(d);
    });
  }

  // Runs `job` on the keyframe callback's thread, after what was posted before.
  void Post(std::function<void()> job) {
    emitter_.Push([this, job = std::move(job)] {
      try {
        job();
      } catch (...) {
        std::lock_guard<std::mutex> lock(callback_mutex_);
        if (!emit_error_) emit_error_ = std::current_exception();
      }
    });
    emitter_.Drain();  // unthreaded (deterministic): at once
  }
  // Waits until every posted callback has run; rethrows the first exception one threw.
  void FlushCallbacks() {
    while (!emitter_.WaitIdle(std::chrono::seconds(1))) {
    }
    RethrowCallbackError();
  }
  void RethrowCallbackError() {
    std::exception_ptr error;
    {
      std::lock_guard<std::mutex> lock(callback_mutex_);
      std::swap(error, emit_error_);
    }
    if (error) std::rethrow_exception(error);
  }

  // carry_boxes: the frame's detector was skipped outside (FeedRgbdFrameCarryingBoxes).
  FrameResult Feed(const RgbdFrame& frame, bool carry_boxes = false);
  double depth_map_factor() const { return options_.sensor.depth_map_factor; }

  std::vector<StampedPose> Trajectory() const { return tracker_.Trajectory(); }
  LocalMappingStats LocalMappingStatistics() const { return local_mapper_.stats(); }
  LoopClosingStats LoopClosingStatistics() const {
    return loop_closer_ ? loop_closer_->stats() : LoopClosingStats{};
  }
  MapStatistics MapSizes() const { return map_->Statistics(); }
  std::vector<MapPointLabel> MapPointLabels() const {
    std::vector<MapPointLabel> labels = dynamic_points_.flagged();
    std::lock_guard<std::mutex> lock(map_->mutex());
    for (const auto& [id, point] : map_->map_points()) labels.push_back(LabelOf(*map_, *point));
    return labels;
  }
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
    FlushCallbacks();
  }

 private:
  struct DetectionJob {
    Timestamp stamp;
    DetectionWorker::Ticket ticket;
  };
  struct PreparedFrame;
  struct FilteredFrame;
  // FeedRgbdFrame's steps: prepare, then filter -> track -> emit.
  void CheckInput(const RgbdFrame& frame);
  std::shared_ptr<DetectionJob> StartDetection(const RgbdFrame& frame, bool own_detector,
                                               bool* detect_now);
  PreparedFrame Prepare(const RgbdFrame& frame, bool carry_boxes, FrameResult* result);
  FilteredFrame Filter(const PreparedFrame& prepared, FrameResult* result);
  void TopUp(const PreparedFrame& prepared, OrbFeatures* kept);
  std::vector<cv::Point2f> UndistortedPoints(const std::vector<cv::KeyPoint>& keypoints) const;
  static std::vector<float> KeypointDepths(const std::vector<cv::KeyPoint>& keypoints,
                                           const cv::Mat& depth_m);
  TrackResult Track(const PreparedFrame& prepared, FilteredFrame* filtered, FrameResult* result);
  // The map point of each feature of this frame, for the next frame's dynamic map-point vote.
  void RememberPoints(const PreparedFrame& prepared, const FilteredFrame& filtered,
                      const TrackResult& tracked);
  void EmitKeyframe(const std::shared_ptr<KeyFrame>& keyframe, const PreparedFrame& prepared,
                    const FilteredFrame& filtered, FrameResult* result);

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
  bool keyframe_detector_ok_ = true;  // false: no detector for keyframes (EmitKeyframe, warned)
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
  DynamicPointVoter dynamic_points_;
  // Per feature of the filter's previous frame: its map point in the tracked frame (or null).
  std::vector<std::shared_ptr<MapPoint>> previous_points_;
  int64_t next_frame_id_ = 0;
  Timestamp last_stamp_;
  bool has_last_stamp_ = false;
  std::mutex callback_mutex_;
  std::function<void(const KeyframeData&)> keyframe_callback_;
  std::exception_ptr emit_error_;  // guarded by callback_mutex_
  // The keyframe callback's thread (Post). Last: finishes its jobs before anything they use goes.
  WorkQueue<std::function<void()>> emitter_{[](std::function<void()>& job) { job(); },
                                            !options_.deterministic, /*capacity=*/16,
                                            "keyframe out"};
};

namespace {
const std::vector<Detection> kNoDetections;
}  // namespace

// A frame after preparation (stella_vslam's frame before tracking): the checked input, its grey
// image, depth in metres and ORB features, and the boxes the filter uses on it.
struct SystemImpl::PreparedFrame {
  const RgbdFrame* input = nullptr;
  cv::Mat gray;
  cv::Mat depth_m;  // CV_32FC1 metres
  OrbFeatures features;
  // Filled by the extraction, reused by the top-up extraction (pyramid and FAST corners).
  mutable OrbExtractionCache extraction_cache;
  // Boxes given with the frame, found by the own detector or carried from its last frame;
  // nullopt: none (the filter mode needs none, or none were given).
  std::optional<std::vector<Detection>> detections;
  bool propagate_boxes = false;  // own detector on every n-th frame: carry boxes in between
  // The detector skipped this frame (the own detector's cadence, or one outside that skips
  // frames: FeedRgbdFrameCarryingBoxes): its boxes are carried.
  bool detector_skipped = false;

  const std::vector<Detection>& boxes() const { return detections ? *detections : kNoDetections; }
};

// The dynamic filter's verdict on a prepared frame and the features tracking gets.
struct SystemImpl::FilteredFrame {
  std::vector<uint8_t> dynamic;  // per feature of PreparedFrame::features: removed as dynamic
  OrbFeatures kept;              // the static features, then the top-up features
  std::vector<int> kept_source;  // per kept feature: its index in `features` (-1: top-up)
  std::vector<uint8_t> kept_in_region;  // per kept feature: kept inside a box (demoted)
};

void SystemImpl::CheckInput(const RgbdFrame& frame) {
  CheckRgbdFrame(frame, options_.camera.width, options_.camera.height);
  if (has_last_stamp_ && frame.stamp <= last_stamp_)
    throw InputError("frame stamp " + frame.stamp.ToString() + " is not after the previous frame " +
                     last_stamp_.ToString());
  last_stamp_ = frame.stamp;
  has_last_stamp_ = true;
}

// The own detector's job for this frame: a prefetched one, a new one, or none (not a detector
// frame of the cadence). *detect_now: this frame is a detector frame.
std::shared_ptr<SystemImpl::DetectionJob> SystemImpl::StartDetection(const RgbdFrame& frame,
                                                                     bool own_detector,
                                                                     bool* detect_now) {
  std::shared_ptr<DetectionJob> job;
  // Prefetched detections of this frame; those of earlier stamps were never fed: dropped.
  while (!prefetched_.empty() && prefetched_.front()->stamp < frame.stamp) prefetched_.pop_front();
  if (!prefetched_.empty() && prefetched_.front()->stamp == frame.stamp) {
    job = prefetched_.front();
    prefetched_.pop_front();
  }
  *detect_now = true;
  if (!own_detector) return job;
  const int every_n = options_.detection_every_n_frames;
  *detect_now = own_detector_frames_ % every_n == 0;
  ++own_detector_frames_;
  if (every_n > 1) {
    while (!deferred_.empty() && deferred_.front().stamp <= frame.stamp) deferred_.pop_front();
    // The next announced frame: start its detection now if it is a detector frame, so it
    // overlaps this frame's tracking.
    if (!deferred_.empty() && own_detector_frames_ % every_n == 0) {
      SubmitAhead(deferred_.front().rgb, deferred_.front().stamp);
      deferred_.pop_front();
    }
  }
  if (!*detect_now) return nullptr;
  if (!job) {
    if (frame.rgb.channels() != 3)
      throw InputError("rgb image: the detector needs CV_8UC3 BGR, got one channel");
    EnsureDetector();
    job = std::make_shared<DetectionJob>();
    job->stamp = frame.stamp;
    job->ticket = detection_worker_->Submit(frame.rgb);
  }
  return job;
}

// Checks, grey image, depth in metres, ORB extraction (while the own detector runs on another
// thread), and the boxes of the frame.
SystemImpl::PreparedFrame SystemImpl::Prepare(const RgbdFrame& frame, bool carry_boxes,
                                              FrameResult* result) {
  CheckInput(frame);
  PreparedFrame prepared;
  prepared.input = &frame;
  prepared.gray = GrayImage(frame.rgb);
  prepared.depth_m = frame.DepthInMetres();
  const bool need_detections = options_.NeedsDetections();
  const bool own_detector = need_detections && !frame.detections && !carry_boxes;
  bool detect_now = true;
  const std::shared_ptr<DetectionJob> job = StartDetection(frame, own_detector, &detect_now);
  const auto t_orb = std::chrono::steady_clock::now();
  prepared.features = extractor_.Extract(prepared.gray, frame.mask, -1, &prepared.extraction_cache);
  result->times.orb_extraction_ms = MsSince(t_orb);
  result->num_features = static_cast<int>(prepared.features.keypoints.size());
  // Boxes are carried between detector frames (the internal detector, or one outside that skips
  // frames): their motion is tracked on every frame.
  prepared.propagate_boxes = need_detections && options_.detection_every_n_frames > 1;
  if (own_detector && detect_now) {
    const auto t_wait = std::chrono::steady_clock::now();
    prepared.detections = job->ticket.result.get();
    result->times.detection_wait_ms = MsSince(t_wait);
    result->times.detection_ms = *job->ticket.detect_ms;
    if (prepared.propagate_boxes) boxes_.SetDetections(*prepared.detections);
  } else if (own_detector || (need_detections && carry_boxes)) {
    prepared.detections = boxes_.Predict();
    result->detections_carried = true;
    prepared.detector_skipped = true;
  } else {
    prepared.detections = frame.detections;
    // Given from outside: the boxes the next skipped frames carry.
    if (prepared.propagate_boxes && frame.detections) boxes_.SetDetections(*frame.detections);
  }
  result->detections_used = need_detections && prepared.detections.has_value();
  return prepared;
}

// The dynamic filter on the prepared features (undistorted positions, depth of each keypoint),
// the static features it keeps, and the top-up outside the boxes on crowded frames.
SystemImpl::FilteredFrame SystemImpl::Filter(const PreparedFrame& prepared, FrameResult* result) {
  const OrbFeatures& features = prepared.features;
  const cv::Mat descriptor_matrix = features.DescriptorMatrix();
  FilterInput input(features.keypoints, descriptor_matrix, prepared.boxes());
  const std::vector<cv::Point2f> undistorted = UndistortedPoints(features.keypoints);
  if (!undistorted.empty()) input.undistorted_points = &undistorted;
  const std::vector<float> keypoint_depths = KeypointDepths(features.keypoints, prepared.depth_m);
  const cv::Matx33d camera_matrix(options_.camera.K());
  input.depths = &keypoint_depths;
  input.camera_matrix = &camera_matrix;
  input.depth_image = &prepared.depth_m;  // box_depth_band: each box's object depth
  const FilterResult verdict = filter_.Process(input);
  if (prepared.propagate_boxes) {
    boxes_.Observe(previous_keypoints_, features.keypoints, verdict);
    previous_keypoints_ = features.keypoints;
  }
  result->times.matching_ms = verdict.matching_ms;
  result->times.probability_ms = verdict.probability_ms;
  result->num_dynamic = verdict.num_dynamic;

  FilteredFrame filtered;
  filtered.dynamic = verdict.DynamicFlags();
  if (!previous_points_.empty()) {  // the map points of the filter's tracks
    std::vector<int> previous_match(verdict.features.size());
    for (size_t i = 0; i < previous_match.size(); ++i)
      previous_match[i] = verdict.features[i].prev_match;
    dynamic_points_.Vote(*map_, previous_points_, previous_match, filtered.dynamic);
  }
  // Inside a detection box (geometry mode treats the whole image as one region: no boxes).
  const bool demote =
      options_.demote_in_box_features && options_.filter.mode != FilterMode::kGeometry;
  for (size_t i = 0; i < features.keypoints.size(); ++i) {
    if (filtered.dynamic[i]) continue;
    filtered.kept.keypoints.push_back(features.keypoints[i]);
    filtered.kept_source.push_back(static_cast<int>(i));
    filtered.kept.descriptors.push_back(features.descriptors[i]);
    filtered.kept_in_region.push_back(verdict.features[i].in_dynamic_region && demote ? 1 : 0);
  }
  if (!prepared.boxes().empty() && options_.static_top_up_fraction > 0) {
    const auto t_top_up = std::chrono::steady_clock::now();
    TopUp(prepared, &filtered.kept);
    result->times.top_up_ms = MsSince(t_top_up);
  }
  filtered.kept_in_region.resize(filtered.kept.keypoints.size(), 0);  // top-up: outside the boxes
  return filtered;
}

void SystemImpl::TopUp(const PreparedFrame& prepared, OrbFeatures* kept) {
  const int budget = options_.orb.num_features;
  if (kept->keypoints.size() >= options_.static_top_up_fraction * budget) return;
  std::vector<cv::Rect> boxes;
  for (const Detection& d : prepared.boxes())
    boxes.push_back(cv::Rect(DynamicRegion(d, options_.filter)));
  TopUpFeatures(extractor_, prepared.gray, prepared.input->mask, boxes, budget,
                &prepared.extraction_cache, kept);
}

std::vector<cv::Point2f> SystemImpl::UndistortedPoints(
    const std::vector<cv::KeyPoint>& keypoints) const {
  std::vector<cv::Point2f> undistorted;
  if (!options_.camera.HasDistortion() || keypoints.empty()) return undistorted;
  std::vector<cv::Point2f> points(keypoints.size());
  for (size_t i = 0; i < points.size(); ++i) points[i] = keypoints[i].pt;
  cv::undistortPoints(points, undistorted, options_.camera.K(), options_.camera.DistCoeffs(),
                      cv::noArray(), options_.camera.K());
  return undistorted;
}

// Depth of each keypoint at its image position (like Frame), 0 where there is none.
std::vector<float> SystemImpl::KeypointDepths(const std::vector<cv::KeyPoint>& keypoints,
                                              const cv::Mat& depth_m) {
  std::vector<float> depths(keypoints.size(), 0.f);
  for (size_t i = 0; i < depths.size(); ++i) {
    const cv::Point p(cvRound(keypoints[i].pt.x), cvRound(keypoints[i].pt.y));
    if (p.x < 0 || p.y < 0 || p.x >= depth_m.cols || p.y >= depth_m.rows) continue;
    const float z = depth_m.at<float>(p);
    if (std::isfinite(z) && z > 0) depths[i] = z;
  }
  return depths;
}

TrackResult SystemImpl::Track(const PreparedFrame& prepared, FilteredFrame* filtered,
                              FrameResult* result) {
  const auto t_track = std::chrono::steady_clock::now();
  Frame frame(next_frame_id_++, prepared.input->stamp, std::move(filtered->kept), prepared.depth_m,
              geometry_, std::move(filtered->kept_in_region));
  if (options_.tracking.dense_fallback && options_.filter.mode != FilterMode::kNone)
    frame.dense =
        MakeDenseView(prepared.gray, prepared.depth_m, prepared.boxes(),
                      prepared.features.keypoints, filtered->dynamic, options_.dynamic_mask);
  TrackResult tracked = tracker_.Track(std::move(frame));
  result->times.tracking_ms = MsSince(t_track);
  result->state = tracked.state;
  if (tracked.cam_from_world) result->world_from_cam = tracked.cam_from_world->Inverse();
  result->num_tracked = tracked.num_inliers;
  result->is_keyframe = tracked.new_keyframe != nullptr;
  return tracked;
}

void SystemImpl::RememberPoints(const PreparedFrame& prepared, const FilteredFrame& filtered,
                                const TrackResult& tracked) {
  previous_points_.clear();
  // Localization leaves the loaded map untouched: no votes, no points flagged.
  if (!options_.dynamic_points.enabled || options_.localization ||
      tracked.map_points.size() != filtered.kept_source.size())
    return;
  previous_points_.resize(prepared.features.keypoints.size());
  for (size_t k = 0; k < filtered.kept_source.size(); ++k)
    if (filtered.kept_source[k] >= 0)
      previous_points_[filtered.kept_source[k]] = tracked.map_points[k];
}

// A new keyframe: to the keyframe callback (the map), then to local mapping.
void SystemImpl::EmitKeyframe(const std::shared_ptr<KeyFrame>& keyframe,
                              const PreparedFrame& prepared, const FilteredFrame& filtered,
                              FrameResult* result) {
  std::function<void(const KeyframeData&)> cb;
  {
    std::lock_guard<std::mutex> lock(callback_mutex_);
    cb = keyframe_callback_;
  }
  if (cb) {
    // What the map needs of the frame, copied (the caller may reuse its buffers); the map mask
    // and, on a frame the detector skipped, the detection for it are computed on the callback's
    // thread (Post).
    const RgbdFrame& input = *prepared.input;
    auto data = std::make_shared<KeyframeData>();
    data->id = keyframe->id;
    data->stamp = input.stamp;
    data->world_from_cam = *result->world_from_cam;
    data->rgb = input.rgb.clone();
    data->depth = prepared.depth_m.clone();
    data->keypoints = prepared.features.keypoints;
    data->keypoint_dynamic = filtered.dynamic;
    std::optional<std::vector<Detection>> boxes = prepared.detections;
    // A keyframe on a frame the detector skipped (own cadence, or a detector outside that skips
    // frames, e.g. the DDS detector component): its mask for the map from the detector run on
    // this frame (carried boxes fit the people less well; tracking keeps using the carried ones,
    // so the trajectory does not depend on whether a map is built). The own detector is created
    // here on first use when boxes come from outside.
    DetectionWorker* detector = nullptr;
    if (prepared.detector_skipped && options_.detect_skipped_keyframes && keyframe_detector_ok_ &&
        input.rgb.type() == CV_8UC3) {
      try {
        EnsureDetector();
        detector = detection_worker_.get();
      } catch (const InputError& e) {
        // Boxes from outside (the own detector would have failed on its first frame): no model
        // here. The carried boxes stay; said once.
        LOG_WARNING << "keyframes on frames the detector skipped keep the carried boxes for their "
                       "map mask: "
                    << e.what();
        keyframe_detector_ok_ = false;
      }
    }
    const DynamicMaskOptions mask_options = options_.dynamic_mask;
    Post([cb, data, boxes, detector, mask_options]() mutable {
      if (detector) boxes = detector->Submit(data->rgb).result.get();
      data->dynamic_mask =
          ComputeDynamicMask(data->rgb.size(), data->depth, boxes ? *boxes : kNoDetections,
                             data->keypoints, data->keypoint_dynamic, mask_options);
      if (boxes) data->detections = *boxes;
      cb(*data);
    });
  }
  const auto t_map = std::chrono::steady_clock::now();
  tracker_.HandOffKeyFrame(keyframe);
  result->times.local_mapping_ms = MsSince(t_map);  // deterministic mode: local mapping runs here
}

// stella_vslam's create-frame / feed-frame: prepare, then filter -> track -> emit.
FrameResult SystemImpl::Feed(const RgbdFrame& frame, bool carry_boxes) {
  RethrowCallbackError();
  const auto t_start = std::chrono::steady_clock::now();
  FrameResult result;
  result.stamp = frame.stamp;
  const PreparedFrame prepared = Prepare(frame, carry_boxes, &result);
  FilteredFrame filtered = Filter(prepared, &result);
  const TrackResult tracked = Track(prepared, &filtered, &result);
  RememberPoints(prepared, filtered, tracked);
  if (tracked.new_keyframe) EmitKeyframe(tracked.new_keyframe, prepared, filtered, &result);
  result.times.total_ms = MsSince(t_start);
  return result;
}

MapFileInfo CheckMapFile(const std::string& path, const SystemOptions& options) {
  const OrbExtractor extractor(options.orb);
  auto geometry = std::make_shared<CameraGeometry>(
      CameraGeometry::Create(options.camera, options.sensor, extractor));
  const auto vocabulary = LoadVocabulary(options);
  const MapFileSettings settings =
      MapFileSettings::Of(*geometry, options.orb.scale_factor,
                          vocabulary ? vocabulary->Checksum() : 0, options.sensor.depth_map_factor);
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
  if (!impl_) return;
  try {
    impl_->Shutdown();
  } catch (const std::exception& e) {  // a keyframe callback's error, not collected by Shutdown()
    LOG_WARNING << "keyframe callback failed: " << e.what();
  }
}
FrameResult System::FeedRgbdFrame(const RgbdFrame& frame) { return impl_->Feed(frame); }
FrameResult System::FeedRgbdFrame(const cv::Mat& rgb, const cv::Mat& depth, Timestamp stamp,
                                  const cv::Mat& mask, const std::vector<Detection>* detections) {
  RgbdFrame frame;
  frame.stamp = stamp;
  frame.rgb = rgb;
  frame.depth = depth;
  frame.depth_scale = impl_->depth_map_factor();
  frame.mask = mask;
  if (detections) frame.detections = *detections;
  return impl_->Feed(frame);
}
FrameResult System::FeedRgbdFrameCarryingBoxes(const RgbdFrame& frame) {
  return impl_->Feed(frame, /*carry_boxes=*/true);
}
std::vector<StampedPose> System::Trajectory() const { return impl_->Trajectory(); }
LocalMappingStats System::LocalMappingStatistics() const { return impl_->LocalMappingStatistics(); }
LoopClosingStats System::LoopClosingStatistics() const { return impl_->LoopClosingStatistics(); }
MapStatistics System::MapSizes() const { return impl_->MapSizes(); }
std::vector<MapPointLabel> System::MapPointLabels() const { return impl_->MapPointLabels(); }
std::vector<StampedPose> System::KeyframeTrajectory() const { return impl_->KeyframeTrajectory(); }
void System::SetKeyframeCallback(std::function<void(const KeyframeData&)> callback) {
  impl_->SetKeyframeCallback(std::move(callback));
}
void System::Shutdown() { impl_->Shutdown(); }
MapFileInfo System::SaveMap(const std::string& path) const { return impl_->SaveMap(path); }
std::optional<MapFileInfo> System::LoadedMapInfo() const { return impl_->LoadedMapInfo(); }

}  // namespace dygslam
