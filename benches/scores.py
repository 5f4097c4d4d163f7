"""Scoring a navigation file as the README scores it, for `peers.py` and `learned_noise.py`.

navego: the horizontal and yaw RMS against `truth.nav.zst` after 60 s, and the share of
epochs whose position lies beyond the run's own 99 % ellipsoid; drive-0708: the RMS over
the ten 15 s outages of each one's largest horizontal error against `ref_rtkfix.txt.zst`
(its reference is the RTK fixes the run reads, not an independent truth: no coverage).
"""
import json, os, subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WINDOWS = json.load(open(os.path.join(ROOT, "data/drive-0708/outage_windows_15s.json")))


def score(binary, kind, nav):
    """`{"h": metres, "yaw": degrees or None, "beyond": percent or None}`, or None when
    `ins-gnss eval` fails (`kind`: "navego" or "drive")."""
    if kind == "navego":
        args = [binary, "eval", nav, os.path.join(ROOT, "data/navego/truth.nav.zst"), "--skip", "60", "--json"]
    else:
        args = [binary, "eval", nav, os.path.join(ROOT, "data/drive-0708/ref_rtkfix.txt.zst"), "--json"]
        for a, b in WINDOWS:
            args += ["--window", f"{a},{b}"]
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        return None
    j = json.loads(r.stdout)
    if kind == "navego":
        o = j["overall"]
        s = {"h": o["horizontal"]["rms"], "yaw": o.get("yaw", {}).get("rms")}
    else:
        s = {"h": j["windows_rms_of_max_horizontal"], "yaw": None}
    nees = (j.get("nees") or {}).get("position") if kind == "navego" else None
    s["beyond"] = None if not nees else 100 * nees["beyond_99"]
    return s
