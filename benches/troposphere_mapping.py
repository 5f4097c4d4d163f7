#!/usr/bin/env python3
"""The troposphere's mapping, one change isolated: 1/sin(el) (`saastamoinen`, RTKLIB's
single point) against Niell's functions (`niell`), in tight coupling on simulated raw
observations whose true troposphere maps as Niell's.

For each seed, `ins-gnss/scenarios/tight.toml` with the seed, a start time spread over the
navigation file's day (so that the sky differs), no canyon, `raw.elevation_mask = 5` and
`raw.troposphere = "niell"`; then `ins-gnss run` with `[gnss.tight]` `elevation_mask` 5 and
15 and `troposphere` each way (the scenario's `[init]`, noise as simulated, the default
gate), and `ins-gnss eval truth.nav --json`. Prints, per mask and model, the runs' mean
horizontal and vertical RMS and position NEES/dof, and the paired (same data) difference
of the mean down error. Run from the repository root after `cargo build --release -p
ins-gnss`:

    python3 benches/troposphere_mapping.py [FIRST_SEED [LAST_SEED_EXCLUSIVE [BINARY]]]
"""
import json, os, re, statistics as st, subprocess, sys, tempfile

first = int(sys.argv[1]) if len(sys.argv) > 1 else 31
last = int(sys.argv[2]) if len(sys.argv) > 2 else 47
B = os.path.abspath(sys.argv[3] if len(sys.argv) > 3 else "target/release/ins-gnss")
SC = open("ins-gnss/scenarios/tight.toml").read()
SC = SC.replace('nav = "../../data', 'nav = "' + os.path.abspath("data"))
MASKS, MODELS = (5, 15), ("saastamoinen", "niell")
root = os.path.join(tempfile.gettempdir(), "troposphere-mapping")
res = {}
for seed in range(first, last):
    d = os.path.join(root, f"s{seed}")
    os.makedirs(d, exist_ok=True)
    t0 = 518400.0 + 3600.0 + (seed - first) * 5000.0  # 01:00 onwards, 5000 s apart
    sc = re.sub(r"^seed = \d+", f"seed = {seed}", SC, flags=re.M)
    sc = sc.replace("time = 529200.0", f"time = {t0}")
    sc = sc.replace("masks = [[300.0, 360.0, 3.0]]", "masks = []")
    sc += 'elevation_mask = 5.0\ntroposphere = "niell"\n'
    open(f"{d}/sc.toml", "w").write(sc)
    subprocess.run([B, "simulate", f"{d}/sc.toml", "--out", f"{d}/data"], check=True,
                   capture_output=True)
    base = open(f"{d}/data/config.toml").read()
    for mask in MASKS:
        for model in MODELS:
            cfg = f"{d}/data/run-{mask}-{model}.toml"
            open(cfg, "w").write(base + f'\n[gnss.tight]\nelevation_mask = {mask}.0\n'
                                        f'troposphere = "{model}"\n')
            out = f"{d}/out-{mask}-{model}"
            rc = subprocess.run([B, "run", cfg, "--out", out, "--quiet"],
                                capture_output=True).returncode
            j = json.loads(subprocess.run([B, "eval", out, f"{d}/data/truth.nav", "--json"],
                                          capture_output=True, text=True).stdout)["forward"]
            o = j["overall"]
            res[(seed, mask, model)] = (rc, o["horizontal"]["rms"], o["down"]["rms"],
                                        o["down"]["mean"], j["nees"]["position"]["mean_per_dof"])
seeds = range(first, last)
print(f"seeds {first}-{last - 1} ({len(seeds)} runs per row)")
print("| filter mask | mapping | exit ≠ 0 | horizontal RMS, mean | vertical RMS, mean | position NEES/dof, mean |")
print("|---|---|---|---|---|---|")
for mask in MASKS:
    for model in MODELS:
        r = [res[(s, mask, model)] for s in seeds]
        print(f"| {mask}° | {model} | {sum(x[0] != 0 for x in r)} | {st.mean(x[1] for x in r):.3f} m "
              f"| {st.mean(x[2] for x in r):.3f} m | {st.mean(x[4] for x in r):.2f} |")
for mask in MASKS:
    diff = [res[(s, mask, "niell")][3] - res[(s, mask, "saastamoinen")][3] for s in seeds]
    print(f"mask {mask}°: mean down error, niell − saastamoinen (same data): mean {st.mean(diff):+.3f} m, "
          f"range {min(diff):+.3f} … {max(diff):+.3f} m, negative (higher) on {sum(x < 0 for x in diff)} of {len(diff)}")
