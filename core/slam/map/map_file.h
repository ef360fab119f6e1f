// The SLAM map file: a map that outlives a run (save, load, localize, continue).
//
// What is stored: every active keyframe (id, frame id, stamp, cam_from_world, keypoints and their
// undistorted positions, descriptors, depth, virtual right coordinate, the "never seeds a point"
// flags, its map point per keypoint, BoW vector and direct index, covisibility weights and order,
// spanning-tree parent), every map point (id, position, descriptor, normal, scale distances,
// visibility counters, reference and first keyframe, observations), the id counters (a continued
// map keeps counting) and the settings that must match for the map to be usable: the camera
// (intrinsics, distortion, size, bf), ThDepth's close depth, the ORB pyramid (scale factor,
// levels), the vocabulary identity (its checksum; 0 = no vocabulary) and, from version 3 on, the
// depth scale (DepthMapFactor: a map made at one scale and used at another puts every point at
// the wrong distance). Culled keyframes are not
// stored: they only serve the trajectory of the run that culled them.
//
// Layout (binary, little-endian): magic "DYGSLMAP", u32 format version, u64 payload size, the
// payload, u64 FNV-1a checksum of everything before it. Written atomically (temp + rename).
// Reading checks, in this order: size, magic, version, declared size vs file size (truncation),
// checksum, settings, then every count against the bytes left and every index and id against
// what it refers to, so hostile bytes give an InputError ("FILE: what is wrong"), never a crash.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/base/camera.h"
#include "core/slam/map/frame.h"
#include "core/slam/map/map.h"

namespace dygslam {

constexpr uint32_t kMapFileVersion = 3;
// Version 1 differs only in its checksum's FNV offset basis; versions 1 and 2 have no depth scale
// (DepthMapFactor: 8 bytes after the vocabulary identity in version 3). Both are still read; their
// depth scale is unknown (0) and not checked.
constexpr uint32_t kOldestReadableMapFileVersion = 1;

// The settings a map depends on; a map is loaded only when they match the run's.
struct MapFileSettings {
  PinholeCamera camera;
  double bf = 0;
  double close_depth = 0;
  double orb_scale_factor = 0;
  int orb_levels = 0;
  uint64_t vocabulary_checksum = 0;  // 0: made without a vocabulary (no BoW vectors)
  double depth_map_factor = 0;       // DepthMapFactor; 0: unknown (versions 1 and 2), not checked

  // The settings of a run: geometry (camera, bf, close depth, pyramid) and its vocabulary checksum.
  static MapFileSettings Of(const CameraGeometry& geometry, double orb_scale_factor,
                            uint64_t vocabulary_checksum, double depth_map_factor = 0);
  // Empty when equal, else the first difference, e.g. "different camera: Camera.fx is 535.4 in
  // the map, 542.8 in the settings".
  std::string Difference(const MapFileSettings& run) const;
};

// What a map file holds besides the map (for messages and the status topic).
struct MapFileInfo {
  uint32_t version = 0;
  uint64_t checksum = 0;  // the file's checksum: identifies the map
  size_t keyframes = 0;
  size_t map_points = 0;
  size_t bytes = 0;
  MapFileSettings settings;
};

// The file's bytes for `map` (the caller must not let another thread change the map: the map's
// mutex is taken here). Deterministic: the same map gives the same bytes.
std::string EncodeMapFile(const Map& map, const MapFileSettings& settings);

// The checksum a map file of `version` stores in its last 8 bytes, over everything before them
// (FNV-1a 64; version 1 used another offset basis).
uint64_t MapFileChecksum(const char* data, size_t size, uint32_t version);

// Writes EncodeMapFile atomically to `path`; throws InputError naming `path` when it cannot be
// written. Returns what was written.
MapFileInfo SaveMapFile(const std::string& path, const Map& map, const MapFileSettings& settings);

// A map restored from a file: keyframes use `geometry` (built from the run's settings, which must
// equal the file's: checked against `run_settings`).
struct LoadedMap {
  std::shared_ptr<Map> map;
  MapFileInfo info;
};

// Decodes `bytes` (read from `source`, named in errors). Throws InputError "source: what is
// wrong" on any problem: another format version, truncation, corruption (checksum, counts,
// indices), settings that differ from `run_settings`.
LoadedMap DecodeMapFile(const std::string& bytes, const std::string& source,
                        const MapFileSettings& run_settings,
                        const std::shared_ptr<const CameraGeometry>& geometry);

// Reads and decodes `path` (missing, unreadable or not a regular file: InputError naming it).
LoadedMap LoadMapFile(const std::string& path, const MapFileSettings& run_settings,
                      const std::shared_ptr<const CameraGeometry>& geometry);

// One line for logs and summaries: "12 keyframes, 3456 map points, 1.2 MB, id 0123abcd...".
std::string DescribeMapFile(const MapFileInfo& info);

// The first bytes of every map file.
inline constexpr char kMapFileSignature[] = "DYGSLMAP";
// Checks before a run that `path` can be written at the end: not empty, not a folder, its folder
// exists. Throws InputError naming the path.
void CheckMapFileWritable(const std::string& path);

}  // namespace dygslam
