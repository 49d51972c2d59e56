#!/usr/bin/env bash
# ROS 2 bags against ROS 1: analyze_bag's whole run (--no-plot) on the same simulated samples stored as a ROS 1 bag
# (lz4 chunks), an MCAP (zstd chunks, indexed: rosbag2's default) and a rosbag2 sqlite3 .db3; wall time, CPU time,
# peak RSS and the ratios to the ROS 1 run, measured side by side (alternating runs, best of R each).
# Usage: bench/ros2_read.sh [--duration S (3600)] [--rate HZ (400)] [--repeat R (3)] [--dir DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:$PATH
duration=3600
rate=400
repeat=3
dir=${GYRO_ALLAN_BENCH_DIR:-/tmp/gyro_allan_bench}
while [ $# -gt 0 ]; do
  case "$1" in
    --duration) duration=$2; shift 2 ;;
    --rate) rate=$2; shift 2 ;;
    --repeat) repeat=$2; shift 2 ;;
    --dir) dir=$2; shift 2 ;;
    *) echo "ros2_read.sh: unknown option $1" >&2; exit 1 ;;
  esac
done
bin=${BUILD_DIR:-.build}/devel/lib/gyro_allan
for t in simulate analyze_bag; do
  [ -x "$bin/$t" ] || { echo "ros2_read.sh: $bin/$t missing: run scripts/build.sh first" >&2; exit 1; }
done
mkdir -p "$dir"
sim=(--rate "$rate" --duration "$duration" --seed 11 --arw 2e-4 --bias-instability 2e-5 --rrw 1e-6 --quantization 1e-6)
base="$dir/ros2_${rate}hz_${duration}s"
[ -s "$base.bag" ] || "$bin/simulate" --output "$base.bag" "${sim[@]}" --compression lz4 >/dev/null
[ -s "$base.mcap" ] || "$bin/simulate" --output "$base.mcap" "${sim[@]}" >/dev/null
[ -s "$base.db3" ] || "$bin/simulate" --output "$base.db3" "${sim[@]}" >/dev/null

timed() {  # prints "wall_s user_s sys_s max_rss_kB"
  local f="$dir/.time"
  /usr/bin/time -o "$f" -f "%e %U %S %M" "$@" >/dev/null 2>&1 || { echo "ros2_read.sh: failed: $*" >&2; exit 1; }
  cat "$f"
}
better() { [ -z "$2" ] || awk -v x="${1%% *}" -v y="${2%% *}" 'BEGIN{exit !(x<y)}'; }
declare -A best
for ((r = 0; r < repeat; ++r)); do
  for ext in bag mcap db3; do
    t=$(timed "$bin/analyze_bag" "$base.$ext" --output "$dir/out_ros2_$ext" --no-plot --quiet)
    better "$t" "${best[$ext]:-}" && best[$ext]=$t
  done
done
for ext in bag mcap db3; do  # the same coefficients from each storage
  cmp -s <(grep -A3 "angle_random_walk:" "$dir/out_ros2_bag/report.yaml") \
         <(grep -A3 "angle_random_walk:" "$dir/out_ros2_$ext/report.yaml") \
    || { echo "ros2_read.sh: $ext gives another answer than the ROS 1 bag" >&2; exit 1; }
done
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "$((duration * rate)) messages at $rate Hz; analyze_bag --no-plot --quiet; best of $repeat by wall time"
printf '%-6s %10s | %8s %8s %8s | %7s %7s %7s\n' storage "file MB" "wall s" "cpu s" "RSS MB" "wall x" "cpu x" "RSS x"
read -r w0 u0 s0 m0 <<<"${best[bag]}"
for ext in bag mcap db3; do
  read -r w u s m <<<"${best[$ext]}"
  awk -v e="$ext" -v sz="$(stat -c %s "$base.$ext")" -v w="$w" -v c="$(awk -v u="$u" -v s="$s" 'BEGIN{print u+s}')" \
      -v m="$m" -v w0="$w0" -v c0="$(awk -v u="$u0" -v s="$s0" 'BEGIN{print u+s}')" -v m0="$m0" \
      'BEGIN{printf "%-6s %10.1f | %8.2f %8.2f %8.0f | %7.2f %7.2f %7.2f\n", e, sz/1048576, w, c, m/1024, w/w0, c/c0, m/m0}'
done
echo "x = this storage's run / the ROS 1 bag's run"
