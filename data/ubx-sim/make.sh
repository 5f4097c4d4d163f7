#!/bin/sh
# Regenerates the simulated u-blox log and RTKLIB's conversion of it (Debian package
# `rtklib`, convbin 2.4.3 b34). Run from the repository root:
#   sh data/ubx-sim/make.sh
set -eu
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cargo run --release --example sim_ubx -- "$tmp/sim.ubx"
convbin -r ubx -v 3.04 -oi -od -os -o "$tmp/sim.obs" -n "$tmp/sim.nav" "$tmp/sim.ubx" >/dev/null 2>&1
for f in sim.ubx sim.obs sim.nav; do
    zstd -q -19 -f "$tmp/$f" -o "data/ubx-sim/$f.zst"
done
