#!/bin/bash
# Wide hostile-input check (~500 cases) against a built `dygslam`:
# every settings key with hostile values, YAML features (merge keys, tabs, several documents,
# tags), images of the wrong bit depth or channels, lists out of order, --frames edge cases, the
# other subcommands with hostile options, signals at every phase of run / map / bench / component
# pipeline, a full disk, an --out made read-only or deleted mid-run, a second player.
#
#   tests/reliability/probe/fresh_probe.sh [BUILD_DIR] [WORK_DIR]
#
# Runs itself in a private network and mount namespace (DDS stays on this machine, domains
# 194-196, the prober's range; the tmpfs of the disk probes is private). Verdicts as in
# hostile_probe.sh (probe_lib.sh),
# plus SANITIZER (an ASan / UBSan report in the log) and HALF (an output cut short).
# PROBE_ONLY=a,b runs the families a and b only (settings yaml images lists frames commands
# signals disk dds). Exit code: the number of probes that are not ok.
set -u
BUILD_DIR=$(realpath "${1:-build}")
WORK=$(realpath -m "${2:-/tmp/dygslam_fresh_probe_$$}")
if [ -z "${DYGSLAM_PROBE_IN_NETNS:-}" ]; then
  exec unshare -n -m bash -c "ip link set lo up; ip link set lo multicast on; \
    ip route add 224.0.0.0/4 dev lo; DYGSLAM_PROBE_IN_NETNS=1 exec bash '$0' '$BUILD_DIR' '$WORK'"
fi
SRC=$(cd "$(dirname "$0")/../../.." && pwd)
DYG="$BUILD_DIR/apps/dygslam"
CFG="$SRC/config/bonn.yaml"
DATA="${DYGSLAM_DATA_DIR:-$SRC/../shared/data}/bonn_crowd_part"
[ -x "$DYG" ] || { echo "no $DYG (build first)"; exit 2; }
[ -f "$DATA/rgb.txt" ] || { echo "no dataset at $DATA"; exit 2; }
mkdir -p "$WORK/logs"
cd "$WORK" || exit 2
export DYGSLAM_DOMAIN_ID=194
# The probes run from WORK_DIR: name the models folder (the default ../shared/models is relative).
export DYGSLAM_MODELS_DIR="${DYGSLAM_MODELS_DIR:-$SRC/../shared/models}"
FAILS=0
# shellcheck source=probe_lib.sh
. "$SRC/tests/reliability/probe/probe_lib.sh"
family() { [ -z "${PROBE_ONLY:-}" ] || [[ ",$PROBE_ONLY," == *",$1,"* ]]; }
# note NAME VERDICT TEXT: a finding of a check after the probe's exit code.
note() {
  echo "  $1: $2 $3"
  FAILS=$((FAILS + 1))
}

small ds 20
small ds40 40
# probe_cfg NAME WANT FILE: `run --direct` of 4 frames with settings FILE.
probe_cfg() {
  probe "$1" "$2" 90 "$DYG" run ds --config "$3" --out "o_$1" --direct --quiet --filter none \
    --frames 0:4
}
# Settings with `key: value` set: a flat key's line replaced, a section key in its section.
with_key() {
  python3 "$SRC/tests/reliability/probe/set_key.py" "$CFG" "$1" "$2"
}

if family settings; then
  echo "== settings: every key with hostile values"
  # Keys of every section (docs/settings.md) with a value that must be refused.
  keys="Camera.fx Camera.fy Camera.cx Camera.cy Camera.k1 Camera.k2 Camera.p1 Camera.p2 Camera.k3
    Camera.width Camera.height Camera.fps Camera.bf ThDepth DepthMapFactor ORBextractor.nFeatures
    ORBextractor.scaleFactor ORBextractor.nLevels ORBextractor.iniThFAST ORBextractor.minThFAST
    OctoMap.resolution OctoMap.max_range OctoMap.prob_hit OctoMap.clamping_max OctoMap.pixel_stride
    Tracking.max_frames_between_keyframes Tracking.init_min_features Tracking.dense_fallback
    Tracking.fallback_smoothing LocalMapping.cull_keyframes DynamicFilter.alpha
    DynamicFilter.Q DynamicFilter.P_init DynamicFilter.threshold DynamicFilter.box_margin_fraction
    DynamicFilter.fundamental_threshold DynamicFilter.world_anchors DynamicFilter.mode
    Detector.input_width Detector.confidence_threshold Detector.num_threads
    Detector.every_n_frames Detector.model LoopClosing.enabled LoopClosing.revisit_min_path_m
    LoopClosing.global_bundle_adjustment LoopClosing.max_correction_m LoopClosing.vocabulary"
  for key in $keys; do
    i=0
    for value in .nan 1e400 '[1, 2]' '{a: 1}' 'abc' '99999999999999999999'; do
      i=$((i + 1))
      f=$(with_key "$key" "$value")
      name="k_${key//./_}_$i"
      probe_cfg "$name" 1 "$f"
      # A refused value must be named by its key and line.
      if [ -s "logs/$name.err" ] && ! grep -q "${key#*.}" "logs/$name.err"; then
        note "$name" NOKEY "message does not name ${key} (value $value)"
      fi
    done
  done
fi

