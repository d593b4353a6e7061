"""Large logs: what reading one costs (hpddo bench --large-log).

A synthetic bench log in the valid format (docs/bench-log.md; seven columns, 2 Hz, duty and
load steps, noisy V, I and encoder: about 62 bytes a row) is written in a temporary folder,
then measured, each measurement in a fresh Python process (its peak RSS its own, by
resource.getrusage):

* read_log of the whole file: seconds and peak RSS against the file's size;
* read_log of the same file with a fault early in it (a non-numeric v_V at FAULT_LINE):
  seconds and peak RSS to the refusal, against the whole read;
* optionally hpddo evaluate of the whole file with a model folder: seconds and peak RSS
  (the largest process of the command, the native replay included).

The target (issue 32): peak RSS at most 3 x the file's size + 300 MB, and a fault refused as
soon as it is read.
"""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

FAULT_LINE = 7207
ROWS = 2_000_000


def budget_bytes(file_bytes: int) -> int:
    """The memory a command may take for a log of file_bytes: 3 x its size + 300 MB."""
    return 3 * file_bytes + 300 * 2**20


def write_synthetic(path, rows: int = ROWS, seed: int = 1, fault_line: int | None = None,
                    chunk: int = 200_000) -> pathlib.Path:
    """Writes a synthetic bench log of `rows` rows (chunk by chunk: its memory is a chunk's);
    fault_line: the file line whose v_V is 'abc' (a non-numeric cell), None: a valid file."""
    import pandas as pd

    rng = np.random.default_rng(seed)
    path = pathlib.Path(path)
    head = "# condition=large\n# sample_rate_hz=2\n# note=synthetic (hpddo.studies.large_log)\n"
    n_head = head.count("\n") + 1  # the header is the line after the metadata
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(head + "t_s,duty,v_V,i_A,rpm_ref,temp_C,load\n")
        for start in range(0, rows, chunk):
            k = np.arange(start, min(start + chunk, rows))
            step = k // 60  # a 30 s step of duty and load
            duty = np.round(0.2 + 0.1 * (step % 8), 4)
            load = (step // 8) % 3
            i = 0.12 + 0.25 * load + 0.01 * rng.standard_normal(len(k))
            v = 12.0 * duty - 0.02 * rng.standard_normal(len(k))
            rpm = np.maximum((v - 2.5 * i) / 0.006, 0) + 2.0 * rng.standard_normal(len(k))
            temp = 30.0 + 10.0 * (1 - np.exp(-k / 20000.0)) + 0.03 * rng.standard_normal(len(k))
            df = pd.DataFrame({"t_s": 0.5 * k, "duty": duty, "v_V": np.round(v, 6), "i_A": np.round(i, 6),
                               "rpm_ref": np.round(rpm, 3), "temp_C": np.round(temp, 4), "load": load})
            if fault_line is not None and start <= fault_line - n_head - 1 < start + len(k):
                df = df.astype({"v_V": object})
                df.loc[fault_line - n_head - 1 - start, "v_V"] = "abc"
            df.to_csv(fh, header=False, index=False, lineterminator="\n")
    return path


_CHILD = """
import json, resource, sys, time
t0 = time.perf_counter()
from hpddo.logs.benchlog import BenchLogError, read_log
t1 = time.perf_counter()
try:
    log = read_log(sys.argv[1]); out = {"rows": len(log.df)}
except BenchLogError as e:
    out = {"refused": str(e)[-120:], "line": e.line}
out["seconds"] = time.perf_counter() - t1
out["peak_rss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps(out))
"""


def read_in_child(path) -> dict:
    """read_log(path) in a fresh Python: {"seconds", "peak_rss" (bytes), "rows" | "refused", "line"}."""
    res = subprocess.run([sys.executable, "-c", _CHILD, str(path)], capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def baseline_in_child() -> int:
    """Peak RSS of a fresh Python that imported the reader and read nothing (what every command pays)."""
    code = ("import resource; from hpddo.logs import benchlog; "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)")
    return int(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)


def evaluate_in_child(model, path, out) -> dict:
    """hpddo evaluate --model model path --out out --quiet in a fresh process: {"seconds", "peak_rss"
    (the largest process of the command, bytes), "status"}."""
    import resource
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "hpddo", "evaluate", "--model", str(model), str(path),
                             "--out", str(out), "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - t0
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    peak = max(usage.ru_maxrss, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss) * 1024
    return {"seconds": seconds, "peak_rss": peak, "status": os.waitstatus_to_exitcode(status), "stderr": err[-500:]}


def measure(tmp, rows: int = ROWS, model=None) -> dict:
    """Every figure of the module docstring, into a dict; prints each as it is measured."""
    tmp = pathlib.Path(tmp)
    good = write_synthetic(tmp / "large.csv", rows)
    bad = write_synthetic(tmp / "large_fault.csv", rows, fault_line=FAULT_LINE)
    size = good.stat().st_size
    mb = 2 ** 20
    base = baseline_in_child()
    whole = read_in_child(good)
    early = read_in_child(bad)
    res = {"rows": rows, "file_bytes": size, "budget_bytes": budget_bytes(size), "python_baseline_rss": base,
           "read": whole, "fault": early}
    print(f"large log: {rows} rows, {size / mb:.1f} MB (synthetic, valid format); budget 3 x size + 300 MB = "
          f"{budget_bytes(size) / mb:.0f} MB; a Python with the reader imported: {base / mb:.0f} MB")
    print(f"  read_log whole file: {whole['seconds']:.2f} s, peak RSS {whole['peak_rss'] / mb:.0f} MB = "
          f"{whole['peak_rss'] / size:.2f} x the file ({'within' if whole['peak_rss'] <= budget_bytes(size) else 'OVER'}"
          " the budget)")
    print(f"  read_log, fault at line {FAULT_LINE}: refused at line {early.get('line')} in {early['seconds']:.3f} s, "
          f"peak RSS {early['peak_rss'] / mb:.0f} MB; time to refuse / time to read the whole file: "
          f"{early['seconds'] / whole['seconds']:.4f}")
    if model is not None:
        ev = evaluate_in_child(model, good, tmp / "evaluation")
        res["evaluate"] = ev
        print(f"  hpddo evaluate --model {model} (whole file): exit {ev['status']}, {ev['seconds']:.1f} s, peak RSS "
              f"{ev['peak_rss'] / mb:.0f} MB = {ev['peak_rss'] / size:.2f} x the file "
              f"({'within' if ev['peak_rss'] <= budget_bytes(size) else 'OVER'} the budget)")
        if ev["status"] != 0:
            print(f"  hpddo evaluate failed: {ev['stderr']}")
    return res


def main(argv=None) -> int:
    import tempfile

    from . import parser
    ap = parser("large_log", __doc__)
    ap.add_argument("--rows", type=int, default=ROWS)
    ap.add_argument("--model", type=pathlib.Path, default=None, help="also time hpddo evaluate with this model folder")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="hpddo-large-log-") as tmp:
        res = measure(tmp, a.rows, a.model)
    if a.json:
        a.json.write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
