#!/usr/bin/env bash
# Whole-tool benchmark: analyze_bag next to a bare rosbag::View read (bag_scan) of the same bags; prints wall time,
# CPU time, peak RSS and the ratios, measured side by side (alternating runs, best of R each). Two analyze_bag rows
# per bag: without the plot (--no-plot) and the default run, which draws allan.png and allan.svg in-process.
# Usage: bench/whole_tool.sh [--durations "600 3600 14400"] [--rate 400] [--repeat 3] [--dir DIR] [--no-plot-only]
#                            [-- analyze_bag options]
# Bags are generated once with the simulate tool into DIR (default /tmp/gyro_allan_bench) and reused.
# ANALYZE_BAG=PATH times that analyze_bag instead of the build's (e.g. an older build, for before/after).
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:$PATH
durations="600 3600 14400"
rate=400
repeat=3
dir=${GYRO_ALLAN_BENCH_DIR:-/tmp/gyro_allan_bench}
extra=()
plot_row=1
while [ $# -gt 0 ]; do
  case "$1" in
    --durations) durations=$2; shift 2 ;;
    --rate) rate=$2; shift 2 ;;
    --repeat) repeat=$2; shift 2 ;;
    --dir) dir=$2; shift 2 ;;
    --no-plot-only) plot_row=0; shift ;;
    --) shift; extra=("$@"); break ;;
    *) echo "whole_tool.sh: unknown option $1" >&2; exit 1 ;;
  esac
done
bin=${BUILD_DIR:-.build}/devel/lib/gyro_allan
for t in simulate bag_scan analyze_bag; do
  [ -x "$bin/$t" ] || { echo "whole_tool.sh: $bin/$t missing: run scripts/build.sh first" >&2; exit 1; }
done
analyze=${ANALYZE_BAG:-$bin/analyze_bag}
mkdir -p "$dir"

# One timed run: prints "wall_s user_s sys_s max_rss_kB".
timed() {
  local f="$dir/.time"
  /usr/bin/time -o "$f" -f "%e %U %S %M" "$@" >/dev/null 2>&1 || { echo "whole_tool.sh: failed: $*" >&2; exit 1; }
  cat "$f"
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "analyze_bag: $analyze, options: --quiet ${extra[*]:-} (no plot: --no-plot; with plot: GYRO_ALLAN_NO_PLOT unset)"
printf '%-9s %9s | %-22s | %-11s %-22s | %7s %7s | %8s\n' "bag" "messages" "bare read: wall cpu RSS" "analyze_bag" \
  "wall cpu RSS" "wall x" "cpu x" "RSS +MB"
# best of the runs by wall time (the least disturbed by other load); RSS is the same every run
better() { [ -z "$2" ] || awk -v x="${1%% *}" -v y="${2%% *}" 'BEGIN{exit !(x<y)}'; }
for d in $durations; do
  bag="$dir/sim_${rate}hz_${d}s.bag"
  if [ ! -s "$bag" ]; then
    "$bin/simulate" --output "$bag" --rate "$rate" --duration "$d" --seed 11 --arw 2e-4 --bias-instability 2e-5 \
      --rrw 1e-6 --quantization 1e-6 --compression lz4 >/dev/null
  fi
  msgs=$((d * rate))
  best_b=""; best_a=""; best_p=""
  for ((r = 0; r < repeat; ++r)); do
    b=$(timed "$bin/bag_scan" "$bag")
    a=$(timed "$analyze" "$bag" --output "$dir/out_$d" --no-plot --quiet "${extra[@]}")
    better "$b" "$best_b" && best_b=$b
    better "$a" "$best_a" && best_a=$a
    if [ "$plot_row" = 1 ]; then
      p=$(timed env -u GYRO_ALLAN_NO_PLOT "$analyze" "$bag" --output "$dir/out_${d}_plot" --quiet "${extra[@]}")
      [ -s "$dir/out_${d}_plot/allan.png" ] || { echo "whole_tool.sh: no allan.png from the run with the plot" >&2; exit 1; }
      better "$p" "$best_p" && best_p=$p
    fi
  done
  read -r bw bu bs bm <<<"$best_b"
  first=1
  for row in "no plot:$best_a" "with plot:$best_p"; do
    [ -n "${row#*:}" ] || continue
    read -r aw au as am <<<"${row#*:}"
    label="$d s"; cnt=$msgs; bare=$(printf '%5.2f s %5.2f s %5.0f MB' "$bw" "$(awk -v u="$bu" -v s="$bs" 'BEGIN{print u+s}')" \
      "$(awk -v m="$bm" 'BEGIN{print m/1024}')")
    if [ "$first" = 0 ]; then label=""; cnt=""; bare=""; fi
    first=0
    awk -v d="$label" -v n="$cnt" -v bare="$bare" -v what="${row%%:*}" -v bw="$bw" -v bu="$bu" -v bs="$bs" -v bm="$bm" \
      -v aw="$aw" -v au="$au" -v as="$as" -v am="$am" \
      'BEGIN{printf "%-9s %9s | %-22s | %-11s %5.2f s %5.2f s %5.0f MB | %7.2f %7.2f | %8.1f\n",
        d, n, bare, what, aw, au+as, am/1024, aw/bw, (au+as)/(bu+bs), (am-bm)/1024}'
  done
done
echo "RSS = peak resident set (MiB); wall x / cpu x = analyze_bag / bare read; RSS +MB = analyze_bag's peak - the bare read's"
