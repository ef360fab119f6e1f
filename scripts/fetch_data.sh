#!/usr/bin/env bash
# Finds or downloads a dataset / model and prints its directory (last line of stdout).
#
#   scripts/fetch_data.sh [--dest DIR] NAME
#
# NAME:
#   bonn_crowd_part     the 360-frame excerpt of Bonn `crowd` shipped with the project (local only;
#                       falls back to the full bonn_crowd sequence when not found)
#   bonn_<sequence>     Bonn RGB-D Dynamic, e.g. bonn_crowd, bonn_crowd2, bonn_balloon,
#                       bonn_person_tracking, bonn_moving_nonobstructing_box
#   fr<N>_<sequence>    TUM RGB-D, e.g. fr3_walking_xyz, fr3_walking_halfsphere, fr3_walking_static,
#                       fr3_walking_rpy, fr3_sitting_static, fr1_xyz, fr2_desk
#   yolov3-tiny         YOLOv3-tiny Darknet weights (35,434,956 bytes) + cfg + coco.names
#
# Lookup order: $DYGSLAM_DATA_DIR (models: $DYGSLAM_MODELS_DIR), ../shared/data (../shared/models)
# next to the repository, then DIR (default: $DYGSLAM_DATA_DIR, else <repo>/data; models:
# <dest>/models). Only when nothing is found locally it downloads with curl from the official
# URL into DIR, unpacks and verifies the layout. DYGSLAM_OFFLINE=1 forbids downloads.
# Exit codes: 0 found, 1 not available (offline / download failed / bad layout), 2 usage.
set -euo pipefail

REPO="$(cd "$(dirname "$0")/.." && pwd)"
SHARED_DATA="$REPO/../shared/data"
SHARED_MODELS="$REPO/../shared/models"
YOLO_WEIGHTS_URL="https://pjreddie.com/media/files/yolov3-tiny.weights"
YOLO_WEIGHTS_SIZE=35434956
YOLO_CFG_URL="https://raw.githubusercontent.com/pjreddie/darknet/master/cfg/yolov3-tiny.cfg"
COCO_NAMES_URL="https://raw.githubusercontent.com/pjreddie/darknet/master/data/coco.names"

log() { echo "fetch_data: $*" >&2; }
die() { echo "fetch_data: error: $*" >&2; exit 1; }
usage() {
  sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

DEST=""
NAME=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --dest) [[ $# -ge 2 ]] || usage; DEST="$2"; shift 2 ;;
    --dest=*) DEST="${1#--dest=}"; shift ;;
    -h|--help) usage ;;
    -*) echo "fetch_data: unknown option $1" >&2; usage ;;
    *) [[ -z "$NAME" ]] || usage; NAME="$1"; shift ;;
  esac
done
[[ -n "$NAME" ]] || usage
if [[ -z "$DEST" ]]; then DEST="${DYGSLAM_DATA_DIR:-$REPO/data}"; fi

