#!/usr/bin/env python3
"""Checks of host/replay.cpp that need whole logs (ctest core.replay_*):

  split split_row=0 in the log, or --split 0 without it, makes every row a test row
        (what hpddo evaluate replays), and the estimates do not depend on how;
  seq   a jump of the log's full seq by 65536 (invisible in the 16 bits the observer
        sees) restarts the lags exactly as a visible gap does.

    check_replay.py --replay build-core/host/replay_tiny --workdir DIR {split,seq}
"""
import argparse
import csv
import pathlib
import subprocess
import sys


def write_log(path, condition, seqs, split_row=5):
    rows = []
    for k, seq in enumerate(seqs):
        duty = 0.3 + 0.5 * ((k // 10) % 2)
        i = 0.3 + 1.2 * duty + 0.05 * (k % 3)
        v = 12.0 * duty
        rows.append(f"{0.5 * k:.4f},{duty:.4f},{v:.6f},{i:.6f},{(v - 4.5 * i) / 0.406 * 9.549:.3f},40.0000,{seq}")
    split = "" if split_row is None else f"# split_row={split_row}\n"
    text = (f"# condition={condition}\n# sample_rate_hz=2\n{split}"
            "t_s,duty,v_V,i_A,rpm_ref,temp_C,seq\n" + "\n".join(rows) + "\n")
    path.write_text(text)


def run(replay, *args):
    r = subprocess.run([replay, *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"replay failed ({r.returncode}): {r.stderr}")


def estimates(replay, work, stem, seqs, split_row=5, args=(), fields=("rpm_m2", "rpm_m3", "status")):
    log = work / f"{stem}.csv"
    write_log(log, stem, seqs, split_row)
    out = work / stem
    out.mkdir(exist_ok=True)
    run(replay, *args, "--out-dir", out, log)
    with open(out / f"{stem}.estimates.csv") as f:
        return [tuple(r[k] for k in fields) for r in csv.DictReader(f)]


def check_split(replay, work):
    fields = ("rpm_m2", "rpm_m3", "status", "part")
    meta = estimates(replay, work, "meta", range(40), split_row=0, fields=fields)
    arg = estimates(replay, work, "arg", range(40), split_row=None, args=("--split", "0"), fields=fields)
    assert len(meta) == 40 and {r[3] for r in meta} == {"test"}, meta[:3]
    assert meta == arg, [(k, x, y) for k, (x, y) in enumerate(zip(meta, arg)) if x != y][:3]
    assert meta[0][2] != "invalid", meta[0]
    print("split_row=0 and --split 0 make all 40 rows test rows, with the same estimates")


def check_seq(replay, work):
    base = list(range(1000, 1040))
    hidden = base[:20] + [s + 65536 for s in base[20:]]  # low 16 bits consecutive
    visible = base[:20] + [s + 5 for s in base[20:]]     # a gap the 16 bits show
    a = estimates(replay, work, "hidden", hidden)
    b = estimates(replay, work, "visible", visible)
    c = estimates(replay, work, "none", base)
    assert a == b, [(k, x, y) for k, (x, y) in enumerate(zip(a, b)) if x != y][:3]
    assert a[20] != c[20], "the gap must change the estimate at its row (lags restarted)"
    print("a seq jump of 65536 restarts the lags like a visible gap")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--replay", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("check", choices=("split", "seq"))
    args = ap.parse_args()
    work = pathlib.Path(args.workdir)
    work.mkdir(parents=True, exist_ok=True)
    (check_split if args.check == "split" else check_seq)(args.replay, work)


if __name__ == "__main__":
    main()
