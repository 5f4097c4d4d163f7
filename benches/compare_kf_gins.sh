#!/usr/bin/env bash
# Whole-run comparison with your own KF-GINS build (not part of CI).
#
#   benches/compare_kf_gins.sh PATH/TO/KF-GINS CONFIG.yaml [PAIRS] [-- extra ins-gnss args]
#
# Builds ins-gnss in release, then runs KF-GINS (`KF-GINS CONFIG.yaml`) and
# `ins-gnss run CONFIG.yaml --quiet --accept-inconsistent --out DIR` alternately PAIRS
# times (default 8), file to file, and prints the median wall and CPU (user + sys) time
# of each and their ratios. Build KF-GINS as its README says, with -O3 -DNDEBUG
# (e.g. cmake -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS="-O3 -DNDEBUG"). Both read the
# same YAML; KF-GINS writes where its `outputpath` says, ins-gnss into a temporary
# directory. Give plain-text inputs for a fair comparison (KF-GINS does not read .zst).
set -euo pipefail
kf=${1:?KF-GINS binary}; cfg=${2:?KF-GINS YAML}; pairs=${3:-8}
shift $(( $# < 3 ? $# : 3 ))
[ "${1:-}" = "--" ] && shift
cd "$(dirname "$0")/.."
cargo build --release -p ins-gnss >/dev/null
ours=target/release/ins-gnss
out=$(mktemp -d); log=$(mktemp)
trap 'rm -rf "$out" "$log"' EXIT
for _ in $(seq "$pairs"); do
  /usr/bin/time -f "kf-gins %e %U %S" "$kf" "$cfg" >/dev/null 2>>"$log" || true
  /usr/bin/time -f "ins-gnss %e %U %S" "$ours" run "$cfg" --quiet --accept-inconsistent \
    --out "$out" "$@" >/dev/null 2>>"$log" || true
done
grep -E '^(kf-gins|ins-gnss) ' "$log" | awk '
  { wall[$1] = wall[$1] " " $2; cpu[$1] = cpu[$1] " " ($3 + $4) }
  function median(s,   a, n, i, j, t) {
    n = split(s, a, " ")
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
    return (n % 2) ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
  }
  END {
    kw = median(wall["kf-gins"]); kc = median(cpu["kf-gins"])
    ow = median(wall["ins-gnss"]); oc = median(cpu["ins-gnss"])
    printf "KF-GINS : wall %.3f s, CPU %.3f s\n", kw, kc
    printf "ins-gnss: wall %.3f s, CPU %.3f s\n", ow, oc
    if (ow > 0 && oc > 0) printf "ratio   : %.1fx wall, %.1fx CPU\n", kw / ow, kc / oc
  }'
