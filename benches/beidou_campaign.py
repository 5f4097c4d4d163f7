#!/usr/bin/env python3
"""BeiDou in tight coupling from u-blox logs, one change isolated: for each seed, a GPS +
BeiDou log (`examples/sim_ubx.rs --beidou --seed S`: the receiver's errors drawn with S;
BeiDou MEO satellites from D1 and GEO satellites from D2) and an IMU along its drive
(`data/ubx-sim/drive.toml` with seed S), then `ins-gnss run` tight from the log alone (no
navigation file, no `[init]`: the run starts itself; noise as simulated; the default
gate) with `gnss.tight.systems = ["G"]` and `["G", "C"]`, and `ins-gnss eval truth.nav
--json`; and, isolating the GEO satellites, `["G", "C"]` on the same log without their
observations (`--no-geo`: every other satellite's errors unchanged). Prints per seed and
in all the horizontal and vertical RMS, position NEES/dof and exit status, and on how many
seeds BeiDou lowered the horizontal RMS. Run from the
repository root after `cargo build --release -p ins-gnss && cargo build --release --example sim_ubx`:

    python3 benches/beidou_campaign.py [FIRST_SEED [LAST_SEED_EXCLUSIVE]]
"""
import json, os, re, statistics as st, subprocess, sys, tempfile

from campaign import strip_init

first = int(sys.argv[1]) if len(sys.argv) > 1 else 101
last = int(sys.argv[2]) if len(sys.argv) > 2 else 117
B = os.path.abspath("target/release/ins-gnss")
SIM = os.path.abspath("target/release/examples/sim_ubx")
SC = open("data/ubx-sim/drive.toml").read()
# (name, systems, the log without its GEO satellites)
RUNS = {"G": ('["G"]', False), "GC": ('["G", "C"]', False), "GC-meo": ('["G", "C"]', True)}
root = os.path.join(tempfile.gettempdir(), "beidou-campaign")
res = {}
for seed in range(first, last):
    d = os.path.join(root, f"s{seed}")
    os.makedirs(d, exist_ok=True)
    logs = {False: f"{d}/log.ubx", True: f"{d}/log-meo.ubx"}
    subprocess.run([SIM, logs[False], "--beidou", "--seed", str(seed)], check=True,
                   capture_output=True)
    subprocess.run([SIM, logs[True], "--beidou", "--no-geo", "--seed", str(seed)], check=True,
                   capture_output=True)
    open(f"{d}/sc.toml", "w").write(re.sub(r"^seed = \d+", f"seed = {seed}", SC, flags=re.M))
    subprocess.run([B, "simulate", f"{d}/sc.toml", "--out", f"{d}/data"], check=True,
                   capture_output=True)
    base = open(f"{d}/data/config.toml").read()
    base = strip_init(base)  # no [init]: the run starts itself from the log
    base = base.replace("use_velocity = true\n", 'use_velocity = true\ncoupling = "tight"\n', 1)
    for name, (systems, meo) in RUNS.items():
        cfg = f"{d}/data/run-{name}.toml"
        text = base.replace('gnss = "GNSS.txt"', f'gnss = "{logs[meo]}"')
        open(cfg, "w").write(text + f"\n[gnss.tight]\nsystems = {systems}\n")
        out = f"{d}/out-{name}"
        rc = subprocess.run([B, "run", cfg, "--out", out, "--quiet"],
                            capture_output=True).returncode
        j = json.loads(subprocess.run([B, "eval", out, f"{d}/data/truth.nav", "--json"],
                                      capture_output=True, text=True).stdout)["forward"]
        o = j["overall"]
        res[(seed, name)] = (rc, o["horizontal"]["rms"], o["down"]["rms"],
                             j["nees"]["position"]["mean_per_dof"])
seeds = range(first, last)
print("| seed | horizontal RMS G / G+C / G+C MEO | vertical RMS | position NEES/dof | exit |")
print("|---|---|---|---|---|")
for s in seeds:
    r = [res[(s, n)] for n in RUNS]
    print(f"| {s} | {' / '.join(f'{x[1]:.2f}' for x in r)} m | {' / '.join(f'{x[2]:.2f}' for x in r)} m "
          f"| {' / '.join(f'{x[3]:.2f}' for x in r)} | {' / '.join(str(x[0]) for x in r)} |")
better = sum(res[(s, "GC")][1] < res[(s, "G")][1] for s in seeds)
ratio = [res[(s, "GC")][1] / res[(s, "G")][1] for s in seeds]
for name in RUNS:
    r = [res[(s, name)] for s in seeds]
    print(f"{name}: exit ≠ 0 {sum(x[0] != 0 for x in r)}, horizontal RMS mean {st.mean(x[1] for x in r):.3f} m, "
          f"vertical {st.mean(x[2] for x in r):.3f} m, NEES/dof {min(x[3] for x in r):.2f}–{max(x[3] for x in r):.2f}")
print(f"BeiDou lowered the horizontal RMS on {better} of {len(seeds)} seeds; ratio G+C / G "
      f"median {st.median(ratio):.3f} ({min(ratio):.3f}–{max(ratio):.3f})")
for name in RUNS:
    over = [s for s in seeds if res[(s, name)][3] > 3.0]
    print(f"{name}: position NEES/dof above 3 on {len(over)} of {len(seeds)} seeds {over}")
