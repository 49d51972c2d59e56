#!/usr/bin/env bash
# Whole-tool benchmark: analyze_bag next to a bare rosbag::View read (bag_scan) of the same bags; prints wall time,
# CPU time, peak RSS and the ratios, measured side by side (alternating runs, best of R each).
# Usage: bench/whole_tool.sh [--durations "600 3600 14400"] [--rate 400] [--repeat 3] [--dir DIR] [-- analyze_bag options]
# Bags are generated once with the simulate tool into DIR (default /tmp/gyro_allan_bench) and reused.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:$PATH
durations="600 3600 14400"
rate=400
repeat=3
dir=${GYRO_ALLAN_BENCH_DIR:-/tmp/gyro_allan_bench}
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --durations) durations=$2; shift 2 ;;
    --rate) rate=$2; shift 2 ;;
    --repeat) repeat=$2; shift 2 ;;
    --dir) dir=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) echo "whole_tool.sh: unknown option $1" >&2; exit 1 ;;
  esac
done
bin=${BUILD_DIR:-.build}/devel/lib/gyro_allan
for t in simulate bag_scan analyze_bag; do
  [ -x "$bin/$t" ] || { echo "whole_tool.sh: $bin/$t missing: run scripts/build.sh first" >&2; exit 1; }
done
mkdir -p "$dir"

# One timed run: prints "wall_s user_s sys_s max_rss_kB".
timed() {
  local f="$dir/.time"
  /usr/bin/time -o "$f" -f "%e %U %S %M" "$@" >/dev/null 2>&1 || { echo "whole_tool.sh: failed: $*" >&2; exit 1; }
  cat "$f"
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "analyze_bag options: --no-plot --quiet ${extra[*]:-}"
printf '%-9s %9s | %-22s | %-22s | %7s %7s | %8s\n' "bag" "messages" "bare read: wall cpu RSS" "analyze_bag: wall cpu RSS" \
  "wall x" "cpu x" "RSS +MB"
for d in $durations; do
  bag="$dir/sim_${rate}hz_${d}s.bag"
  if [ ! -s "$bag" ]; then
    "$bin/simulate" --output "$bag" --rate "$rate" --duration "$d" --seed 11 --arw 2e-4 --bias-instability 2e-5 \
      --rrw 1e-6 --quantization 1e-6 --compression lz4 >/dev/null
  fi
  msgs=$((d * rate))
  best_b=""; best_a=""
  for ((r = 0; r < repeat; ++r)); do
    b=$(timed "$bin/bag_scan" "$bag")
    a=$(timed "$bin/analyze_bag" "$bag" --output "$dir/out_$d" --no-plot --quiet "${extra[@]}")
    # best of the runs by wall time (the least disturbed by other load); RSS is the same every run
    if [ -z "$best_b" ] || awk -v x="${b%% *}" -v y="${best_b%% *}" 'BEGIN{exit !(x<y)}'; then best_b=$b; fi
    if [ -z "$best_a" ] || awk -v x="${a%% *}" -v y="${best_a%% *}" 'BEGIN{exit !(x<y)}'; then best_a=$a; fi
  done
  read -r bw bu bs bm <<<"$best_b"
  read -r aw au as am <<<"$best_a"
  awk -v d="$d" -v n="$msgs" -v bw="$bw" -v bu="$bu" -v bs="$bs" -v bm="$bm" -v aw="$aw" -v au="$au" -v as="$as" -v am="$am" \
    'BEGIN{printf "%-9s %9d | %5.2f s %5.2f s %5.0f MB | %5.2f s %5.2f s %5.0f MB | %7.2f %7.2f | %8.1f\n",
      d " s", n, bw, bu+bs, bm/1024, aw, au+as, am/1024, aw/bw, (au+as)/(bu+bs), (am-bm)/1024}'
done
echo "RSS = peak resident set (MiB); wall x / cpu x = analyze_bag / bare read; gyro samples as doubles = 24 B x messages"
