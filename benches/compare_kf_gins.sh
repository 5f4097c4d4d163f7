#!/usr/bin/env bash
# Whole-run comparison with KF-GINS on the same machine (not part of CI).
#
#   benches/compare_kf_gins.sh [KF-GINS] CONFIG.yaml [PAIRS] [-- extra ins-gnss args]
#
# KF-GINS defaults to ../shared/bin/kf-gins (built -O3 -DNDEBUG; see its README). The
# script builds ins-gnss in release, then copies the YAML's inputs into a scratch folder as
# plain text (KF-GINS reads neither .zst nor .gz; ins-gnss reads the same plain files, so
# both parse the same bytes), writes a copy of the YAML whose `imupath`, `gnsspath` and
# `outputpath` point there, and runs, from that folder, `kf-gins CONFIG.yaml` and
# `ins-gnss run CONFIG.yaml --quiet --accept-inconsistent --out DIR` alternately PAIRS
# times (default 10), file to file. It prints the median wall and CPU (user + sys) time of
# each and their ratios. A run of either program that fails, or a KF-GINS run that writes
# no navigation file, stops the script with its output and a non-zero status.
#
# Both programs write into an emptied output folder before each run (emptied outside the
# timing), the same condition for both. With RERUN=1 in the environment both write over
# their own earlier result instead: KF-GINS truncates its files, ins-gnss keeps the earlier
# result aside until its verdict (and frees it after), so each pays for the earlier files.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
if [ $# -ge 1 ] && [[ "$1" != *.yaml && "$1" != *.yml ]]; then
  kf=$1; shift
else
  kf=$root/../shared/bin/kf-gins
fi
cfg=${1:?KF-GINS YAML}; shift
pairs=10
if [ $# -ge 1 ] && [ "$1" != "--" ]; then pairs=$1; shift; fi
[ "${1:-}" = "--" ] && shift
kf=$(cd "$(dirname "$kf")" && pwd)/$(basename "$kf")
[ -x "$kf" ] || { echo "compare_kf_gins: no KF-GINS executable at $kf" >&2; exit 1; }
cfg_dir=$(cd "$(dirname "$cfg")" && pwd)
(cd "$root" && cargo build --release --quiet -p ins-gnss)
ours=$root/target/release/ins-gnss

work=$(mktemp -d); log=$work/times
trap 'rm -rf "$work"' EXIT
# the YAML's inputs as plain text, and a copy of the YAML that reads them
value() { sed -n "s/^$1:[[:space:]]*\"\{0,1\}\([^\"#]*\)\"\{0,1\}.*/\1/p" "$cfg" | sed 's/[[:space:]]*$//' | head -1; }
plain() {
  local src=$cfg_dir/$1 dst=$work/$2
  case "$src" in
    *.zst) zstd -dqc "$src" >"$dst" ;;
    *.gz) gzip -dc "$src" >"$dst" ;;
    *.xz) xz -dc "$src" >"$dst" ;;
    *) cp "$src" "$dst" ;;
  esac
}
imu=$(value imupath); gnss=$(value gnsspath)
[ -n "$imu" ] && [ -n "$gnss" ] || { echo "compare_kf_gins: $cfg has no imupath or gnsspath" >&2; exit 1; }
plain "$imu" imu.txt
plain "$gnss" gnss.txt
mkdir -p "$work/kf-out"
sed -e 's|^imupath:.*|imupath: "imu.txt"|' -e 's|^gnsspath:.*|gnsspath: "gnss.txt"|' \
    -e 's|^outputpath:.*|outputpath: "kf-out"|' "$cfg" >"$work/config.yaml"
cd "$work"
run() {
  # run NAME COMMAND...: time it, stop the script with its output when it fails
  # (bash's `time` to the millisecond: GNU time's %e has 10 ms steps, a tenth of a run)
  local name=$1 status=0 times TIMEFORMAT='%3R %3U %3S'; shift
  times=$({ time "$@" >"$work/$name.out" 2>&1; } 2>&1) || status=$?
  if [ "$status" != 0 ]; then
    echo "compare_kf_gins: $name failed (exit $status): $*" >&2
    tail -20 "$work/$name.out" >&2
    exit 1
  fi
  echo "$name $times" >>"$log"
}
for _ in $(seq "$pairs"); do
  [ "${RERUN:-0}" = 1 ] || rm -rf kf-out/* "$work/ours"
  run kf-gins "$kf" config.yaml
  [ -s kf-out/KF_GINS_Navresult.nav ] || ls kf-out/*.nav >/dev/null 2>&1 || {
    echo "compare_kf_gins: KF-GINS wrote no navigation file into kf-out/" >&2
    tail -20 "$work/kf-gins.out" >&2
    exit 1
  }
  run ins-gnss "$ours" run config.yaml --quiet --accept-inconsistent --out "$work/ours" "$@"
done
awk '
  { wall[$1] = wall[$1] " " $2; cpu[$1] = cpu[$1] " " ($3 + $4) }
  function median(s,   a, n, i, j, t) {
    n = split(s, a, " ")
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
    return (n % 2) ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
  }
  END {
    kw = median(wall["kf-gins"]); kc = median(cpu["kf-gins"])
    ow = median(wall["ins-gnss"]); oc = median(cpu["ins-gnss"])
    printf "KF-GINS : wall %.3f s, CPU %.3f s (median of %d)\n", kw, kc, split(wall["kf-gins"], x, " ")
    printf "ins-gnss: wall %.3f s, CPU %.3f s (median of %d)\n", ow, oc, split(wall["ins-gnss"], x, " ")
    if (ow > 0 && oc > 0) printf "ratio   : %.1fx wall, %.1fx CPU\n", kw / ow, kc / oc
  }' "$log"