if family yaml; then
  echo "== YAML features"
  yaml() { cp "$CFG" "y_$1.yaml"; printf '%b' "$2" >>"y_$1.yaml"; echo "y_$1.yaml"; }
  # Merge keys: yaml-cpp does not merge; the values must not be dropped without a word.
  probe_cfg y_merge_key 1 "$(yaml merge_key 'base: &b {alpha: 0.9}\nDynamicFilter:\n  <<: *b\n')"
  probe_cfg y_merge_flow '0|1' "$(yaml merge_flow 'DynamicFilter: {<<: {threshold: 0.7}}\n')"
  grep -q "<<\|merge" logs/y_merge_flow.err || note y_merge_flow SILENT "merge key dropped"
  probe_cfg y_tab_indent 1 "$(yaml tab_indent 'Tracking:\n\tinit_min_features: 200\n')"
  grep -q ":[0-9]" logs/y_tab_indent.err || note y_tab_indent NOLINE "no line"
  probe_cfg y_two_docs 1 "$(yaml two_docs '---\nCamera.fx: 500\n')"
  probe_cfg y_doc_end '0|1' "$(yaml doc_end '...\nCamera.fx: 12\n')"
  [ "$(grep -c . logs/y_doc_end.err)" -gt 0 ] || note y_doc_end SILENT "text after '...' ignored"
  probe_cfg y_dup_in_section 1 "$(yaml dup_in_section 'Tracking:\n  init_min_features: 300\n  init_min_features: 200\n')"
  probe_cfg y_flat_and_nested 1 "$(yaml flat_and_nested 'Camera:\n  fy: 500\n')"
  probe_cfg y_tag_str '0|1' "$(sed 's/^Camera.fx:.*/Camera.fx: !!str 542/' "$CFG" >y_tag_str.yaml; echo y_tag_str.yaml)"
  probe_cfg y_tag_custom '0|1' "$(sed 's/^Camera.fx:.*/Camera.fx: !weird 542.8/' "$CFG" >y_tag_c.yaml; echo y_tag_c.yaml)"
  probe_cfg y_tag_binary 1 "$(sed 's/^Camera.fx:.*/Camera.fx: !!binary aGVsbG8=/' "$CFG" >y_tag_b.yaml; echo y_tag_b.yaml)"
  probe_cfg y_int_float 1 "$(sed 's/^ORBextractor.nFeatures:.*/ORBextractor.nFeatures: 1000.5/' "$CFG" >y_if.yaml; echo y_if.yaml)"
  probe_cfg y_int_hex '0|1' "$(sed 's/^ORBextractor.nFeatures:.*/ORBextractor.nFeatures: 0x3E8/' "$CFG" >y_ih.yaml; echo y_ih.yaml)"
  probe_cfg y_int_octal '0|1' "$(sed 's/^ORBextractor.nLevels:.*/ORBextractor.nLevels: 010/' "$CFG" >y_io.yaml; echo y_io.yaml)"
  probe_cfg y_width_float 1 "$(sed 's/^Camera.width:.*/Camera.width: 640.5/' "$CFG" >y_wf.yaml; echo y_wf.yaml)"
  probe_cfg y_quoted_num 0 "$(sed 's/^Camera.fx:.*/Camera.fx: "542.822841"/' "$CFG" >y_qn.yaml; echo y_qn.yaml)"
  probe_cfg y_bool_word 0 "$(yaml bool_word 'LocalMapping:\n  cull_keyframes: off\n')"
  probe_cfg y_bool_two 1 "$(yaml bool_two 'LocalMapping:\n  cull_keyframes: 2\n')"
  probe_cfg y_bool_string 1 "$(yaml bool_string 'LocalMapping:\n  cull_keyframes: maybe\n')"
  probe_cfg y_case_key 0 "$(yaml case_key 'camera.fx: 500\n')"
  grep -q "did you mean" logs/y_case_key.err || note y_case_key SILENT "no warning"
  probe_cfg y_section_case 0 "$(yaml section_case 'dynamicfilter:\n  threshold: 0.9\n')"
  grep -q "unknown key" logs/y_section_case.err || note y_section_case SILENT "no warning"
  probe_cfg y_key_space 0 "$(yaml key_space '"Camera.fx ": 500\n')"
  grep -q "unknown key" logs/y_key_space.err || note y_key_space SILENT "no warning"
  probe_cfg y_long_key 1 "$(yaml long_key "$(head -c 100000 /dev/zero | tr '\0' k): 1\n")"
  [ "$(wc -c <logs/y_long_key.err)" -lt 4000 ] || note y_long_key UNBOUNDED "echo of the key"
  probe_cfg y_latin1 '0|1' "$(yaml latin1 'Tracking:\n  caf\xe9: 1\n')"
  probe_cfg y_yaml12 '0|1' "$(printf '%%YAML 1.2\n---\n' >y_y12.yaml; tail -n +2 "$CFG" >>y_y12.yaml; echo y_y12.yaml)"
  probe_cfg y_comments_only 1 "$(printf '# nothing\n' >y_co.yaml; echo y_co.yaml)"
  probe_cfg y_top_list 1 "$(printf -- '- 1\n- 2\n' >y_tl.yaml; echo y_tl.yaml)"
  probe_cfg y_top_scalar 1 "$(printf 'hello\n' >y_ts.yaml; echo y_ts.yaml)"
  probe_cfg y_anchor_reuse 0 "$(yaml anchor_reuse 'Tracking: &t {init_min_features: 300}\nLocalMapping: {cull_keyframes: true}\n')"
  probe_cfg y_alias_scalar 0 "$(sed 's/^Camera.fx:.*/Camera.fx: \&f 542.822841/; s/^Camera.fy:.*/Camera.fy: *f/' "$CFG" >y_as.yaml; echo y_as.yaml)"
  probe_cfg y_alias_undefined 1 "$(yaml alias_undefined 'Tracking: *nothere\n')"
  probe_cfg y_crlf 0 "$(sed 's/$/\r/' "$CFG" >y_crlf.yaml; echo y_crlf.yaml)"
  probe_cfg y_classes_empty 1 "$(yaml classes_empty 'Detector:\n  dynamic_classes: []\n')"
  probe_cfg y_classes_dup '0|1' "$(yaml classes_dup 'Detector:\n  dynamic_classes: [person, person]\n')"
  probe_cfg y_empty_value 1 "$(sed 's/^Camera.fx:.*/Camera.fx:/' "$CFG" >y_ev.yaml; echo y_ev.yaml)"
  probe_cfg y_null_value 1 "$(sed 's/^Camera.fx:.*/Camera.fx: ~/' "$CFG" >y_nv.yaml; echo y_nv.yaml)"
  probe_cfg y_neg_zero 1 "$(sed 's/^Camera.fx:.*/Camera.fx: -0.0/' "$CFG" >y_nz.yaml; echo y_nz.yaml)"
  probe_cfg y_denormal 1 "$(sed 's/^Camera.fx:.*/Camera.fx: 4.9e-324/' "$CFG" >y_dn.yaml; echo y_dn.yaml)"
  probe_cfg y_opencv_matrix 1 "$(sed 's/^Camera.fx:.*/Camera.fx: !!opencv-matrix {rows: 1, cols: 1, dt: d, data: [542.8]}/' "$CFG" >y_om.yaml; echo y_om.yaml)"
  probe_cfg y_depthfactor_zero 1 "$(sed 's/^DepthMapFactor:.*/DepthMapFactor: 0/' "$CFG" >y_dz.yaml; echo y_dz.yaml)"
  probe_cfg y_scale_one 1 "$(sed 's/^ORBextractor.scaleFactor:.*/ORBextractor.scaleFactor: 1.0/' "$CFG" >y_s1.yaml; echo y_s1.yaml)"
  probe_cfg y_fast_order 1 "$(sed 's/^ORBextractor.minThFAST:.*/ORBextractor.minThFAST: 50/' "$CFG" >y_fo.yaml; echo y_fo.yaml)"
  probe_cfg y_prob_order 1 "$(yaml_oct=1; sed 's/^  prob_hit:.*/  prob_hit: 0.3/' "$CFG" >y_po.yaml; echo y_po.yaml)"
  probe_cfg y_clamp_order 1 "$(sed 's/^  clamping_min:.*/  clamping_min: 0.99/' "$CFG" >y_cl.yaml; echo y_cl.yaml)"
  probe_cfg y_range_order 1 "$(sed 's/^  min_range:.*/  min_range: 9.0/' "$CFG" >y_ro.yaml; echo y_ro.yaml)"