# A dataset folder in TUM layout?
dataset_ok() {
  [[ -f "$1/rgb.txt" && -f "$1/depth.txt" && -d "$1/rgb" && -d "$1/depth" ]]
}
verify_dataset() {
  local dir="$1" missing=()
  for f in rgb.txt depth.txt; do [[ -f "$dir/$f" ]] || missing+=("$f"); done
  for d in rgb depth; do [[ -d "$dir/$d" ]] || missing+=("$d/"); done
  [[ ${#missing[@]} -eq 0 ]] || die "$dir: not a TUM-layout dataset (missing: ${missing[*]})"
  [[ -f "$dir/groundtruth.txt" ]] || log "warning: $dir has no groundtruth.txt (no evaluation possible)"
}

download() {  # url output
  local url="$1" out="$2"
  if [[ "${DYGSLAM_OFFLINE:-0}" == "1" ]]; then
    die "$NAME not found locally and downloads are disabled (DYGSLAM_OFFLINE=1).
  Download $url yourself and put it (unpacked) into ${PLACE_HINT:-$DEST},
  or point DYGSLAM_DATA_DIR / DYGSLAM_MODELS_DIR at a folder that has it."
  fi
  command -v curl >/dev/null || die "curl not found (apt-get install curl), needed to download $url"
  log "downloading $url"
  if ! curl -fL --retry 2 --connect-timeout 20 -o "$out.part" "$url"; then
    rm -f "$out.part"
    die "could not download $url (offline?).
  Put the data in \$DYGSLAM_DATA_DIR (or ../shared/data) yourself, or retry with network access."
  fi
  mv "$out.part" "$out"
}

# ---------------------------------------------------------------- models
if [[ "$NAME" == "yolov3-tiny" ]]; then
  MODELS_DEST="${DYGSLAM_MODELS_DIR:-$DEST/models}"
  weights_ok() {
    [[ -f "$1/yolov3-tiny.weights" ]] &&
      [[ "$(stat -c %s "$1/yolov3-tiny.weights")" == "$YOLO_WEIGHTS_SIZE" ]] &&
      [[ -f "$1/yolov3-tiny.cfg" ]]
  }
  for root in "${DYGSLAM_MODELS_DIR:-}" "$SHARED_MODELS" "$MODELS_DEST"; do
    [[ -n "$root" && -d "$root/yolov3-tiny" ]] || continue
    if weights_ok "$root/yolov3-tiny"; then
      echo "$(cd "$root/yolov3-tiny" && pwd)"
      exit 0
    fi
    if [[ -f "$root/yolov3-tiny/yolov3-tiny.weights" ]]; then
      log "ignoring $root/yolov3-tiny/yolov3-tiny.weights: $(stat -c %s "$root/yolov3-tiny/yolov3-tiny.weights") bytes, expected $YOLO_WEIGHTS_SIZE"
    fi
  done
  target="$MODELS_DEST/yolov3-tiny"
  PLACE_HINT="$target"
  mkdir -p "$target"
  # cfg / names: copy from a local copy when there is one.
  for f in yolov3-tiny.cfg coco.names; do
    [[ -f "$target/$f" ]] && continue
    for root in "${DYGSLAM_MODELS_DIR:-}" "$SHARED_MODELS"; do
      if [[ -n "$root" && -f "$root/yolov3-tiny/$f" ]]; then cp "$root/yolov3-tiny/$f" "$target/$f"; break; fi
    done
  done
  download "$YOLO_WEIGHTS_URL" "$target/yolov3-tiny.weights"
  size="$(stat -c %s "$target/yolov3-tiny.weights")"
  if [[ "$size" != "$YOLO_WEIGHTS_SIZE" ]]; then
    rm -f "$target/yolov3-tiny.weights"
    die "downloaded yolov3-tiny.weights has $size bytes, expected $YOLO_WEIGHTS_SIZE (removed)"
  fi
  [[ -f "$target/yolov3-tiny.cfg" ]] || download "$YOLO_CFG_URL" "$target/yolov3-tiny.cfg"
  [[ -f "$target/coco.names" ]] || download "$COCO_NAMES_URL" "$target/coco.names"
  echo "$(cd "$target" && pwd)"
  exit 0
fi

# ---------------------------------------------------------------- datasets
FALLBACK=""
case "$NAME" in
  bonn_crowd_part)
    CANDIDATES=(bonn_crowd_part)
    FALLBACK=bonn_crowd ;;
  bonn_*)
    seq="${NAME#bonn_}"
    [[ "$seq" =~ ^[a-z0-9_]+$ ]] || usage
    CANDIDATES=("$NAME" "rgbd_bonn_$seq")
    URL="https://www.ipb.uni-bonn.de/html/projects/rgbd_dynamic2019/rgbd_bonn_$seq.zip"
    UNPACKED="rgbd_bonn_$seq" ;;
  fr[123]_*)
    n="${NAME:2:1}"
    seq="${NAME#fr?_}"
    [[ "$seq" =~ ^[a-z0-9_]+$ ]] || usage
    CANDIDATES=("$NAME" "rgbd_dataset_freiburg${n}_$seq")
    URL="https://cvg.cit.tum.de/rgbd/dataset/freiburg$n/rgbd_dataset_freiburg${n}_$seq.tgz"
    UNPACKED="rgbd_dataset_freiburg${n}_$seq" ;;
  *)
    echo "fetch_data: unknown name '$NAME'" >&2
    usage ;;
esac

for root in "${DYGSLAM_DATA_DIR:-}" "$SHARED_DATA" "$DEST"; do
  [[ -n "$root" ]] || continue
  for c in "${CANDIDATES[@]}"; do
    if dataset_ok "$root/$c"; then
      verify_dataset "$root/$c"
      echo "$(cd "$root/$c" && pwd)"
      exit 0
    fi
    [[ -d "$root/$c" ]] && verify_dataset "$root/$c"  # exists but incomplete: say what is missing
  done
done

if [[ -n "$FALLBACK" ]]; then
  log "$NAME not found locally (it is a 360-frame excerpt of bonn_crowd); using the full $FALLBACK sequence"
  args=()
  [[ -n "$DEST" ]] && args=(--dest "$DEST")
  exec "$0" "${args[@]}" "$FALLBACK"
fi

mkdir -p "$DEST"
archive="$DEST/$(basename "$URL")"
download "$URL" "$archive"
log "unpacking $archive"
case "$archive" in
  *.tgz) tar -xzf "$archive" -C "$DEST" ;;
  *.zip) python3 -m zipfile -e "$archive" "$DEST" ;;
esac
rm -f "$archive"
[[ -d "$DEST/$UNPACKED" ]] || die "$archive did not contain $UNPACKED/"
verify_dataset "$DEST/$UNPACKED"
echo "$(cd "$DEST/$UNPACKED" && pwd)"
