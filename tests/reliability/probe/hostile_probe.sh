#!/bin/bash
# Hostile-input check of the bad-input families (bad settings, images and lists, signals at random
# moments, DDS foreign writers, bad command-line values): ~65 probes against a built `dygslam`.
#
#   tests/reliability/probe/hostile_probe.sh [BUILD_DIR] [WORK_DIR]
#
# Runs itself inside a private network namespace (DDS stays on this machine; domains 201-204).
# Each probe prints one line: NAME rc=N VERDICT [detail]. Verdicts:
#   ok          the exit code is one the contract allows for this input, no "internal error"
#   CRASH       killed by a signal it did not ask for (SIGSEGV, SIGABRT, ...)
#   HANG        still running after the probe's deadline (killed)
#   INTERNAL    the message says "internal error" (bad input must be named, not crash through)
#   LOSS        a run stopped or failed mid-way left no trajectory of the frames it processed
#   UNEXPECTED  another exit code than the contract's (see the probe's "want")
#   SILENT      a wrong configuration or input accepted without a word
# Logs: WORK_DIR/logs/NAME.{out,err}. Exit code: the number of probes that are not ok.
# PROBE_ONLY=settings runs the settings-file probes only.
set -u
BUILD_DIR=$(realpath "${1:-build}")
WORK=$(realpath -m "${2:-/tmp/dygslam_probe_$$}")
if [ -z "${DYGSLAM_PROBE_IN_NETNS:-}" ]; then
  exec unshare -n bash -c "ip link set lo up; ip link set lo multicast on; \
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
export DYGSLAM_DOMAIN_ID=201
FAILS=0

# shellcheck source=probe_lib.sh
. "$SRC/tests/reliability/probe/probe_lib.sh"

small ds 20
small ds40 40
yaml() { cp "$CFG" "y_$1.yaml"; printf '%b' "$2" >>"y_$1.yaml"; echo "y_$1.yaml"; }
# probe_cfg NAME WANT FILE: `run --direct` of 8 frames with settings FILE.
probe_cfg() {
  probe "$1" "$2" 60 "$DYG" run ds --config "$3" --out "o_$1" --direct --quiet --filter none --frames 0:8
}

