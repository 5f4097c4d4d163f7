#!/usr/bin/env python3
"""Write the 24 h scenario of benches/README.md ("The second pass and the day").

    python3 benches/day_scenario.py > day.toml
    ins-gnss simulate day.toml --out day        # 8.64 M IMU samples at 100 Hz, ~3 min
    # add to day/config.toml:   [vehicle.nhc]  mounting = [0.0, 0.0, 2.0]
    # for the runs without the truth evaluation, drop the `truth = ...` line (notruth.toml)
    ins-gnss run day/notruth.toml --nhc [--smooth]

The header and everything after the segments are those of
`ins-gnss/scenarios/car-aided.toml`; the segments are a 114 s loop (stop, accelerate,
straight, left turn, straight, right turn, decelerate) flown 757 times, then a last stop:
86,308 s.
"""
import pathlib
import re

CAR = pathlib.Path(__file__).resolve().parent.parent / "ins-gnss/scenarios/car-aided.toml"
LOOP = [
    ("stop", 10.0, None),
    ("accelerate", 8.0, ("accel", 1.5)),
    ("straight", 30.0, None),
    ("turn", 15.0, ("rate", 6.0)),
    ("straight", 30.0, None),
    ("turn", 15.0, ("rate", -6.0)),
    ("decelerate", 6.0, ("accel", 2.0)),
]


def segment(kind, duration, extra):
    text = f'[[segment]]\nkind = "{kind}"\nduration = {duration}\n'
    if extra:
        text += f"{extra[0]} = {extra[1]}\n"
    return text + "\n"


def main():
    src = CAR.read_text()
    first = src.index("[[segment]]")
    after = re.search(r"^\[(?!\[segment\]\])", src[first:], re.M).start() + first
    segments = "".join(segment(*s) for s in LOOP) * 757 + segment(*LOOP[0])
    print(src[:first] + segments + src[after:], end="")


if __name__ == "__main__":
    main()