fi

if family images; then
  echo "== images of the wrong bit depth or channels"
  # mkimg NAME KIND: ds_NAME whose entry 10 (rgb or depth) is an image made by python/OpenCV.
  mkimg() {
    small "ds_$1" 20
    local col=$2 list=rgb.txt
    [ "$col" = depth ] && list=depth.txt
    local line; line=$(sed -n 11p "ds_$1/$list")
    sed -i "11s#.*#${line%% *} bad.png#" "ds_$1/$list"
    python3 - "ds_$1/bad.png" "$3" <<'EOF'
import sys, struct, zlib
path, kind = sys.argv[1], sys.argv[2]
def chunk(t, d): return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
def png(w, h, depth, ctype, bpp, plte=None):
    row = b'\0' + bytes(int(w * bpp + 0.999))
    raw = row * h
    out = b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, depth, ctype, 0, 0, 0))
    if plte: out += chunk(b'PLTE', plte)
    return out + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b'')
W, H = 640, 480
data = {
  'gray8': png(W, H, 8, 0, 1), 'gray16': png(W, H, 16, 0, 2), 'rgb16': png(W, H, 16, 2, 6),
  'rgba8': png(W, H, 8, 6, 4), 'gray1': png(W, H, 1, 0, 1 / 8), 'palette': png(W, H, 8, 3, 1, b'\0\0\0'),
  'rgb8': png(W, H, 8, 2, 3), 'graya16': png(W, H, 16, 4, 4), 'small': png(W - 1, H, 8, 2, 3),
  'zero': png(0, 0, 8, 2, 3), 'bigw': png(W * 2, H, 16, 0, 2),
}[kind]
open(path, 'wb').write(data)
EOF
  }
  for kind in gray8 rgb16 rgba8 gray1 palette rgb8 graya16 small zero bigw; do
    mkimg "d_$kind" depth "$kind"
    want=1
    probe "i_depth_$kind" "$want" 90 "$DYG" run "ds_d_$kind" --config "$CFG" --out "o_i_d_$kind" \
      --direct --quiet --filter none
    grep -q "depth.txt:11" "logs/i_depth_$kind.err" || note "i_depth_$kind" NOLINE "no list line"
  done
  for kind in gray16 rgb16 gray1 palette graya16 gray8 rgba8 small zero; do
    mkimg "r_$kind" rgb "$kind"
    case $kind in gray8 | rgba8 | palette | gray1) want='0|1' ;; *) want=1 ;; esac
    probe "i_rgb_$kind" "$want" 90 "$DYG" run "ds_r_$kind" --config "$CFG" --out "o_i_r_$kind" \
      --direct --quiet --filter none
  done
  # A JPEG named .png, a PNG with a bad CRC, a PNG cut inside IHDR.
  small ds_jpeg 20; python3 -c "