echo "== settings files"
probe_cfg y_alias_self 1 "$(yaml alias_self 'Tracking: &t {init_min_features: 300, self: *t}\n')"
probe_cfg y_alias_list 1 "$(yaml alias_list 'a: &a [*a]\n')"
deep=$(python3 -c "print('Deep: ' + '['*5000 + ']'*5000)")
probe_cfg y_deep_flow 1 "$(yaml deep_flow "$deep\n")"
deep2=$(python3 -c "print(''.join('  '*i + 'k%d:\\\\n' % i for i in range(60)) + '  '*60 + 'v: 1')")
probe_cfg y_deep_block 1 "$(yaml deep_block "$deep2\n")"
laughs=$(python3 -c "
s='l0: &l0 [x,x,x,x,x,x,x,x,x,x]\\\\n'
for i in range(1,9): s+='l%d: &l%d [' % (i,i) + ','.join(['*l%d' % (i-1)]*10) + ']\\\\n'
print(s)")
probe_cfg y_laughs 1 "$(yaml laughs "$laughs")"
probe_cfg y_section_list 1 "$(yaml section_list 'DynamicFilter: [1, 2]\n')"
probe_cfg y_section_scalar 1 "$(yaml section_scalar 'Detector: 5\n')"
probe_cfg y_typo_warn 0 "$(yaml typo_warn 'DynamicFilter:\n  treshold: 0.5\n')"
grep -q "did you mean 'DynamicFilter.threshold'" logs/y_typo_warn.err || { echo "  y_typo_warn: SILENT (no warning)"; FAILS=$((FAILS+1)); }
probe_cfg y_mistyped_map 1 "$(yaml mistyped_map 'Detector:\n  dynamic_classes: {a: 1}\n')"
grep -q "unknown key" logs/y_mistyped_map.err && { echo "  y_mistyped_map: spurious unknown-key warning"; FAILS=$((FAILS+1)); }
probe_cfg y_fx_huge 1 "$(sed 's/^Camera.fx:.*/Camera.fx: 1e308/' "$CFG" >y_fx.yaml; echo y_fx.yaml)"
probe_cfg y_fx_nan 1 "$(sed 's/^Camera.fx:.*/Camera.fx: .nan/' "$CFG" >y_fxn.yaml; echo y_fxn.yaml)"
probe_cfg y_nfeat_zero 1 "$(sed 's/^ORBextractor.nFeatures:.*/ORBextractor.nFeatures: 0/' "$CFG" >y_nf.yaml; echo y_nf.yaml)"
grep -q "requires\|&&" logs/y_nfeat_zero.err && { echo "  y_nfeat_zero: C++ check text shown"; FAILS=$((FAILS+1)); }
probe_cfg y_width_string 1 "$(sed 's/^Camera.width:.*/Camera.width: wide/' "$CFG" >y_w.yaml; echo y_w.yaml)"
probe_cfg y_dup_key 1 "$(yaml dup_key 'Camera.fx: 500\n')"
probe_cfg y_null_key 1 "$(yaml null_key '~: 1\n')"
probe_cfg y_complex_key 1 "$(yaml complex_key '? [a, b]\n: 1\n')"
probe_cfg y_long_value 1 "$(yaml long_value "Detector:\n  model: $(head -c 200000 /dev/zero | tr '\0' m)\n")"
[ "$(wc -c <logs/y_long_value.err)" -lt 4000 ] || { echo "  y_long_value: message not bounded"; FAILS=$((FAILS+1)); }
probe_cfg y_nul_bytes '0|1' "$(yaml nul_bytes 'Camera.k9: a\0b\n')"
probe_cfg y_every_zero 1 "$(yaml every_zero 'Detector:\n  every_n_frames: 0\n')"
probe_cfg y_dev_zero 1 /dev/zero
probe_cfg y_folder 1 /tmp
probe_cfg y_empty 1 /dev/null
printf '\xef\xbb\xbf' >y_bom_only.yaml
probe_cfg y_bom_only 1 y_bom_only.yaml
rm -f fifo_nowriter; mkfifo fifo_nowriter
signal_probe y_fifo_int INT 2 130 "" "$DYG" run ds --config fifo_nowriter --out o_fifo_int --direct --quiet
rm -f fifo_stall; mkfifo fifo_stall
(exec 3>fifo_stall; head -c 500 "$CFG" >&3; sleep 20) &
staller=$!
signal_probe y_fifo_stall_term TERM 2 143 "" "$DYG" run ds --config fifo_stall --out o_fifo_stall --direct --quiet
kill $staller 2>/dev/null; wait $staller 2>/dev/null

if [ "${PROBE_ONLY:-}" = settings ]; then echo "== $FAILS probes not ok"; exit "$FAILS"; fi
echo "== images and lists"
mkbad() {  # mkbad NAME: ds_NAME with entry 10's rgb image replaced by ./bad.png (made by caller)
  small "ds_$1" 20
  local line; line=$(sed -n 11p "ds_$1/rgb.txt")
  sed -i "11s#.*#${line%% *} bad.png#" "ds_$1/rgb.txt"
}
first_png=ds/$(awk 'NR==11{print $2}' ds/rgb.txt)
mkbad trunc; head -c 20000 "$first_png" >ds_trunc/bad.png
probe i_trunc_direct 1 120 "$DYG" run ds_trunc --config "$CFG" --out o_i_trunc --direct --quiet --filter none
[ -s o_i_trunc/trajectory.txt ] || { echo "  i_trunc_direct: LOSS (no trajectory)"; FAILS=$((FAILS+1)); }
probe i_trunc_map 1 120 "$DYG" map ds_trunc --config "$CFG" --out o_m_trunc --quiet --filter none
[ -s o_m_trunc/map.bt ] && [ -s o_m_trunc/trajectory.txt ] || { echo "  i_trunc_map: LOSS"; FAILS=$((FAILS+1)); }
probe i_trunc_dds 1 180 "$DYG" run ds_trunc --config "$CFG" --out o_d_trunc --quiet --filter none --domain 202
[ -s o_d_trunc/trajectory.txt ] || { echo "  i_trunc_dds: LOSS"; FAILS=$((FAILS+1)); }
mkbad huge; python3 - <<'EOF'
import struct, zlib
def chunk(t, d): return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
png = b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', 65535, 65535, 8, 2, 0, 0, 0)) + chunk(b'IEND', b'')
open('ds_huge/bad.png', 'wb').write(png)
EOF
probe i_huge_header 1 60 "$DYG" run ds_huge --config "$CFG" --out o_i_huge --direct --quiet --filter none
mkbad fifo; mkfifo ds_fifo/bad.png
probe i_fifo 1 60 "$DYG" run ds_fifo --config "$CFG" --out o_i_fifo --direct --quiet --filter none
mkbad zero; ln -s /dev/zero ds_zero/bad.png
probe i_devzero 1 60 "$DYG" run ds_zero --config "$CFG" --out o_i_zero --direct --quiet --filter none
mkbad dir; mkdir ds_dir/bad.png
probe i_dir 1 60 "$DYG" run ds_dir --config "$CFG" --out o_i_dir --direct --quiet --filter none
mkbad text; echo "not an image" >ds_text/bad.png
probe i_text 1 60 "$DYG" run ds_text --config "$CFG" --out o_i_text --direct --quiet --filter none
small ds_garbage 20; head -c 3000 /dev/urandom >ds_garbage/rgb.txt
probe l_garbage 1 60 "$DYG" run ds_garbage --config "$CFG" --out o_l_garbage --direct --quiet
small ds_long 20; python3 -c "print('1548339823.9 ' + 'a'*5000000)" >>ds_long/rgb.txt
probe l_long_line 1 60 "$DYG" run ds_long --config "$CFG" --out o_l_long --direct --quiet
[ "$(wc -c <logs/l_long_line.err)" -lt 4000 ] || { echo "  l_long_line: message not bounded"; FAILS=$((FAILS+1)); }
small ds_unsorted 20; (sed -n 5p ds_unsorted/rgb.txt; cat ds_unsorted/rgb.txt) >u && mv u ds_unsorted/rgb.txt
probe l_unsorted 1 60 "$DYG" run ds_unsorted --config "$CFG" --out o_l_uns --direct --quiet
small ds_gtzero 20; rm ds_gtzero/groundtruth.txt; ln -s /dev/zero ds_gtzero/groundtruth.txt
probe l_gt_devzero 0 120 "$DYG" run ds_gtzero --config "$CFG" --out o_l_gtzero --direct --quiet --filter none
grep -q "not a regular file" logs/l_gt_devzero.err || { echo "  l_gt_devzero: SILENT"; FAILS=$((FAILS+1)); }
small ds_gtbad 20; echo "1 2 3" >>ds_gtbad/groundtruth.txt
probe l_gt_malformed 0 120 "$DYG" run ds_gtbad --config "$CFG" --out o_l_gtbad --direct --quiet --filter none
echo "1.0 10 10 50 50 0 0.9" >det_nomatch.txt
probe l_det_nomatch 0 120 "$DYG" run ds --config "$CFG" --out o_l_det --quiet --filter boxes --detections det_nomatch.txt
grep -q "match no frame" logs/l_det_nomatch.err || { echo "  l_det_nomatch: SILENT"; FAILS=$((FAILS+1)); }
echo "$(awk 'NR==1{print $1}' ds/rgb.txt) 10 10 50 50 1e300 0.9" >det_cls.txt
probe l_det_class 1 60 "$DYG" run ds --config "$CFG" --out o_l_detc --quiet --filter boxes --detections det_cls.txt

echo "== OctoMap and map files"
"$DYG" map ds --config "$CFG" --out o_base --quiet --filter none --frames 0:10 >/dev/null 2>&1
if [ -s o_base/map.ot ]; then
  head -c $(( $(stat -c %s o_base/map.ot) / 2 )) o_base/map.ot >trunc.ot
  probe o_trunc_ot 1 60 "$DYG" run ds --config "$CFG" --out o_o_trunc --direct --quiet --filter none --load-octomap trunc.ot
  printf '# Octomap\0OcTree\n' >nul.ot
  probe o_nul_header 1 60 "$DYG" run ds --config "$CFG" --out o_o_nul --direct --quiet --filter none --load-octomap nul.ot
  grep -q 'x00' logs/o_nul_header.err || { echo "  o_nul_header: NUL not escaped"; FAILS=$((FAILS+1)); }
  probe o_bt_as_ot 0 120 "$DYG" run ds --config "$CFG" --out o_o_bt --direct --quiet --filter none --load-octomap o_base/map.bt
fi
head -c 5000 /dev/urandom >rand.map
probe o_random_map 1 60 "$DYG" run ds --config "$CFG" --out o_o_rand --direct --quiet --load-map rand.map
probe o_map_dir 1 60 "$DYG" run ds --config "$CFG" --out o_o_mdir --direct --quiet --load-map /tmp

echo "== command line values"
probe c_frames_beyond 0 120 "$DYG" run ds --config "$CFG" --out o_c_fb --direct --quiet --filter none --frames 0:5000
grep -q "warning: --frames" logs/c_frames_beyond.err || { echo "  c_frames_beyond: SILENT"; FAILS=$((FAILS+1)); }
probe c_frames_rev 2 30 "$DYG" run ds --config "$CFG" --out o_c --frames 9:3
probe c_frames_neg 2 30 "$DYG" run ds --config "$CFG" --out o_c --frames -1:3
probe c_frames_huge 2 30 "$DYG" run ds --config "$CFG" --out o_c --frames 0:99999999999999999999
probe c_domain_neg 2 30 "$DYG" run ds --config "$CFG" --out o_c --domain -7
probe c_domain_big 2 30 "$DYG" run ds --config "$CFG" --out o_c --domain 233
probe c_domain_long 2 30 "$DYG" run ds --config "$CFG" --out o_c --domain "$(head -c 100000 /dev/zero | tr '\0' 9)"
[ "$(wc -c <logs/c_domain_long.err)" -lt 4000 ] || { echo "  c_domain_long: echo not bounded"; FAILS=$((FAILS+1)); }
probe c_listen_long 2 30 "$DYG" discovery-server --listen "$(head -c 100000 /dev/zero | tr '\0' 1)"
[ "$(wc -c <logs/c_listen_long.err)" -lt 4000 ] || { echo "  c_listen_long: echo not bounded"; FAILS=$((FAILS+1)); }
probe c_partition_wild 2 30 "$DYG" run ds --config "$CFG" --out o_c --partition 'a*'
probe c_filter_bad 2 30 "$DYG" run ds --config "$CFG" --out o_c --filter bogus
probe c_out_file 1 30 "$DYG" run ds --config "$CFG" --out "$CFG"
probe c_out_dataset 1 30 "$DYG" run ds --config "$CFG" --out ds
probe c_out_devnull 1 30 "$DYG" run ds --config "$CFG" --out /dev/null
probe c_out_empty 1 30 "$DYG" run ds --config "$CFG" --out ''
probe c_proc_direct 2 30 "$DYG" run ds --config "$CFG" --processes --direct
probe c_loop_nan 2 30 "$DYG" run ds --config "$CFG" --out o_c --loop-minutes nan
probe c_eval_dir 1 30 "$DYG" eval /tmp /tmp
probe c_eval_devzero 1 30 "$DYG" eval /dev/zero ds/groundtruth.txt
probe c_bench_runs 2 30 "$DYG" bench --runs -3
probe c_unknown 2 30 "$DYG" frobnicate
probe c_version_extra 2 30 "$DYG" version now
probe c_component_bogus 2 30 "$DYG" component bogus
probe c_map_every 2 30 "$DYG" map ds --config "$CFG" --out o_c --every 3
probe c_map_res 2 30 "$DYG" map ds --config "$CFG" --out o_c --resolution 1e-9
probe c_save_map_dir 1 30 "$DYG" run ds --config "$CFG" --out o_c --direct --save-map /tmp

echo "== signals at random moments"
for mode in direct map dds processes; do
  for sig in INT TERM HUP; do
    delay=$(python3 -c "import random; print(round(random.uniform(0.05, 4.0), 2))")
    case $mode in
      direct) cmd=("$DYG" run ds40 --config "$CFG" --out "o_s_${mode}_$sig" --direct --quiet --filter none) ;;
      map) cmd=("$DYG" map ds40 --config "$CFG" --out "o_s_${mode}_$sig" --quiet --filter none) ;;
      dds) cmd=("$DYG" run ds40 --config "$CFG" --out "o_s_${mode}_$sig" --quiet --domain 203) ;;
      processes) cmd=("$DYG" run ds40 --config "$CFG" --out "o_s_${mode}_$sig" --quiet --processes --domain 204) ;;
    esac
    signal_probe "s_${mode}_${sig}_at_${delay}" "$sig" "$delay" "0" "o_s_${mode}_$sig" "${cmd[@]}"
  done
done

echo "== DDS foreign writer"
small ds_other 40
"$DYG" run ds40 --config "$CFG" --out o_f_run --quiet --domain 201 --partition probe_p \
  >logs/f_run.out 2>logs/f_run.err &
runpid=$!
sleep 1
timeout -s KILL 60 "$DYG" component player --dataset ds_other --config "$CFG" --domain 201 \
  --partition probe_p >logs/f_player.out 2>logs/f_player.err &
playerpid=$!
wait $runpid; rc=$?
kill $playerpid 2>/dev/null; wait $playerpid 2>/dev/null
verdict f_run "$rc" "0|1"
n=$(grep -cv '^#' o_f_run/trajectory.txt 2>/dev/null || echo 0)
[ "$n" -le 40 ] || { echo "  f_run: $n poses for 40 frames: foreign frames tracked"; FAILS=$((FAILS+1)); }

echo "== $FAILS probes not ok (logs in $WORK/logs)"
exit "$FAILS"
