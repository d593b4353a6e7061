#!/usr/bin/env python3
"""Checks of host/replay.cpp that need whole logs (ctest core.replay_*):

  json  a condition name with a quote, a backslash and a tab is written to metrics.json
        as a valid JSON string that reads back to the same name;
  seq   a jump of the log's full seq by 65536 (invisible in the 16 bits the observer
        sees) restarts the lags exactly as a visible gap does.

    check_replay.py --replay build-core/host/replay_tiny --workdir DIR {json,seq}
"""
import argparse
import csv
import json
import pathlib
import subprocess
import sys


def write_log(path, condition, seqs):
    rows = []
    for k, seq in enumerate(seqs):
        duty = 0.3 + 0.5 * ((k // 10) % 2)
        i = 0.3 + 1.2 * duty + 0.05 * (k % 3)
        v = 12.0 * duty
        rows.append(f"{0.5 * k:.4f},{duty:.4f},{v:.6f},{i:.6f},{(v - 4.5 * i) / 0.406 * 9.549:.3f},40.0000,{seq}")
    text = (f"# condition={condition}\n# sample_rate_hz=2\n# split_row=5\n"
            "t_s,duty,v_V,i_A,rpm_ref,temp_C,seq\n" + "\n".join(rows) + "\n")
    path.write_text(text)


def run(replay, *args):
    r = subprocess.run([replay, *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"replay failed ({r.returncode}): {r.stderr}")


def check_json(replay, work):
    name = 'quote"back\\slash\ttab'
    log = work / "quoted.csv"
    write_log(log, name, range(40))
    metrics = work / "metrics.json"
    run(replay, "--metrics", metrics, log)
    m = json.loads(metrics.read_text())
    for key in ("clamped_share", "fallback_share", "invalid_share", "test_rows"):
        assert name in m[key], (key, list(m[key]))
    for model in ("M1", "M2", "M3"):
        assert name in m["rmse_rpm"][model], (model, list(m["rmse_rpm"][model]))
    print("metrics.json reads back the condition", json.dumps(name))


def estimates(replay, work, stem, seqs):
    log = work / f"{stem}.csv"
    write_log(log, stem, seqs)
    out = work / stem
    out.mkdir(exist_ok=True)
    run(replay, "--out-dir", out, log)
    with open(out / f"{stem}.estimates.csv") as f:
        return [(r["rpm_m2"], r["rpm_m3"], r["status"]) for r in csv.DictReader(f)]


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
    ap.add_argument("check", choices=("json", "seq"))
    args = ap.parse_args()
    work = pathlib.Path(args.workdir)
    work.mkdir(parents=True, exist_ok=True)
    (check_json if args.check == "json" else check_seq)(args.replay, work)


if __name__ == "__main__":
    main()
