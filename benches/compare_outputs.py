#!/usr/bin/env python3
"""Every output of `run CONFIG --smooth` from two binaries, compared file by file.

    python3 benches/compare_outputs.py OLD_BIN NEW_BIN CONFIG [CONFIG...]

Each CONFIG runs from its own directory into a fresh temporary output directory per
binary; a run that fails is compared by its exit code and error message. A file is reported identical, or with the number of lines that differ; for
`std_smoothed.txt` the rows of the new file are matched with the old file's rows at the
same time stamp (the old binary may have written more of them), and the largest
difference in units of the last printed digit and the largest relative difference are
given. `--by-index` matches `std_smoothed.txt` rows through `nav.txt`'s row numbers
instead (for binaries whose time stamps differ) and compares every column but the time,
as it does for `nav_smoothed.txt`.
"""
import os
import shutil
import subprocess
import sys
import tempfile


def run(binary, config):
    out = tempfile.mkdtemp(prefix="compare-")
    cmd = [os.path.abspath(binary), "run", os.path.basename(config), "--quiet",
           "--accept-inconsistent", "--smooth", "--out", out]
    done = subprocess.run(cmd, cwd=os.path.dirname(os.path.abspath(config)),
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return out, done.returncode, done.stderr


def last_digits(a, b):
    """Largest difference of two rows in units of the last printed digit, and relative."""
    units, rel = 0.0, 0.0
    for p, q in zip(a, b):
        if p != q:
            dec = len(p.split(".")[1]) if "." in p else 0
            units = max(units, abs(float(p) - float(q)) * 10 ** dec)
            rel = max(rel, abs(float(p) - float(q)) / max(abs(float(p)), 1e-300))
    return units, rel


def compare_std(old_dir, new_dir, by_index):
    old = [l.split() for l in open(os.path.join(old_dir, "std_smoothed.txt"))]
    new = [l.split() for l in open(os.path.join(new_dir, "std_smoothed.txt"))]
    if by_index:
        times = [l.split()[1] for l in open(os.path.join(new_dir, "nav.txt"))]
        row = {t: i for i, t in enumerate(times)}
        pairs = [(old[row[r[0]]][1:], r[1:]) for r in new if r[0] in row]
    else:
        at = {}
        for r in old:
            at.setdefault(r[0], r)
        pairs = [(at[r[0]], r) for r in new if r[0] in at]
    differ = [(a, b) for a, b in pairs if a != b]
    worst = [last_digits(a, b) for a, b in differ]
    units = max((w[0] for w in worst), default=0.0)
    rel = max((w[1] for w in worst), default=0.0)
    return (f"{len(new)} rows (old file {len(old)}), {len(pairs)} matched; {len(differ)} differ, "
            f"at most {units:.0f} unit(s) of the last digit, {rel:.1e} relative")


def main():
    args = [a for a in sys.argv[1:] if a != "--by-index"]
    by_index = "--by-index" in sys.argv
    if len(args) < 3:
        sys.exit(__doc__)
    old_bin, new_bin, configs = args[0], args[1], args[2:]
    for config in configs:
        (old_dir, old_rc, old_err), (new_dir, new_rc, new_err) = \
            run(old_bin, config), run(new_bin, config)
        try:
            print(f"== {config}")
            if old_rc or new_rc:
                # a refused or failed run: its exit code and message are its output
                same = (old_rc, old_err) == (new_rc, new_err)
                print(f"  exit {old_rc} -> {new_rc}, message "
                      f"{'identical' if same else 'differs'}")
            for name in sorted(os.listdir(new_dir)):
                a = open(os.path.join(old_dir, name), "rb").read()
                b = open(os.path.join(new_dir, name), "rb").read()
                if a == b:
                    print(f"  {name:18} identical")
                elif name == "std_smoothed.txt":
                    print(f"  {name:18} {compare_std(old_dir, new_dir, by_index)}")
                elif name == "nav_smoothed.txt" and by_index:
                    la, lb = a.decode().splitlines(), b.decode().splitlines()
                    drop = lambda r: r[:1] + r[2:]  # every column but the time
                    n = sum(1 for x, y in zip(la, lb) if drop(x.split()) != drop(y.split()))
                    print(f"  {name:18} {n} of {len(lb)} lines differ besides the time "
                          f"(old file {len(la)})")
                else:
                    la, lb = a.decode().splitlines(), b.decode().splitlines()
                    n = sum(1 for x, y in zip(la, lb) if x != y)
                    print(f"  {name:18} {n} of {len(lb)} lines differ (old file {len(la)})")
        finally:
            shutil.rmtree(old_dir, ignore_errors=True)
            shutil.rmtree(new_dir, ignore_errors=True)


if __name__ == "__main__":
    main()