import cv2, numpy as np; cv2.imwrite('ds_jpeg/x.jpg', np.zeros((480,640,3), np.uint8))" 2>/dev/null
  if [ -f ds_jpeg/x.jpg ]; then
    mv ds_jpeg/x.jpg ds_jpeg/bad.png; l=$(sed -n 11p ds_jpeg/rgb.txt); sed -i "11s#.*#${l%% *} bad.png#" ds_jpeg/rgb.txt
    probe i_jpeg_as_png '0|1' 90 "$DYG" run ds_jpeg --config "$CFG" --out o_i_jpeg --direct --quiet --filter none
  fi
  mkimg crc rgb rgb8; printf '\x00' | dd of=ds_crc/bad.png bs=1 seek=29 conv=notrunc 2>/dev/null
  probe i_bad_crc 1 90 "$DYG" run ds_crc --config "$CFG" --out o_i_crc --direct --quiet --filter none
  mkimg cut rgb rgb8; truncate -s 20 ds_cut/bad.png
  probe i_cut_ihdr 1 90 "$DYG" run ds_cut --config "$CFG" --out o_i_cut --direct --quiet --filter none
  mkimg empty rgb rgb8; : >ds_empty/bad.png
  probe i_empty_file 1 90 "$DYG" run ds_empty --config "$CFG" --out o_i_empty --direct --quiet --filter none
  # The same images through the DDS player and `map`.
  probe i_depth_rgb8_dds 1 180 "$DYG" run ds_d_rgb8 --config "$CFG" --out o_i_d_dds --quiet --filter none --domain 195
  [ -s o_i_d_dds/trajectory.txt ] || note i_depth_rgb8_dds LOSS "no trajectory of the frames before"
  probe i_depth_rgb8_map 1 180 "$DYG" map ds_d_rgb8 --config "$CFG" --out o_i_d_map --quiet --filter none
  [ -s o_i_d_map/map.bt ] || note i_depth_rgb8_map LOSS "no map of the frames before"
fi

if family lists; then
  echo "== lists"
  lst() {  # lst NAME SCRIPT: ds_NAME (20 frames) changed by the shell SCRIPT run inside it
    small "ds_$1" 20
    (cd "ds_$1" && eval "$2")
  }
  lprobe() {  # lprobe NAME WANT: run --direct on ds_NAME
    probe "$1" "$2" 120 "$DYG" run "ds_$1" --config "$CFG" --out "o_$1" --direct --quiet --filter none
  }
  lst l_depth_unsorted '(sed -n 5p depth.txt; cat depth.txt) >u && mv u depth.txt'; lprobe l_depth_unsorted 1
  lst l_depth_dup 'sed -n 3p depth.txt >>depth.txt; sort -n depth.txt -o depth.txt'; lprobe l_depth_dup 1
  lst l_rgb_dup 'sed -i "4s/^[^ ]*/$(sed -n 3p rgb.txt | cut -d" " -f1)/" rgb.txt'; lprobe l_rgb_dup 1
  lst l_rgb_reversed 'tac rgb.txt >u && mv u rgb.txt'; lprobe l_rgb_reversed 1
  lst l_comments_only 'echo "# x" >rgb.txt'; lprobe l_comments_only 1
  lst l_empty ': >rgb.txt'; lprobe l_empty 1
  lst l_tabs 'sed -i "s/ /\t/" rgb.txt'; lprobe l_tabs 0
  lst l_three_cols 'sed -i "5s/$/ extra/" rgb.txt'; lprobe l_three_cols 1
  for stamp in nan inf 1e400 -0 0x10 1e18 12345678901234567890.5 1548339823.1234567890123; do
    n="l_stamp_${stamp//[^a-z0-9]/_}"
    lst "$n" "sed -i \"1s/^[^ ]*/$stamp/\" rgb.txt"
    case $stamp in 1548339823.1234567890123 | -0) w='0|1' ;; *) w=1 ;; esac
    lprobe "$n" "$w"
  done
  lst l_no_overlap 'awk "{printf \"%.6f %s\n\", \$1 + 1000, \$2}" depth.txt >u && mv u depth.txt'; lprobe l_no_overlap 1
  lst l_half_overlap 'head -n 10 depth.txt >u && mv u depth.txt'; lprobe l_half_overlap 0
  lst l_self_link 'rm rgb.txt; ln -s rgb.txt rgb.txt'; lprobe l_self_link 1
  lst l_rgb_dir 'rm rgb.txt; mkdir rgb.txt'; lprobe l_rgb_dir 1
  lst l_assoc_bad 'echo "1 a 2" >associations.txt'; lprobe l_assoc_bad 1
  lst l_assoc_far 'paste -d" " rgb.txt depth.txt | awk "{print \$1, \$2, \$1 + 5, \$4}" >associations.txt'; lprobe l_assoc_far 1
  lst l_gt_nan 'sed -i "3s/^\([^ ]*\) [^ ]*/\1 nan/" groundtruth.txt'; lprobe l_gt_nan 0
  grep -q "groundtruth.txt:3" logs/l_gt_nan.err || note l_gt_nan SILENT "NaN in groundtruth.txt"
  lst l_gt_quat_zero 'sed -i "3s/^\(\S* \S* \S* \S*\) .*/\1 0 0 0 0/" groundtruth.txt'; lprobe l_gt_quat_zero 0
  grep -q "groundtruth.txt:3" logs/l_gt_quat_zero.err || note l_gt_quat_zero SILENT "zero quaternion"
  lst l_outside_many 'sed -i "s#rgb/#$DATA/rgb/#" rgb.txt'; lprobe l_outside_many 0
  [ "$(grep -c "outside the dataset" logs/l_outside_many.err)" -le 1 ] ||
    note l_outside_many NOISY "$(grep -c "outside the dataset" logs/l_outside_many.err) warnings for one list"
  lst l_utf16 'iconv -f utf-8 -t utf-16 rgb.txt >u && mv u rgb.txt'; lprobe l_utf16 1
  lst l_nul_line 'printf "1548339823.9 rgb/a\0b.png\n" >>rgb.txt'; lprobe l_nul_line 1
  lst l_space_path 'cp "$(readlink -f rgb)/$(ls rgb | head -1)" "a b.png"; sed -i "1s#rgb/[^ ]*#a b.png#" rgb.txt'; lprobe l_space_path 1
  det_stamp=$(awk 'NR==1{print $1}' ds/rgb.txt)
  for d in "$det_stamp 10 10 -50 50 0 0.9" "$det_stamp 10 10 50 50 0 nan" "$det_stamp nan 10 50 50 0 0.9" \
    "$det_stamp 10 10 50 50 0" "$det_stamp 1e9 1e9 1e9 1e9 0 0.9" "$det_stamp 10 10 50 50 0 7"; do
    i=$(( ${i:-0} + 1 )); echo "$d" >"det_$i.txt"
    w=1; [[ "$d" == *" 1e9 1e9 "* ]] && w=0  # a box outside the image: a warning (checked below)
    probe "l_det_$i" "$w" 120 "$DYG" run ds --config "$CFG" --out "o_l_det_$i" --direct --quiet --filter boxes --detections "det_$i.txt"
    [ "$w" = 1 ] || grep -q "lie outside" "logs/l_det_$i.err" || note "l_det_$i" SILENT "box outside the image"
  done
