// The SLAM system as a library: RGB-D frames in, poses / keyframes out. No middleware.
//   System system(options);
//   RgbdFrame frame;                        // core/base/rgbd_frame.h
//   frame.stamp = t; frame.rgb = bgr; frame.depth = raw16; frame.depth_scale = 5000;
//   frame.detections = boxes;               // optional: else the System runs its own detector
//   FrameResult r = system.FeedRgbdFrame(frame);
//   FrameResult r = system.FeedRgbdFrame(rgb, depth, stamp);  // loose images, raw / DepthMapFactor
//
// Inside, like stella_vslam's create-frame / feed-frame: the frame is prepared (checks, grey
// image, depth in metres, ORB features while the detector runs;
// core/slam/feature/frame_preparation.h), then filtered (dynamic features out, top-up outside the
// boxes on crowded frames), tracked, and a new keyframe is emitted to the keyframe callback and
// handed to local mapping.
#pragma once

#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/base/camera.h"
#include "core/base/rgbd_frame.h"
#include "core/base/types.h"
#include "core/dynamic/detection_propagation.h"
#include "core/dynamic/dynamic_filter.h"
#include "core/dynamic/dynamic_mask.h"
#include "core/dynamic/yolo_detector.h"
#include "core/slam/feature/orb_extractor.h"
#include "core/slam/local_mapping/local_mapping.h"
#include "core/slam/loop_closing/loop_closing.h"
#include "core/slam/map/dynamic_points.h"
#include "core/slam/map/map_file.h"
#include "core/slam/tracking/tracking.h"

