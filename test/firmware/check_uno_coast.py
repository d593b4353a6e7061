#!/usr/bin/env python3
"""Runs uno_acq's coast probe build (-DACQ_RIPPLE_HZ=10000 -DACQ_COAST=1) in simavr and checks the
probes (issue 33 item 7; uno_acq/acq_coast.h; docs/ripple-board.md, "Coast probes").

The harness (uno_sim.c with uno_sim_ripple.h) feeds each triggered conversion the value of its
window's period from a feed file, on the channel the ADC converts: A1 for a current sample, A0 for
a voltage one. Every window's feed holds, at the probe's periods (the burst's first ones), a probe
as the motor would give it: the current freewheeling to zero over a few samples, the terminal
voltage then the back-EMF, slowing with the shaft, at a level of its own per window. Then:

* the stream's "~" lines decode (hpddo.logs.ripple_link) with no bad line; a probe comes every
  coast_every windows (acq_coast.h: round(1.5 s / window)), in the recorded windows, whole, with
  the probe's sample count, and its codes are those fed at its periods, current first and the
  channels in turn (the harness's record of each conversion's channel); the windows without a
  probe keep their whole bursts (the line keeps up);
* the drive (the harness's record of OCR1A, TCCR1A and PORTB at each period's end) is off in every
  period of the probe (OCR1A 0 in the cut period, the output disconnected and low after it) and
  back at the period after it, with OCR1A as before: how long it is off is printed;
* the probes written as <condition>.coast.csv (ripple_link.coast_file, through logs/coast.py's
  writer) read back with logs.coast.read, and the estimator's back-EMF (hpddo.ripple.coast.back_emf)
  reads each probe's back-EMF as fed, within a code of the voltage channel; `hpddo ripple --coast`
  (hpddo.ripple.coast.estimate) runs on the capture's three files;
* the stack's low-water mark stays above the static RAM; the flash and RAM of the build are printed.
"""
import argparse
import bisect
import pathlib
import random
import subprocess
import sys

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(HERE))
import numpy as np  # noqa: E402

from check_uno_ripple import expected_ocr1b, mv_for_code  # noqa: E402
from hpddo import bench  # noqa: E402
from hpddo.logs import coast as coast_file  # noqa: E402
from hpddo.logs import ripple as ripple_file  # noqa: E402
from hpddo.logs import ripple_link  # noqa: E402
from hpddo.logs.benchlog import read_log  # noqa: E402
from hpddo.ripple.coast import back_emf, estimate  # noqa: E402
from hpddo.ripple.options import CoastOptions, Options  # noqa: E402
from hpddo.studies.ripple_board import burst_n  # noqa: E402

HW = bench.HARDWARE
F_CPU = HW.cpu_hz
PROBE_US = 4000     # acq_coast.h kCoastProbeUs
PERIOD_MS = 1500    # acq_coast.h kCoastPeriodMs
COM1A1 = 0x80
PB1 = 0x02


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