fi

if family frames; then
  echo "== --frames edge cases"
  for f in 0:0 : 5: :5 19:20 20: 20:21 1e1:15 ' 0:5' 0:5:7 0x2:5 +1:5 1.5:3 3 '' a:b -0:5 \
    0:18446744073709551616 '0:5 ' '０:5'; do
    i=$(( ${j:-0} + 1 )); j=$i
    probe "f_frames_$i" '0|1|2' 120 "$DYG" run ds --config "$CFG" --out "o_f_$i" --direct --quiet --filter none --frames "$f"
    echo "    (f_frames_$i was --frames '$f'; trajectory: $(grep -cv '^#' "o_f_$i/trajectory.txt" 2>/dev/null || echo none) poses)"
  done
  probe f_map_frames_empty 2 30 "$DYG" map ds --config "$CFG" --out o_f_m --frames 5:5
  probe f_bench_frames_rev 2 30 "$DYG" bench ds --frames 9:3 --out o_f_b --runs 1
  probe f_component_frames 2 30 "$DYG" component player --dataset ds --config "$CFG" --frames x:1
fi

if family commands; then
  echo "== subcommands with hostile options"
  gt=ds/groundtruth.txt
  awk 'NR<=30' "$gt" >est.txt
  printf '1 nan 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n' >est_nan.txt
  printf '1 0 0 0 0 0 0 1\n' >est_one.txt
  printf '1 0 0 0 0 0 0 0\n2 1 0 0 0 0 0 0\n3 0 1 0 0 0 0 0\n' >est_q0.txt
  probe e_nan 1 30 "$DYG" eval "$gt" est_nan.txt
  probe e_one 1 30 "$DYG" eval "$gt" est_one.txt
  probe e_quat_zero 1 30 "$DYG" eval est_q0.txt est_q0.txt
  probe e_empty 1 30 "$DYG" eval "$gt" /dev/null
  probe e_delta_zero 2 30 "$DYG" eval "$gt" est.txt --delta 0
  probe e_delta_nan 2 30 "$DYG" eval "$gt" est.txt --delta nan
  probe e_maxdiff_neg 2 30 "$DYG" eval "$gt" est.txt --max-diff -1
  probe e_offset_inf 2 30 "$DYG" eval "$gt" est.txt --offset inf
  probe e_plot_nodir 1 60 "$DYG" eval "$gt" est.txt --plot /nonexistent/dir/x.png
  probe e_plot_dir 2 60 "$DYG" eval "$gt" est.txt --plot /tmp
  probe e_save_dir 1 30 "$DYG" eval "$gt" est.txt --save-aligned /tmp
  probe e_save_proc 1 30 "$DYG" eval "$gt" est.txt --save-aligned /proc/version
  probe e_extra_arg 2 30 "$DYG" eval "$gt" est.txt extra
  probe e_same_file 2 30 "$DYG" eval "$gt" "$gt"
  probe b_runs_zero 2 30 "$DYG" bench ds --runs 0 --out o_b
  probe b_runs_huge 2 30 "$DYG" bench ds --runs 99999999999 --out o_b
  probe b_configs_bad 2 30 "$DYG" bench ds --configs none,bogus --out o_b --runs 1
  probe b_configs_empty 2 30 "$DYG" bench ds --configs '' --out o_b --runs 1
  probe b_no_data 1 30 "$DYG" bench /nonexistent --out o_b --runs 1
  probe b_empty_dir 1 30 "$DYG" bench "$(mkdir -p empty_dir; echo empty_dir)" --out o_b --runs 1
  probe b_out_file 1 30 "$DYG" bench ds --out "$CFG" --runs 1
  probe b_report_only_none 1 30 "$DYG" bench ds --report-only --out o_b_none
  probe b_update_missing 1 30 "$DYG" bench ds --report-only --out o_b_none --update-benchmarks /nonexistent.md
  probe b_features_frame 2 30 "$DYG" bench ds --features-frame -5 --out o_b --runs 1
  probe m_res_nan 2 30 "$DYG" map ds --config "$CFG" --out o_m --resolution nan
  probe m_every_zero 2 30 "$DYG" map ds --config "$CFG" --out o_m --every 0
  probe m_traj_missing 1 30 "$DYG" map ds --config "$CFG" --out o_m --trajectory /nonexistent.txt
  probe m_traj_nan 1 60 "$DYG" map ds --config "$CFG" --out o_m_tn --trajectory est_nan.txt
  probe m_traj_q0 1 60 "$DYG" map ds --config "$CFG" --out o_m_tq --trajectory est_q0.txt
  probe m_save_every_neg 2 30 "$DYG" map ds --config "$CFG" --out o_m --save-every -1
  probe s_frames_zero 2 30 "$DYG" synth o_s --frames 0
  probe s_frames_neg 2 30 "$DYG" synth o_s --frames -3
  probe s_frames_huge 2 30 "$DYG" synth o_s --frames 99999999999
  probe s_objects_9 2 30 "$DYG" synth o_s --objects 9
  probe s_fps_zero 2 30 "$DYG" synth o_s --fps 0
  probe s_fps_nan 2 30 "$DYG" synth o_s --fps nan
  probe s_room_nan 2 30 "$DYG" synth o_s --room nan,5,3
  probe s_room_small 2 30 "$DYG" synth o_s --room 1,1,1
  probe s_room_two 2 30 "$DYG" synth o_s --room 6,5
  probe s_loop_bad 2 30 "$DYG" synth o_s --loop-path a,b
  probe s_loop_huge 2 30 "$DYG" synth o_s --loop-path 1e9,1e9
  probe s_speed_neg 2 30 "$DYG" synth o_s --speed -1 --loop-path 2,1.5
  probe s_super_9 2 30 "$DYG" synth o_s --supersampling 9
  probe s_maxdepth_neg 2 30 "$DYG" synth o_s --max-depth -1
  probe s_objfrom_neg 2 30 "$DYG" synth o_s --objects-from -1
  probe s_out_file 1 30 "$DYG" synth "$CFG" --frames 2
  probe s_out_devnull 1 30 "$DYG" synth /dev/null --frames 2
  probe s_out_dataset '0|1' 60 "$DYG" synth ds_synth_into --frames 2
  probe v_branch_1 2 30 "$DYG" vocab o_v.dygvoc --branching 1
  probe v_depth_9 2 30 "$DYG" vocab o_v.dygvoc --depth 9
  probe v_scenes_zero 2 30 "$DYG" vocab o_v.dygvoc --scenes 0
  probe v_out_nodir 1 30 "$DYG" vocab /nonexistent/dir/v.dygvoc --scenes 1 --frames-per-scene 1
  probe v_out_dir 1 30 "$DYG" vocab /tmp --scenes 1 --frames-per-scene 1
  mknod full_dev c 1 7 2>/dev/null  # a device of our own (never /dev/full: a bug once replaced it)
  probe v_out_devfull 1 120 "$DYG" vocab full_dev --scenes 1 --frames-per-scene 2 --depth 2 --quiet
  probe v_extra 2 30 "$DYG" vocab a.dygvoc b.dygvoc
  probe v_none 2 30 "$DYG" vocab
  probe c_player_nodata 2 30 "$DYG" component player --config "$CFG"
  probe c_player_bogus 1 30 "$DYG" component player --dataset /nonexistent --config "$CFG" --domain 196
  probe c_slam_badcfg 1 30 "$DYG" component slam --config /dev/null --domain 196
  probe c_rate_neg 2 30 "$DYG" component player --dataset ds --config "$CFG" --rate -1
  probe c_window_zero 2 30 "$DYG" component player --dataset ds --config "$CFG" --window 0
  probe c_wait_neg 2 30 "$DYG" component slam --config "$CFG" --detection-wait-ms -5
  probe c_domain_300 2 30 "$DYG" component slam --config "$CFG" --domain 300
  probe c_cfg_missing 1 30 "$DYG" component detector --config /nonexistent.yaml --domain 196
  probe c_det_cfg_missing 1 30 "$DYG" component detector --config "$CFG" --detector-cfg /nonexistent.cfg --domain 196
  probe c_det_model_bogus 1 30 "$DYG" component detector --config "$CFG" --detector-model bogus --domain 196
  probe c_iface_bad 2 30 "$DYG" component slam --config "$CFG" --dds-interface 999.1.1.1 --domain 196
  probe c_ds_bad 2 30 "$DYG" component slam --config "$CFG" --discovery-server nohost --domain 196
  probe c_loadmap_missing 1 30 "$DYG" component slam --config "$CFG" --load-map /nonexistent.map --domain 196
  probe c_localization_alone 2 30 "$DYG" run ds --config "$CFG" --out o_c_loc --localization
  probe c_out_proc 1 30 "$DYG" run ds --config "$CFG" --out /proc/self --direct
  probe c_out_sys 1 30 "$DYG" run ds --config "$CFG" --out /sys/kernel --direct
  probe c_config_dir_missing 1 30 "$DYG" run ds --config /nonexistent/x.yaml --out o_c_cm --direct
  probe c_dup_option '0|2' 30 "$DYG" run ds --config "$CFG" --config "$CFG" --out o_c_dup --direct
  probe c_dup_out 2 30 "$DYG" run ds --config "$CFG" --out o_a --out o_b --direct
  probe c_equals_form '0|2' 120 "$DYG" run ds --config="$CFG" --out=o_c_eq --direct --quiet --filter none --frames 0:4
  probe c_missing_value 2 30 "$DYG" run ds --config
  probe c_two_datasets 2 30 "$DYG" run ds ds40 --config "$CFG"
  probe c_no_dataset 2 30 "$DYG" run --config "$CFG"
  probe c_quiet_help 0 30 "$DYG" run --help --quiet
