#!/usr/bin/env bash
# Nodelet CPU benchmark: AnalyzerNodelet (default parameters: window 1 h, hop 300 s, quick answers every 5 s) fed a
# simulated 3-axis IMU at --speed x real time; prints the analyzer's CPU time (user + sys, /proc) per stretch of input
# and as a fraction of one core at real time (CPU seconds / input seconds), and its mean once the window is full
# (steady state: a full analysis of the whole window every hop). Set-ups:
#   default: the analyzer standalone (its own process), the samples from `rosbag play` (TCP, serialized);
#   --in-process: the analyzer and gyro_allan/BagPlayerNodelet in one nodelet manager, as beside a driver's nodelet
#   (samples by pointer); the player thread's own CPU (bag reading) is left out;
#   --bare: instead of the analyzer, bare_imu_subscriber (bench/bare_imu_subscriber.cpp), which subscribes as the
#   analyzer does and only counts: the floor any process pays to receive the topic (_batch_ms:=0 after --: ros::spin).
# Usage: bench/nodelet_cpu.sh [--rate 1000] [--minutes 70] [--speed 10] [--in-process | --bare] [--dir DIR]
#        [-- _param:=value ...]
#   (after --: private parameters of the analyzer, or of bare_imu_subscriber, e.g. _update_s:=0)
# GYRO_ALLAN_BENCH_LINE_S: seconds of input per printed line (default 300).
# Needs a build (scripts/build.sh). The bag is generated once into DIR (default /tmp/gyro_allan_bench) and reused.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:$PATH
rate=1000
minutes=70
speed=10
dir=${GYRO_ALLAN_BENCH_DIR:-/tmp/gyro_allan_bench}
params=()
in_process=0
bare=0
while [ $# -gt 0 ]; do
  case "$1" in
    --rate) rate=$2; shift 2 ;;
    --minutes) minutes=$2; shift 2 ;;
    --speed) speed=$2; shift 2 ;;
    --dir) dir=$2; shift 2 ;;
    --in-process) in_process=1; shift ;;
    --bare) bare=1; shift ;;
    --) shift; params=("$@"); break ;;
    *) echo "nodelet_cpu.sh: unknown option $1" >&2; exit 1 ;;
  esac
done
bin=.build/devel/lib/gyro_allan
[ -x "$bin/simulate" ] || { echo "nodelet_cpu.sh: $bin/simulate missing: run scripts/build.sh first" >&2; exit 1; }
mkdir -p "$dir"
duration=$((minutes * 60))
bag="$dir/sim_${rate}hz_${duration}s.bag"
if [ ! -s "$bag" ]; then
  "$bin/simulate" --output "$bag" --rate "$rate" --duration "$duration" --seed 12 --arw 2e-4 --bias-instability 2e-5 \
    --rrw 1e-6 --quantization 1e-6 --compression lz4 >/dev/null
fi
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://localhost:$port ROS_HOSTNAME=localhost
ROS_HOME=$(mktemp -d)
export ROS_HOME ROS_LOG_DIR=$ROS_HOME/log
set +u
source .build/devel/setup.bash
set -u
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  [ -z "${GYRO_ALLAN_BENCH_KEEP_LOGS:-}" ] && rm -rf "$ROS_HOME" || echo "logs: $ROS_HOME"
}
trap cleanup EXIT
roscore -p "$port" >"$ROS_HOME/roscore.log" 2>&1 &
pids+=($!)
for _ in $(seq 100); do rosparam list >/dev/null 2>&1 && break; sleep 0.2; done
if [ "$in_process" = 1 ]; then
  rosrun nodelet nodelet manager __name:=manager >"$ROS_HOME/manager.log" 2>&1 &
  pids+=($!)
  sleep 2
  rosrun nodelet nodelet load gyro_allan/AnalyzerNodelet manager __name:=analyzer --no-bond "${params[@]}" \
    >"$ROS_HOME/nodelet.log" 2>&1 &
  pids+=($!)
  sleep 3
  npid=$(pgrep -f "__name:=manager" | head -1)
elif [ "$bare" = 1 ]; then
  [ -x "$bin/bare_imu_subscriber" ] || { echo "nodelet_cpu.sh: $bin/bare_imu_subscriber missing: rebuild" >&2; exit 1; }
  "$bin/bare_imu_subscriber" __name:=analyzer "${params[@]}" >"$ROS_HOME/nodelet.log" 2>&1 &
  pids+=($!)
  sleep 3
  npid=$(pgrep -f "__name:=analyzer" | head -1)
else
  rosrun nodelet nodelet standalone gyro_allan/AnalyzerNodelet __name:=analyzer --no-bond "${params[@]}" \
    >"$ROS_HOME/nodelet.log" 2>&1 &
  pids+=($!)
  sleep 3
  npid=$(pgrep -f "__name:=analyzer" | head -1)
