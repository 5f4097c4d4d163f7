#!/bin/sh
# Regenerates RTKLIB's single-point solutions of the two stations and its RTK solutions of
# 0759 against 3040 (Debian package `rtklib`, rnx2rtkp 2.4.3 b34): the references
# `ins-gnss-core/tests/raw_spp.rs`, `tests/rtk.rs`, `ins-gnss spp --against` and
# `ins-gnss rtk --against` compare with. Run from this folder.
set -eu
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for s in 0759 3040; do
    zstd -q -d -c ../${s}0920.05o.zst > "$tmp/${s}0920.05o"
    zstd -q -d -c ../${s}0920.05n.zst > "$tmp/${s}0920.05n"
    # `-p 0` with no configuration: 15° mask, no ionosphere, no troposphere correction
    rnx2rtkp -p 0 -o "$tmp/spp$s-default.pos" "$tmp/${s}0920.05o" "$tmp/${s}0920.05n" 2>/dev/null
    rnx2rtkp -k klobuchar-saas.conf -o "$tmp/spp$s-klobuchar-saas.pos" "$tmp/${s}0920.05o" "$tmp/${s}0920.05n" 2>/dev/null
    rnx2rtkp -k ionofree-saas.conf -o "$tmp/spp$s-ionofree-saas.pos" "$tmp/${s}0920.05o" "$tmp/${s}0920.05n" 2>/dev/null
done
# RTK, 0759 the rover, 3040 the base at its header's APPROX POSITION XYZ (RTKLIB's own
# default averages the base's single points instead), every other option RTKLIB's
# default: static (-p 3) and kinematic (-p 2) on L1 + L2 (-f 2), kinematic on L1 (-f 1)
base="-3978242.4348 3382841.1715 3649902.7667"
for m in "3 2 static-l1l2" "2 2 kinematic-l1l2" "2 1 kinematic-l1"; do
    set -- $m
    rnx2rtkp -p "$1" -f "$2" -r $base -o "$tmp/rtk0759-$3.pos" "$tmp/07590920.05o" "$tmp/30400920.05o" "$tmp/07590920.05n" 2>/dev/null
done
for f in "$tmp"/*.pos; do zstd -q -19 -f "$f" -o "$(basename "$f").zst"; done