namespace dygslam {

// Per-frame stage times in milliseconds (the paper's Table 3 columns).
struct StageTimes {
  double orb_extraction_ms = 0;
  double detection_ms = 0;       // detector wall time (may overlap extraction)
  double detection_wait_ms = 0;  // time tracking waited for the detector after extraction
  double matching_ms = 0;        // dynamic filter: feature matching to previous frame
  double probability_ms = 0;     // dynamic filter: F estimation + probability update
  double top_up_ms = 0;          // crowded frames: extra extraction outside the boxes
  double tracking_ms = 0;        // pose tracking (motion model / reference KF / local map)
  double local_mapping_ms = 0;   // synchronous local mapping (deterministic mode only)
  double total_ms = 0;           // wall time of FeedRgbdFrame
};

struct FrameResult {
  Timestamp stamp;
  TrackingState state = TrackingState::kNotInitialized;
  std::optional<Rigid3d> world_from_cam;  // set only when HasPose(state)
  bool is_keyframe = false;
  int num_features = 0;
  int num_dynamic = 0;  // features removed by the dynamic filter
  int num_tracked = 0;  // inlier map-point matches after pose optimisation
  bool detections_used = false;
  // The internal detector did not run on this frame (SystemOptions::detection_every_n_frames):
  // the boxes of the last detector frame were carried to it (detections_used is true).
  bool detections_carried = false;
  StageTimes times;
};

struct SystemOptions {
  PinholeCamera camera;
  RgbdSensorOptions sensor;
  OrbExtractorOptions orb;
  TrackingOptions tracking;
  LocalMappingOptions local_mapping;
  // Place recognition (vocabulary) and loop closing; no vocabulary: neither.
  LoopClosingOptions loop_closing;
  // The filter mode (filter.mode: none, boxes, geometry, full; `--filter`) and the paper's
  // parameters.
  DynamicFilterOptions filter;
  // Pixels of keyframes judged dynamic, for the map.
  DynamicMaskOptions dynamic_mask;
  // When FeedRgbdFrame gets no detections and the filter mode needs them, this detector runs
  // inside the system, concurrently with ORB extraction. Empty cfg_path: the default model
  // (see SystemOptions::Check / system.cc).
  DetectorOptions detector;
  // The internal detector runs on every n-th frame (`Detector.every_n_frames`); the frames in
  // between get the last boxes shifted by their content's image motion (box_propagation, see
  // core/dynamic/detection_propagation.h) and the filter carries its per-feature probabilities
  // through the matches as on every frame. 2 by default (live use): with one OpenCV thread and
  // the aspect-ratio input (DetectorOptions) the System costs ~28 ms of CPU per frame on
  // bonn_crowd_part against ~37 ms with the detector on every frame, ATE not worse
  // (BENCHMARKS.md). The dataset presets (config/*.yaml) set 1 (the paper): their trajectory is the
  // reference of the accuracy tables and mapping/SlamMap's ghost-voxel test. Detections given to
  // FeedRgbdFrame from outside are used as given (and carried to FeedRgbdFrameCarryingBoxes).
  int detection_every_n_frames = 2;
  // detection_every_n_frames > 1 and a keyframe callback set (a map is built): a keyframe made on
  // a frame the detector skipped (the internal one's cadence, or a detector outside the System:
  // FeedRgbdFrameCarryingBoxes) gets its dynamic mask and detections (KeyframeData) from the
  // internal detector run on that frame then (`detector` options; created on first use), not
  // from the carried boxes; tracking keeps the carried boxes. Costs one detection per such
  // keyframe; false: the carried boxes.
  bool detect_skipped_keyframes = true;
  BoxPropagationOptions box_propagation;
  // Crowded frames: when fewer than this share of nFeatures survive the filter, features are
  // extracted again outside the detection boxes (budget = the shortfall) so tracking keeps a
  // full feature budget on the visible background. 0 disables it.
  double static_top_up_fraction = 0.7;
  // Features the filter keeps inside detection boxes never seed map points and do not count
  // toward the local-map inlier minimum (they may still be matched). false: the paper (they are
  // ordinary static features).
  bool demote_in_box_features = true;
  // Map points whose tracked features the filter labels dynamic are flagged and taken out of the
  // map (core/slam/map/dynamic_points.h). Off in the `paper` configurations.
  DynamicPointOptions dynamic_points;
  // Fixed seeds, local mapping run synchronously after each keyframe: identical output run to run.
  bool deterministic = false;
  // A SLAM map file to start from (map_file.h; empty: a new map). Its camera, ORB pyramid and
  // vocabulary must match these settings. Without `localization` the loaded map is extended
  // (keyframe and point ids continue); with it, frames are tracked against the loaded map without
  // adding keyframes or map points, and the first frame is relocalized with the BoW index.
  std::string load_map;
  bool localization = false;
  bool NeedsDetections() const { return UsesDetections(filter.mode); }
  void Check() const;
};

// Named filter configurations (`--filter NAME`): the four modes and the paper's method as written
// (docs/how_it_works.md, "Dynamic filter"):
//   paper  DYG-SLAM as the paper describes it (mode full): boxes exactly as detected, features
//          the filter keeps inside boxes are ordinary static features, no re-extraction, the
//          paper's epipolar test. Our documented choices only where the paper is silent
//          (matching, degenerate motion, variance of a new state).
//   full   our default: the paper's filter with our extensions (box margin, in-box demotion,
//          re-extraction outside the boxes, depth residual; the values of the settings file apply)
// (The ablation steps between them are configurations of the benchmark: tools/bench.) Sets
// options->filter.mode and, for paper, the extensions' options. Throws InvalidOptions naming the
// accepted names.
void ApplyFilterConfiguration(const std::string& name, SystemOptions* options);
// Every accepted name: none, boxes, geometry, paper, full.
const std::vector<std::string>& FilterConfigurationNames();

// Loads the map file `path` against the settings in `options` (camera, ORB pyramid, vocabulary)
// and returns what it holds; throws InputError naming the file and what is wrong. For checking a
// --load-map argument before a run starts (the map is loaded again by the System).
MapFileInfo CheckMapFile(const std::string& path, const SystemOptions& options);

class SystemImpl;

class System {
 public:
  explicit System(const SystemOptions& options);
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  // One frame (core/base/rgbd_frame.h): raw depth is divided by frame.depth_scale (once);
  // frame.detections, when given, are used instead of the internal detector (DDS detector
  // component, detections file); nullopt = run the internal one if the filter mode needs it.
  // Throws InputError naming the image for a frame that is not usable (CheckRgbdFrame) or a stamp
  // that does not increase.
  FrameResult FeedRgbdFrame(const RgbdFrame& frame);
  // The same from loose images (stella_vslam's feed_RGBD_frame): rgb CV_8UC3 BGR, depth CV_16UC1
  // raw (divided by the settings' DepthMapFactor) or CV_32FC1 metres, mask optional CV_8UC1
  // (nonzero = no features), detections nullptr = none given.
  FrameResult FeedRgbdFrame(const cv::Mat& rgb, const cv::Mat& depth, Timestamp stamp,
                            const cv::Mat& mask = cv::Mat(),
                            const std::vector<Detection>* detections = nullptr);
  // A frame the detector skipped (a detector outside the System running on every n-th frame,
  // SystemOptions::detection_every_n_frames = n > 1, e.g. the DDS detector component): filtered
  // with the boxes of the last detections given to FeedRgbdFrame, carried and shifted exactly as
  // for the internal detector's skipped frames (FrameResult::detections_carried). With n = 1 no
  // boxes are carried: the frame goes on without boxes. frame.detections is ignored. A keyframe
  // made on such a frame gets the internal detector's boxes for its mask
  // (SystemOptions::detect_skipped_keyframes).
  FrameResult FeedRgbdFrameCarryingBoxes(const RgbdFrame& frame);