fi

if family signals; then
  echo "== signals at every phase"
  # sprobe NAME SIG DELAY OUT CMD...: like signal_probe, plus: outputs cut short are HALF.
  sprobe() {
    local name=$1 sig=$2 delay=$3 out=$4; shift 4
    # A bench stopped before its first run ended has nothing to write: 128 + the signal.
    local want=0
    [ "$2" = bench ] && want="0|$((128 + $(kill -l "$sig")))"
    signal_probe "$name" "$sig" "$delay" "$want" "$out" "$@"
    local half; half=$(half_written "$out")
    [ -z "$half" ] || note "$name" HALF "$half"
  }
  for delay in 0.01 0.2 1.5 4; do
    sprobe "sg_direct_INT_$delay" INT "$delay" "o_sg_d_$delay" "$DYG" run ds40 --config "$CFG" --out "o_sg_d_$delay" --direct --quiet --filter none
    sprobe "sg_map_TERM_$delay" TERM "$delay" "o_sg_m_$delay" "$DYG" map ds40 --config "$CFG" --out "o_sg_m_$delay" --quiet --filter none
    sprobe "sg_dds_HUP_$delay" HUP "$delay" "o_sg_s_$delay" "$DYG" run ds40 --config "$CFG" --out "o_sg_s_$delay" --quiet --filter none --domain 195
    sprobe "sg_pipe_INT_$delay" INT "$delay" "o_sg_p_$delay" "$DYG" component pipeline --dataset ds40 --config "$CFG" --out "o_sg_p_$delay" --filter none --domain 196
  done
  for delay in 0.3 3; do
    sprobe "sg_bench_INT_$delay" INT "$delay" "o_sg_b_$delay" "$DYG" bench ds40 --runs 1 --configs none --no-baseline --no-pictures --out "o_sg_b_$delay" --quiet
    [ "$(ls o_sg_b_$delay 2>/dev/null | wc -l)" -eq 0 ] || [ -s "o_sg_b_$delay/report.md" ] ||
      [ ! -s "logs/sg_bench_INT_$delay.err" ] || echo "    (bench: $(ls o_sg_b_$delay | tr '\n' ' '))"
    # SIGTERM too: a background job ignores SIGINT unless the program installs its own handler.
    sprobe "sg_bench_TERM_$delay" TERM "$delay" "o_sg_bt_$delay" "$DYG" bench ds40 --runs 2 --configs none --no-baseline --no-pictures --out "o_sg_bt_$delay" --quiet
    # Killed before its handlers existed (no output folder, nothing on stderr: the verdict
    # `early`): no run had started, nothing to lose.
    [ -s "o_sg_bt_$delay/runs.csv" ] || grep -q "before any run ended" "logs/sg_bench_TERM_$delay.err" ||
      { [ ! -e "o_sg_bt_$delay" ] && [ ! -s "logs/sg_bench_TERM_$delay.err" ]; } ||
      note "sg_bench_TERM_$delay" LOSS "no runs.csv of the runs done"
    sprobe "sg_proc_TERM_$delay" TERM "$delay" "o_sg_pr_$delay" "$DYG" run ds40 --config "$CFG" --out "o_sg_pr_$delay" --quiet --processes --filter none --domain 196
  done
  # While writing the outputs: the signal just as the last frames end (a run of 40 frames is
  # timed first), and a second signal right after the first.
  start=$(date +%s.%N)
  "$DYG" run ds40 --config "$CFG" --out o_sg_time --direct --quiet --filter none >/dev/null 2>&1
  t=$(python3 -c "print(max(0.1, $(date +%s.%N) - $start - 0.15))")
  for k in 1 2 3; do
    d=$(python3 -c "print(round($t + ($k - 2) * 0.1, 2))")
    sprobe "sg_direct_end_$k" INT "$d" "o_sg_e_$k" "$DYG" run ds40 --config "$CFG" --out "o_sg_e_$k" --direct --quiet --filter none
  done
  rm -f logs/sg_double.hang
  "$DYG" run ds40 --config "$CFG" --out o_sg_double --direct --quiet --filter none >logs/sg_double.out 2>logs/sg_double.err &
  pid=$!; sleep 2; kill -INT $pid; sleep 0.05; kill -INT $pid; wait $pid; rc=$?
  verdict sg_double "$rc" '0|130'
  [ -z "$(half_written o_sg_double)" ] || note sg_double HALF "$(half_written o_sg_double)"
  # SIGKILL at random moments: whatever is there must be whole (atomic writes).
  for k in 1 2 3 4 5 6; do
    d=$(python3 -c "import random; print(round(random.uniform(0.5, $t + 0.5), 2))")
    "$DYG" run ds40 --config "$CFG" --out "o_sg_k_$k" --direct --quiet --filter none >/dev/null 2>&1 &
    pid=$!; sleep "$d"; kill -KILL $pid 2>/dev/null; wait $pid
    h=$(half_written "o_sg_k_$k")
    if [ -z "$h" ]; then printf '%-28s %-14s %s\n' "sg_kill_at_$d" ok "$(ls o_sg_k_$k 2>/dev/null | tr '\n' ' ')"
    else note "sg_kill_at_$d" HALF "$h"; fi
  done
