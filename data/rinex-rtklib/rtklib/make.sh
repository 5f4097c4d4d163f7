#!/bin/sh
# Regenerates RTKLIB's single-point solutions of the two stations (Debian package
# `rtklib`, rnx2rtkp 2.4.3 b34): the references `ins-gnss-core/tests/raw_spp.rs` and
# `ins-gnss spp --against` compare with. Run from this folder.
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
for f in "$tmp"/*.pos; do zstd -q -19 -f "$f" -o "$(basename "$f").zst"; done
