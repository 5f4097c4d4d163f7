#!/bin/sh
# Regenerates the simulated u-blox logs and RTKLIB's conversions of them (Debian package
# `rtklib`, convbin 2.4.3 b34): `sim` (GPS, 300 s), `gal` (GPS and Galileo I/NAV, 70 s) and
# `bds` (GPS and BeiDou D1 and D2, 200 s), and RTKLIB's single point of the `bds` log (rnx2rtkp
# 2.4.3 b34 with `bds-rtklib.conf`: GPS and BeiDou, no mask, Klobuchar, Saastamoinen).
# Run from the repository root:
#   sh data/ubx-sim/make.sh
set -eu
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cargo run --release --example sim_ubx -- "$tmp/sim.ubx"
cargo run --release --example sim_ubx -- "$tmp/gal.ubx" --galileo
cargo run --release --example sim_ubx -- "$tmp/bds.ubx" --beidou
for log in sim gal bds; do
    convbin -r ubx -v 3.04 -oi -od -os -o "$tmp/$log.obs" -n "$tmp/$log.nav" "$tmp/$log.ubx" >/dev/null 2>&1
    for f in $log.ubx $log.obs $log.nav; do
        zstd -q -19 -f "$tmp/$f" -o "data/ubx-sim/$f.zst"
    done
done
rnx2rtkp -k data/ubx-sim/bds-rtklib.conf -o "$tmp/bds-rtklib.pos" "$tmp/bds.obs" "$tmp/bds.nav" 2>/dev/null
zstd -q -19 -f "$tmp/bds-rtklib.pos" -o data/ubx-sim/bds-rtklib.pos.zst