fi

if family disk; then
  echo "== disk full, read-only and deleted --out"
  mkdir -p tiny ro gone
  # 64 KiB, 52 KiB of it taken: the outputs of a 40-frame run do not fit.
  mount -t tmpfs -o size=64k tmpfs tiny
  dd if=/dev/zero of=tiny/ballast bs=1k count=52 2>/dev/null
  probe d_full_direct 1 120 "$DYG" run ds40 --config "$CFG" --out tiny/o --direct --quiet --filter none
  grep -q "tiny/o" logs/d_full_direct.err || note d_full_direct NOWHERE "the full file not named"
  [ -z "$(half_written tiny/o)" ] || note d_full_direct HALF "$(half_written tiny/o)"
  ls tiny/o/*.tmp.* >/dev/null 2>&1 && note d_full_direct LEFTOVER "$(ls tiny/o)"
  rm -rf tiny/o
  probe d_full_map 1 120 "$DYG" map ds40 --config "$CFG" --out tiny/m --quiet --filter none
  [ -z "$(half_written tiny/m)" ] || note d_full_map HALF "$(half_written tiny/m)"
  rm -rf tiny/m
  probe d_full_dds 1 180 "$DYG" run ds40 --config "$CFG" --out tiny/s --quiet --filter none --domain 195
  [ -z "$(half_written tiny/s)" ] || note d_full_dds HALF "$(half_written tiny/s)"
  rm -rf tiny/s
  probe d_full_synth 1 120 "$DYG" synth tiny/y --frames 5 --quiet
  rm -rf tiny/y
  probe d_full_vocab '0|1' 120 "$DYG" vocab tiny/v.dygvoc --scenes 1 --frames-per-scene 2 --depth 2 --quiet
  awk 'NR<=30' ds/groundtruth.txt >est_d.txt
  probe d_full_eval '0|1' 30 "$DYG" eval ds/groundtruth.txt est_d.txt --save-aligned tiny/a.txt
  dd if=/dev/zero of=tiny/fill bs=1k count=64 2>/dev/null  # the rest
  probe d_full_at_start 1 60 "$DYG" run ds --config "$CFG" --out tiny/o2 --direct --quiet --filter none
  umount tiny
  # Read-only mid-run: a tmpfs remounted read-only while the run goes.
  mount -t tmpfs -o size=64m tmpfs ro
  for mode in direct dds map; do
    case $mode in
      direct) cmd=("$DYG" run ds40 --config "$CFG" --out ro/o_$mode --direct --quiet --filter none) ;;
      dds) cmd=("$DYG" run ds40 --config "$CFG" --out ro/o_$mode --quiet --filter none --domain 196) ;;
      map) cmd=("$DYG" map ds40 --config "$CFG" --out ro/o_$mode --quiet --filter none) ;;
    esac
    mount -o remount,rw ro
    "${cmd[@]}" >"logs/d_ro_$mode.out" 2>"logs/d_ro_$mode.err" &
    pid=$!; sleep 2; mount -o remount,ro ro
    wait $pid; rc=$?
    verdict "d_ro_$mode" "$rc" 1
    grep -q "ro/o_$mode" "logs/d_ro_$mode.err" || note "d_ro_$mode" NOWHERE "--out not named"
  done
  mount -o remount,rw ro; umount ro
  # --out deleted mid-run: the run writes its outputs (creating the folder again) or says why.
  for mode in direct dds map; do
    case $mode in
      direct) cmd=("$DYG" run ds40 --config "$CFG" --out gone/o_$mode --direct --quiet --filter none) ;;
      dds) cmd=("$DYG" run ds40 --config "$CFG" --out gone/o_$mode --quiet --filter none --domain 196) ;;
      map) cmd=("$DYG" map ds40 --config "$CFG" --out gone/o_$mode --quiet --filter none) ;;
    esac
    "${cmd[@]}" >"logs/d_gone_$mode.out" 2>"logs/d_gone_$mode.err" &
    pid=$!; sleep 2; rm -rf "gone/o_$mode"
    wait $pid; rc=$?
    verdict "d_gone_$mode" "$rc" '0|1'
    if [ "$rc" = 0 ] && [ ! -s "gone/o_$mode/trajectory.txt" ]; then
      note "d_gone_$mode" LOSS "exit 0 without a trajectory"
    fi
  done
fi

if family dds; then
  echo "== a second player on the run's partition"
  small ds_other 40
  "$DYG" run ds40 --config "$CFG" --out o_p_run --quiet --domain 194 --partition fresh_p --filter none \
    >logs/p_run.out 2>logs/p_run.err &
  runpid=$!
  sleep 1.5
  timeout -s KILL 90 "$DYG" component player --dataset ds_other --config "$CFG" --domain 194 \
    --partition fresh_p >logs/p_player.out 2>logs/p_player.err &
  playerpid=$!
  wait $runpid; rc=$?
  kill $playerpid 2>/dev/null; wait $playerpid 2>/dev/null
  verdict p_run "$rc" "0|1"
  n=$(grep -cv '^#' o_p_run/trajectory.txt 2>/dev/null || echo 0)
  [ "$n" -le 40 ] || note p_run FOREIGN "$n poses for 40 frames: a second player's frames tracked"
  grep -q "second frame source\|another frame source\|ignored" logs/p_run.err logs/p_run.out ||
    note p_run SILENT "a second player on the partition without a word"
fi

echo "== $FAILS probes not ok (logs in $WORK/logs)"
exit "$FAILS"