  // Pipelining: starts the internal detector on a frame that will be fed next (dataset runs know
  // it in advance), so detection of frame t+1 overlaps the tracking of frame t and does not add to
  // the per-frame time. FeedRgbdFrame uses the prefetched detections when the stamp matches.
  // No effect when the filter mode needs no detections. `rgb` must stay valid until it is fed.
  void PrefetchDetections(const cv::Mat& rgb, Timestamp stamp);

  // Every tracked frame, world_from_cam, expressed relative to its (refined) reference keyframe.
  std::vector<StampedPose> Trajectory() const;
  // This run's keyframes (a loaded map's keyframes are in the map file, not here).
  std::vector<StampedPose> KeyframeTrajectory() const;
  // Called for each new keyframe and for keyframe pose corrections (pose_update_only = true), in
  // the order they happened, from one thread of the System's own (the caller's thread with
  // SystemOptions::deterministic): a keyframe's map mask (and, on a frame the detector skipped,
  // its detection) is computed there, not on the frame's critical path. Shutdown() returns when
  // every call is done. An exception the callback throws is rethrown by the next FeedRgbdFrame or
  // Shutdown.
  void SetKeyframeCallback(std::function<void(const KeyframeData&)> callback);
  // Local mapping so far: keyframes processed, points triangulated/culled, keyframes culled, time
  // per keyframe (its own thread; synchronous in deterministic mode).
  LocalMappingStats LocalMappingStatistics() const;
  // Loop closing so far (zeros without a vocabulary): loops detected/closed, points fused,
  // global bundle adjustments.
  LoopClosingStats LoopClosingStatistics() const;
  // Map sizes and live object counts (memory monitoring in long runs).
  MapStatistics MapSizes() const;
  // One observation of every point in the map and of every point flagged dynamic and taken out
  // (SystemOptions::dynamic_points), for evaluation against ground truth; after Shutdown.
  std::vector<MapPointLabel> MapPointLabels() const;
  // Map files (map_file.h). SaveMap writes the current map atomically (call after Shutdown for
  // the final map; during a run it saves a consistent snapshot under the map lock).
  MapFileInfo SaveMap(const std::string& path) const;
  // The map file this system started from (SystemOptions::load_map), if any.
  std::optional<MapFileInfo> LoadedMapInfo() const;
  // Finishes local mapping and loop closing (and a global bundle adjustment still running);
  // afterwards Trajectory() is final.
  void Shutdown();

 private:
  std::unique_ptr<SystemImpl> impl_;
};

}  // namespace dygslam