fi
[ -n "$npid" ] || { echo "nodelet_cpu.sh: the nodelet did not start" >&2; cat "$ROS_HOME"/*.log >&2; exit 1; }
tck=$(getconf CLK_TCK)
# The process's CPU, less the bag player thread's (in-process set-up)
cpu() {
  local player=0 f
  for f in /proc/"$npid"/task/*/stat; do
    if grep -q "(bag_player)" "$f" 2>/dev/null; then player=$(awk '{print $14 + $15}' "$f"); fi
  done
  awk -v t="$tck" -v p="$player" '{printf "%.2f", ($14 + $15 - p) / t}' "/proc/$npid/stat"
}
rss() { awk '/VmRSS/ {printf "%.0f", $2 / 1024}' "/proc/$npid/status"; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
if [ "$in_process" = 1 ]; then
  setup="analyzer in one nodelet manager with BagPlayerNodelet"
elif [ "$bare" = 1 ]; then
  setup="bare_imu_subscriber (receiving only), from rosbag play"
else
  setup="analyzer standalone, from rosbag play"
fi
echo "input: $bag ($rate Hz x 3 axes, $minutes min) at ${speed}x; $setup; default parameters ${params[*]:-}"
c0=$(cpu)
if [ "$in_process" = 1 ]; then
  rosrun nodelet nodelet load gyro_allan/BagPlayerNodelet manager __name:=player --no-bond _bag:="$bag" \
    _speed:="$speed" >"$ROS_HOME/player.log" 2>&1 &
else
  rosrun rosbag play -q -r "$speed" "$bag" >/dev/null 2>&1 &
fi
play=$!
pids+=($play)
start=$(date +%s.%N)
step=$(awk -v s="$speed" -v l="${GYRO_ALLAN_BENCH_LINE_S:-300}" 'BEGIN{printf "%.3f", l / s}')  # 5 min of input per line
printf '%-14s | %-12s | %-22s | %s\n' "input [min]" "CPU [s]" "core at real time [%]" "RSS [MB]"
prev=$c0; prev_t=0; steady_cpu=0; steady_s=0
played() { awk -v a="$start" -v b="$(date +%s.%N)" -v s="$speed" -v m="$minutes" 'BEGIN{exit !((b - a) * s / 60 > m + 0.5)}'; }
while kill -0 "$play" 2>/dev/null && ! played; do
  sleep "$step"
  now=$(date +%s.%N)
  t=$(awk -v a="$start" -v b="$now" -v s="$speed" 'BEGIN{printf "%.1f", (b - a) * s / 60}')
  c=$(cpu)
  d=$(awk -v a="$prev" -v b="$c" 'BEGIN{printf "%.2f", b - a}')
  span=$(awk -v a="$prev_t" -v b="$t" 'BEGIN{printf "%.1f", (b - a) * 60}')
  share=$(awk -v d="$d" -v s="$span" 'BEGIN{printf "%.2f", (s > 0 ? 100 * d / s : 0)}')
  printf '%5.1f - %5.1f  | %12s | %22s | %s\n' "$prev_t" "$t" "$d" "$share" "$(rss)"
  # window full (steady state: a full analysis of the whole window every hop), and the bag still playing to the end
  if awk -v a="$prev_t" -v b="$t" -v m="$minutes" 'BEGIN{exit !(a >= 60 && b <= m + 0.5)}'; then
    steady_cpu=$(awk -v x="$steady_cpu" -v d="$d" 'BEGIN{print x + d}')
    steady_s=$(awk -v x="$steady_s" -v s="$span" 'BEGIN{print x + s}')
  fi
  prev=$c; prev_t=$t
done
diag=$(timeout 10 rostopic echo -n 3 /diagnostics 2>/dev/null || true)
value() { echo "$diag" | grep -A1 "key: \"$1\"" | awk -F'"' '/value:/ {v = $2} END {print v}'; }
echo "whole run: $(awk -v a="$c0" -v b="$(cpu)" 'BEGIN{printf "%.1f", b - a}') CPU s over $minutes min of input"
if awk -v s="$steady_s" 'BEGIN{exit !(s > 0)}'; then
  echo "window full (input >= 60 min): $(awk -v c="$steady_cpu" -v s="$steady_s" 'BEGIN{printf "%.2f %% of one core at real time (%.1f CPU s over %.0f s of input)", 100 * c / s, c, s}')"
fi
echo "full analyses: $(value "analyses (total)"), hops skipped: $(value "hops skipped, analysis busy (total)") (a skipped hop would hide a full analysis's cost)"