def coast_samples(period):
    """acq_coast.h coast_samples."""
    pairs = (PROBE_US * (F_CPU // 1000000) // 2 + period // 2) // period
    return 4 if pairs < 2 else 2 * pairs


def coast_every(period, window_periods):
    """acq_coast.h coast_every_windows."""
    window = window_periods * period
    return max(2, min(65535, (PERIOD_MS * (F_CPU // 1000) + window // 2) // window))


def probe_feed(n, e0_V, i0_A, period_s):
    """A probe as the motor gives it, as pin mV per sample (current at even samples, voltage at odd
    ones): the current freewheels from i0 to zero within 0.6 ms (straight, as L di/dt = -(Vf + E)),
    the terminals read 0 V while it flows (the diode's -Vf, below the ADC's range), then the back-EMF
    e0 (1 - 5 t), the shaft slowing 2 % in 4 ms. Returns (mV, the back-EMF's function of t)."""
    t_off = 0.0006
    mv = []
    for k in range(n):
        t = k * period_s
        if k % 2 == 0:
            i = max(0.0, i0_A * (1 - t / t_off))
            mv.append(round(1000 * i * HW.shunt_ohm * HW.shunt_gain))
        else:
            v = e0_V * (1 - 5 * t) if t > t_off else 0.0
            mv.append(round(1000 * v / HW.divider_ratio))
    return mv, (lambda t: e0_V * (1 - 5 * t))


def t0_ok(e, windows, seqs):
    """Whether cycle e lies in the recorded windows."""
    return windows[seqs[0] - 1]["close"] <= e < windows[seqs[-1]]["close"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--harness", required=True)
    ap.add_argument("--elf", required=True, help="uno_acq built with -DACQ_RIPPLE_HZ=<hz> -DACQ_COAST=1")
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--hz", type=int, default=10000, help="the build's ACQ_RIPPLE_HZ")
    ap.add_argument("--rate", type=float, default=2.0, help="windows per second")
    ap.add_argument("--probes", type=int, default=3, help="probes to record")
    ap.add_argument("--duty", type=float, default=0.8)
    a = ap.parse_args()

    work = pathlib.Path(a.workdir)
    work.mkdir(parents=True, exist_ok=True)
    top = F_CPU // a.hz - 1
    period = top + 1
    win_periods = round(a.hz / a.rate)
    n_burst = burst_n(win_periods)
    n_probe = coast_samples(period)
    every = coast_every(period, win_periods)
    if not n_burst > n_probe:
        fail(f"no probe fits a window of {win_periods} periods (burst {n_burst}, probe {n_probe})")
    start = win_periods - n_burst
    # the recording begins at the window after `rec`; the probes' count starts at `rate` (configure)
    rows = every * a.probes + 1
    rng = random.Random(20261130)
    n_feed = 7
    feed, emf = [], []
    for w in range(n_feed):
        row = [mv_for_code(rng.randint(8, 400)) for _ in range(win_periods)]
        mv, e = probe_feed(n_probe, 6.0 + 0.9 * w, 0.5 + 0.1 * w, 1.0 / a.hz)
        row[start:start + n_probe] = mv
        feed.append(row)
        emf.append(e)
    (work / "feed.txt").write_text("".join(" ".join(str(v) for v in row) + "\n" for row in feed))
    long = read_log(ROOT / "data" / "default" / "long.csv").df
    part = long.iloc[int(0.8 * len(long)):].iloc[:13]
    drive = [(round(v, 4), round(i, 4), round(r, 3)) for v, i, r in zip(part["v_V"], part["i_A"], part["rpm_ref"])]
    (work / "drive.csv").write_text("".join(f"{v},{i},{r}\n" for v, i, r in drive))
    commands = [f"duty {a.duty:g}", f"pwm {a.hz}", f"rate {a.rate:g}", "rec coast"]
    cmd = [a.harness, a.elf, str(work / "drive.csv"), str(work), str(rows)] + commands
    print("UNO_SIM_RIPPLE=feed.txt", " ".join(cmd))
    env = {"UNO_SIM_RIPPLE": str(work / "feed.txt"), "PATH": "/usr/bin:/bin"}
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env)
    print(res.stdout.strip())
    if res.returncode != 0:
        fail(f"harness exit {res.returncode}: {res.stderr.strip()}")
    summary = [l for l in res.stdout.splitlines() if l.startswith("uno_sim ripple:") and " triggers, " in l][0]
    sp_room = int(summary.split("(")[1].split()[0])

    # ---- the stream
    host = (work / "host.txt").read_text()
    lines = host[:host.rfind("\n") + 1].splitlines()
    first = max(k for k, l in enumerate(lines) if l.startswith("# condition="))
    log_lines = [l for l in lines[first:] if not l.startswith(("!", "~"))]
    cap = work / "coast.csv"
    cap.write_text("\n".join(log_lines) + "\n")
    log = read_log(cap)
    df = log.df.iloc[:rows]
    meta = log.meta
    if int(meta["ripple_n"]) != n_burst:
        fail(f"metadata ripple_n={meta['ripple_n']}, want {n_burst}")
    asm = ripple_link.Assembler()
    chunk_lines = [(k + 1, l) for k, l in enumerate(lines[first:]) if l.startswith("~")]
    for no, l in chunk_lines:
        asm.feed(l, no)
    if asm.bad or asm.duplicates:
        fail(f"{asm.bad} bad chunk lines {asm.faults[:3]}, {asm.duplicates} duplicates")
    bursts, inc_b = asm.bursts()
    probes, inc_p = asm.probes()
    seqs = [int(s) for s in df["seq"]]
    if seqs != list(range(seqs[0], seqs[0] + len(seqs))):
        fail("seq has a gap: windows lost")
    rec = set(seqs)
    probes = [p for p in probes if p.seq in rec]
    print(f"log: {len(df)} rows, seq {seqs[0]}..{seqs[-1]}; {len(chunk_lines)} chunk lines; {len(probes)} whole "
          f"probes of {n_probe} samples (every {every} windows), {len(inc_p)} incomplete; "
          f"{sum(b.seq in rec for b in bursts)} whole bursts of {n_burst}, incomplete {inc_b}")
    if len(probes) < a.probes:
        fail(f"{len(probes)} probes in the recording, want {a.probes}")
    p_seqs = [p.seq for p in probes]
    if any(y - x != every for x, y in zip(p_seqs, p_seqs[1:])):
        fail(f"probes at seq {p_seqs}, not every {every} windows")
    missing = [s for s in seqs[:-1] if s not in p_seqs and s not in {b.seq for b in bursts}]
    if missing or [s for s in inc_b + inc_p if s in rec and s != seqs[-1]]:
        fail(f"windows without their whole burst or probe: {missing}, incomplete {inc_b + inc_p}")

    # ---- windows, triggers, the drive
    windows = {}
    for k, l in enumerate((work / "windows.csv").read_text().splitlines()[1:]):
        s, close, vmv, imv, rpm, edges = l.split(",")
        windows[int(s)] = dict(close=int(close), i_mV=int(imv), index=k)
    trig = []
    for l in (work / "ripple_triggers.csv").read_text().splitlines()[1:]:
        k, t, ps, started, mv, code, o1a, o1b, ch = (int(x) for x in l.split(","))
        trig.append(dict(t=t, ps=ps, started=started, code=code, ocr1a=o1a, ch=ch))
    pwm = [tuple(int(x) for x in l.split(",")) for l in (work / "ripple_pwm.csv").read_text().splitlines()[1:]]
    pwm_cycles = np.array([r[0] for r in pwm])
    off_us, on_ocr = [], set()
    for p in probes:
        w_open, w_close = windows[p.seq - 1]["close"], windows[p.seq]["close"]
        in_win = [t for t in trig if w_open <= t["t"] < w_close and t["started"] == 1]
        taken = [t for t in in_win if round((t["ps"] - w_open) / period) in range(start, start + n_probe)]
        if len(taken) != n_probe:
            fail(f"seq {p.seq}: {len(taken)} conversions in the probe's periods, want {n_probe}")
        chans = [t["ch"] for t in taken]
        if chans != [1, 0] * (n_probe // 2):
            fail(f"seq {p.seq}: channels {chans[:8]}..., want the current (1) and the voltage (0) in turn")
        if p.start_period != start or p.codes.tolist() != [t["code"] for t in taken]:
            fail(f"seq {p.seq}: the probe's codes or first period ({p.start_period}) differ from those converted")
        fed = [v * 1023 // 5000 for v in feed[windows[p.seq]["index"] % n_feed][start:start + n_probe]]
        if p.codes.tolist() != fed:
            fail(f"seq {p.seq}: the probe's codes are not those fed at its periods")
        # the drive per period k of the window: the state at the period's end (TOV1), OCR1A from
        # the end of the period before (double-buffered)
        ends = [r for r in pwm if w_open < r[0] <= w_close + period // 2]
        state = {}
        for j, r in enumerate(ends[1:], start=1):
            k = round((r[0] - w_open) / period) - 1
            ocr_in_force = ends[j - 1][1]
            com = r[2] & COM1A1
            on = (ocr_in_force + 1) if com else (period if r[3] & PB1 else 0)
            state[k] = on
        before = state.get(start - 1)
        off = [k for k in range(start - 1, start + n_probe + 2) if state.get(k, 1) <= 1]
        if off != list(range(start, start + n_probe)):
            fail(f"seq {p.seq}: the drive is off in the window's periods {off}, want {start}..{start + n_probe - 1}")
        after = state.get(start + n_probe)
        if after != before:
            fail(f"seq {p.seq}: on-time {after} cycles after the probe, {before} before")
        on_ocr.add(before)
        off_us.append(1e6 * (n_probe * period + period - before) / F_CPU)
    print(f"drive: off in the {n_probe} periods of each of the {len(probes)} probes (the cut period's on-time one "
          f"cycle at its start, the output disconnected and low from its interrupt on), back at the next with the "
          f"same on-time ({sorted(on_ocr)} cycles); held off {min(off_us):.2f} us from the last on-time's end to "
          f"the drive's return ({n_probe} periods of {1e6 * period / F_CPU:g} us and the last driven period's "
          f"off-time)")

    # ---- the ADC interrupt in the probes: the channel's toggle added, each ends before the next trigger
    isr = [tuple(int(x) for x in l.split(",")) for l in (work / "adc_isr.csv").read_text().splitlines()[1:]]
    spans = [(windows[p.seq - 1]["close"] + start * period, windows[p.seq - 1]["close"] + (start + n_probe) * period)
             for p in probes]
    in_probe = sorted((e, c) for e, c, tr in isr if tr and any(x <= e < y for x, y in spans))
    trig_t = sorted(t["t"] for t in trig)
    late = sum(1 for e, c in in_probe if bisect.bisect_right(trig_t, e) < len(trig_t)
               and e + c > trig_t[bisect.bisect_right(trig_t, e)])
    cyc = sorted(c for _, c in in_probe)
    print(f"ADC interrupt in the probes: median {cyc[len(cyc) // 2]} cycles, max {cyc[-1]}, {len(cyc)} interrupts, "
          f"{late} held past the next trigger")
    if late:
        fail(f"{late} ADC interrupts of a probe ended after the next trigger (its channel would be the wrong one)")

    # ---- Timer1's overflow interrupt (the window close and the probe's cut and restore are in it)
    ovf = [tuple(int(x) for x in l.split(",")) for l in (work / "ovf_isr.csv").read_text().splitlines()[1:]]
    marks = {}
    for x, _ in spans:
        marks[x - period] = "OCR1A 0"   # the period before the cut
        marks[x] = "cut"
    for x, y in spans:
        marks[y - period] = "restore"
    by_kind = {}
    for e, c in ovf:
        if not t0_ok(e, windows, seqs):
            continue
        k = round(min(marks, key=lambda m: abs(m - e)) if marks else 0)
        kind = marks[k] if abs(k - e) < period // 2 else "other"
        by_kind.setdefault(kind, []).append(c)
    print("Timer1 overflow interrupt: " + "; ".join(
        f"{kind} median {sorted(c)[len(c) // 2]} max {max(c)} cycles ({len(c)})" for kind, c in sorted(by_kind.items())))

    # ---- the coast file and the estimator's back-EMF
    t_start = {int(r.seq): float(r.t_s) for r in df.itertuples()}
    path, kept = ripple_link.coast_file(work / "coast.coast.csv", probes, meta, t_start)
    back = coast_file.read(path)
    if len(back) != kept or kept != len(probes):
        fail(f"{path}: {len(back)} probes read back, want {len(probes)}")
    _, sh, _ = expected_ocr1b(top, a.duty)
    lsb_v = back.v_per_code
    worst = 0.0
    for j, p in enumerate(probes):
        t_want = t_start[p.seq] + (start * period + p.phase_cycles) / F_CPU
        if abs(back.t_s[j] - t_want) > 1e-9 or len(back.i_codes[j]) != n_probe // 2:
            fail(f"probe {j}: t_s {back.t_s[j]} (want {t_want}), {len(back.i_codes[j])} current samples")
        ti, ia = back.current(j)
        tv, vv = back.voltage(j)
        i_before = float(df["i_A"].iloc[seqs.index(p.seq) - 1])
        e, e_sd, t_a, why = back_emf(ti, ia, tv, vv, i_before, CoastOptions())
        if why:
            fail(f"probe {j} (seq {p.seq}): the estimator refuses it: {why}")
        # the back-EMF fed, in the host's volts: simavr's ADC scale is mV 1023 / 5000 (avr_adc.c), the
        # chip's and the host's 1024 (0.1 % apart), and its codes are truncated (half a code low on average)
        want = emf[windows[p.seq]["index"] % n_feed](t_a) / HW.divider_ratio * 1023 / 5000 * 1000 * lsb_v
        # truncation: the codes read half a code low on average; the quadratic's extrapolation back to t_a
        # carries the codes' rounding as the fit's stated uncertainty e_sd
        err = e - (want - 0.5 * lsb_v)
        worst = max(worst, abs(err) / lsb_v)
        if abs(err) > 0.5 * lsb_v + 3 * e_sd:
            fail(f"probe {j} (seq {p.seq}): back-EMF {e:.4f} V (sd {1e3 * e_sd:.2f} mV) at t_a {1e3 * t_a:.3f} ms, "
                 f"fed {want:.4f} V less half a code")
    print(f"{path.name}: {kept} probes, sample_hz {back.sample_hz:g}, a_per_code {back.a_per_code:g}, v_per_code "
          f"{lsb_v:g}; {n_probe // 2} current and {n_probe // 2} voltage samples a probe; the estimator's back-EMF "
          f"within {worst:.2f} codes of the one fed less the truncation's half code (a code {1e3 * lsb_v:.2f} mV, "
          f"simavr's scale)")
    # the three files of a capture, as `hpddo capture` writes them, through `hpddo ripple --coast`'s estimator
    ripple_link.bursts_file(work / "coast.ripple.csv", bursts, meta, t_start)
    opts = Options(ripples_per_rev=HW.ripples_per_rev, gear_ratio=HW.gear_ratio)
    out = estimate(read_log(cap).df, ripple_file.read(work / "coast.ripple.csv"), back, opts, 4.5, 0.35)
    if out.table is None or len(out.table) != kept or not np.isfinite(out.table["e_V"]).all():
        fail(f"the estimator on the capture: {out.statement or out.table}")
    print(f"estimate on the capture: {len(out.table)} probes, back-EMF {', '.join(f'{e:.3f}' for e in out.table['e_V'])}"
          f" V; reasons: {sorted(set(out.table['reason']))} (the simulated rows' speed is not a motor's)")

    # ---- line, stack, flash
    t0, t1 = windows[seqs[0] - 1]["close"], windows[seqs[-1]]["close"]
    sim_s = (t1 - t0) / F_CPU
    coast_chars = sum(len(l) + 1 for _, l in chunk_lines if ripple_link.decode_line(l).coast)
    all_chars = sum(len(l) + 1 for l in lines[first:])
    print(f"line: a probe's chunks {coast_chars / max(1, len(probes) + len(inc_p)):.0f} characters; all lines "
          f"{all_chars / sim_s:.0f}/s of {500000 // 10}/s at 500000 baud")
    print(f"stack: low-water mark {sp_room} bytes above the static RAM")
    if sp_room < 64:
        fail("the stack came within 64 bytes of the static RAM")
    size = pathlib.Path(a.elf).with_name("uno_acq.size")
    if size.exists():
        flash, flash_max, ram, ram_max = (int(x) for x in size.read_text().split())
        print(f"build: flash {flash} of {flash_max} bytes ({flash_max - flash} left), RAM {ram} of {ram_max} "
              f"({ram_max - ram} left before the stack)")
    print("PASS")


if __name__ == "__main__":
    main()
