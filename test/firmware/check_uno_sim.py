#!/usr/bin/env python3
"""Runs uno_acq in simavr on a synthetic bench and checks what it sends.

A short drive table (V, I, speed; fixed seed) is played into the simulated
board, one row per sample window, through the divider and shunt gains and an
encoder in quadrature. Then:

* the host stream, without its "!" reply lines, is a valid bench log
  (tools/hpddo/benchlog.read_log) at the requested rate;
* every row's v_V and i_A equal the driven means within one ADC step;
* every row's rpm_ref equals the encoder counts driven in its window within
  one count (an edge at the very close), and the driven speed within two (one of quantisation, one at the close);
* seq has no gap, t_s follows seq, the row count is right;
* the window closes are periodic within --max-jitter-us;
* the ESP8266 link bytes decode with hpddo::FrameDecoder with no CRC error or
  dropped byte, one frame per window, each matching its log row;
* with --protocol sweep/load: duty and load follow the bench's protocol
  (tools/hpddo/bench.py, from which the firmware's bench_gen.h is generated);
* with --observer fixed/float (the firmware runs the observer, issue 14): every row
  carries rpm_est and est_status, equal to the reference observer
  (tools/hpddo/model/observer_ref.py; the fixed-point network from tools/hpddo/model/quant.py) run
  on the window's exact ADC means within --max-est-diff RPM, with the same status.
"""
import argparse
import math
import pathlib
import random
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
from hpddo import bench  # noqa: E402
from hpddo.logs.benchlog import read_log  # noqa: E402

# The bench's values, from the one description the firmware's bench_gen.h is
# generated from (uno_sim.c includes that header).
HW = bench.HARDWARE
RATIO = HW.divider_ratio
SHUNT_OHM = HW.shunt_ohm * HW.shunt_gain
ADC_REF_V = HW.adc_ref_V
CPR = HW.counts_per_output_rev
F_CPU = HW.cpu_hz


def window_cycles(pwm_hz, rate_hz):
    """CPU cycles of a sample window as the firmware sets it (acq_window.h): whole
    Timer1 periods of the PWM nearest to 1 / rate."""
    ticks, pre = (F_CPU + pwm_hz // 2) // pwm_hz, 1
    if ticks > 65536:
        ticks, pre = (F_CPU // 8 + pwm_hz // 2) // pwm_hz, 8
    period = ticks * pre
    return max(1, int(F_CPU / (rate_hz * period) + 0.5)) * period


def plan(protocol, hold_samples):
    """(duty, load) of each row of a protocol with steps of hold_samples."""
    segs = bench.PROTOCOLS[protocol].segments
    return [(g.duty, g.load) for g in segs for _ in range(hold_samples)]


def drive_table(n, seed):
    rng = random.Random(seed)
    rows = []
    for k in range(n):
        duty = rng.choice([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
        v = round(duty * 12.0 + rng.uniform(0.0, 0.5), 4)  # V, pin below 4.3 V
        i = round(rng.uniform(0.0, 2.0), 4)                   # A, pin below 1 V
        rpm = round(rng.uniform(-30.0, 320.0), 3) if k % 7 else 0.0
        rows.append((v, i, rpm))
    return rows


def check_estimates(df, windows, a, lsb_v, lsb_i, period):
    """The board's rpm_est and est_status against the reference observer on the exact
    inputs of each window, every row. The board resets its observer when the recording begins and
    steps it on every window it processes from then on: the window open at the command (the one
    before the first row) and, when one had closed and waited while the command was read, the one
    before that. The reference runs from each of these starts and the board must follow one of them
    on every row (with the dynamic family, whose state remembers, the start shows for seconds)."""
    import numpy as np
    from hpddo.model import export, quant
    from hpddo.model.observer_ref import ReferenceObserver
    if "rpm_est" not in df or "est_status" not in df:
        fail("no rpm_est / est_status columns: the firmware does not run the observer")
    model = export.read_model_header((pathlib.Path(a.model_dir) / "model_default.h").read_text())
    seq0 = int(df["seq"].iloc[0])

    def reference(start):
        obs = quant.fixed_observer(model, quant.quantise(model)) if a.observer == "fixed" else ReferenceObserver(model)
        out = {}
        for s in range(start, int(df["seq"].iloc[-1]) + 1):
            w = windows[s]
            v = (w["v_mV"] * 1023 // 5000 + 0.5) * lsb_v
            i = (w["i_mV"] * 1023 // 5000 + 0.5) * lsb_i
            out[s] = obs.step(v, i, None, period, s & 0xFFFF)
        return out

    best = None
    for start in (seq0 - 1, seq0 - 2):
        if start not in windows:
            continue
        ref = reference(start)
        worst, bad, statuses = 0.0, None, {}
        for row in df.itertuples():
            o = ref[int(row.seq)]
            if not np.isfinite(row.rpm_est):
                fail(f"seq {row.seq}: rpm_est is not a number")
            d = abs(row.rpm_est - float(o["rpm"]))
            worst = max(worst, d)
            if bad is None and (d > a.max_est_diff or int(row.est_status) != int(o["status"])):
                bad = (f"seq {row.seq}: board estimate {row.rpm_est} status {row.est_status}, reference "
                       f"{float(o['rpm']):.3f} status {o['status']} (the observer started at window {start})")
            statuses[int(row.est_status)] = statuses.get(int(row.est_status), 0) + 1
        if best is None or (bad is None) > (best[2] is None) or ((bad is None) == (best[2] is None) and worst < best[1]):
            best = (start, worst, bad, statuses)
    if best is None:
        fail(f"no window before the first row (seq {seq0}) in the simulation")
    start, worst, bad, statuses = best
    if bad is not None:
        fail(bad)
    family = " with the dynamic family" if model.dynamics_named else ""
    print(f"observer ({a.observer}{family}) on the board: {len(df)} estimates within {worst:.4f} RPM of the "
          f"reference started at window {start} (first row {seq0}; printed with 2 decimals), statuses {statuses}")


def recording_table(n):
    """n rows (V, I, speed) of the test part of data/default/long.csv: operating points
    the default model was trained around, so that its network runs on the board."""
    from hpddo.logs.benchlog import read_log as _read
    df = _read(ROOT / "data" / "default" / "long.csv").df
    part = df.iloc[int(0.8 * len(df)):].iloc[:n]
    return [(round(v, 4), round(i, 4), round(r, 3)) for v, i, r in zip(part["v_V"], part["i_A"], part["rpm_ref"])]


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--harness", required=True)
    ap.add_argument("--elf", required=True)
    ap.add_argument("--frame-dump", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--rate", type=float, default=2.0)
    ap.add_argument("--pwm", type=int, default=None, help="PWM Hz (default: the bench's)")
    ap.add_argument("--rows", type=int, default=6)
    ap.add_argument("--protocol", choices=["sweep", "load"], default=None)
    ap.add_argument("--hold", type=float, default=0.05, help="protocol step, s")
    ap.add_argument("--max-jitter-us", type=float, default=10.0)
    ap.add_argument("--observer", choices=["fixed", "float", "none"], default="fixed",
                    help="which observer the firmware runs (default fixed: model_default_q.h)")
    ap.add_argument("--max-est-diff", type=float, default=0.05, help="RPM, board against reference")
    ap.add_argument("--model-dir", default=str(ROOT / "models" / "default"),
                    help="the folder of the model the firmware was built with (build_uno.sh's ACQ_MODEL_DIR)")
    ap.add_argument("--drive", choices=["random", "recording"], default="random",
                    help="drive table: random points (default) or the test rows of data/default/long.csv")
    a = ap.parse_args()

    work = pathlib.Path(a.workdir)
    work.mkdir(parents=True, exist_ok=True)
    table = drive_table(37, seed=20261121) if a.drive == "random" else recording_table(400)
    (work / "drive.csv").write_text("".join(f"{v},{i},{r}\n" for v, i, r in table))

    pwm_hz = a.pwm or HW.pwm_hz_whole
    commands = [] if a.pwm is None else [f"pwm {a.pwm}"]
    commands += [] if a.rate == HW.sample_rate_hz else [f"rate {a.rate:g}"]
    rows_wanted = a.rows
    if a.protocol:
        commands += [f"hold {a.hold:g}", f"run {a.protocol}"]
        hold_samples = max(1, round(a.hold * a.rate))
        rows_wanted = len(plan(a.protocol, hold_samples))
    else:
        commands += ["rec sim"]
    cmd = [a.harness, a.elf, str(work / "drive.csv"), str(work), str(rows_wanted)] + commands
    print(" ".join(cmd))
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    print(res.stdout.strip())
    if res.returncode != 0:
        fail(f"harness exit {res.returncode}: {res.stderr.strip()}")

    # ---- host stream -> bench log
    host = (work / "host.txt").read_text()
    # The run stops 50 ms after the last wanted row, possibly in the middle of
    # a later line: keep complete lines only.
    lines = host[:host.rfind("\n") + 1].splitlines()
    start = max(k for k, l in enumerate(lines) if l.startswith("# condition="))
    log_lines = [l for l in lines[start:] if not l.startswith("!")]
    (work / "capture.csv").write_text("\n".join(log_lines) + "\n")
    log = read_log(work / "capture.csv")
    df = log.df
    # The window is whole PWM periods; its length in whole us sets the rate reported.
    period_us = window_cycles(pwm_hz, a.rate) // (F_CPU // 1_000_000)
    actual_rate = 1e6 / period_us
    if abs(log.sample_rate_hz - actual_rate) > 1e-4:
        fail(f"sample_rate_hz {log.sample_rate_hz} != {actual_rate} (PWM {pwm_hz} Hz, rate {a.rate})")
    if (len(df) != rows_wanted) if a.protocol else (len(df) < rows_wanted):
        fail(f"{len(df)} rows, want {rows_wanted}")
    seq = df["seq"].to_numpy()
    if any(seq[1:] - seq[:-1] != 1):
        fail("seq has a gap: samples lost")
    period = period_us * 1e-6
    t_err = max(abs(t - (s - seq[0]) * period) for t, s in zip(df["t_s"], seq))
    if t_err > 1e-6:
        fail(f"t_s does not follow seq (error {t_err})")
    print(f"log: {len(df)} rows, seq {seq[0]}..{seq[-1]}, no gap, condition={log.condition}")

    # ---- rows against what was driven
    windows = {}
    wl = (work / "windows.csv").read_text().splitlines()
    for l in wl[1:]:
        s, close, vmv, imv, rpm, edges = l.split(",")
        windows[int(s)] = dict(close=int(close), v_mV=int(vmv), i_mV=int(imv), rpm=float(rpm), edges=int(edges))
    lsb_v = ADC_REF_V / 1024 * RATIO
    lsb_i = ADC_REF_V / 1024 / SHUNT_OHM
    count_rpm = 60.0 / (CPR * period)
    worst_v = worst_i = worst_rpm = 0.0
    for row in df.itertuples():
        w = windows.get(int(row.seq))
        if w is None:
            fail(f"seq {row.seq}: no such window in the simulation")
        v_drv = w["v_mV"] / 1000 * RATIO
        i_drv = w["i_mV"] / 1000 / SHUNT_OHM
        # simavr converts code = floor(mV * 1023 / Vref); the firmware reports (code + 0.5) LSB.
        for got, mv, lsb, name in ((row.v_V, w["v_mV"], lsb_v, "v_V"), (row.i_A, w["i_mV"], lsb_i, "i_A")):
            exact = (mv * 1023 // 5000 + 0.5) * lsb
            if abs(got - exact) > 6e-5:
                fail(f"seq {row.seq}: {name} {got} is not the mean of the codes driven ({exact:.6f})")
        rpm_counts = w["edges"] / CPR * 60.0 / period
        worst_v = max(worst_v, abs(row.v_V - v_drv) / lsb_v)
        worst_i = max(worst_i, abs(row.i_A - i_drv) / lsb_i)
        # An edge within the close interrupt's first cycles may fall on either side.
        if abs(row.rpm_ref - rpm_counts) > count_rpm + 1e-2:
            fail(f"seq {row.seq}: rpm_ref {row.rpm_ref} != {rpm_counts} from the counts driven")
        worst_rpm = max(worst_rpm, abs(row.rpm_ref - w["rpm"]) / count_rpm)
    print(f"V error <= {worst_v:.3f} LSB, I error <= {worst_i:.3f} LSB, speed error <= {worst_rpm:.3f} counts")
    if a.observer != "none":
        check_estimates(df, windows, a, lsb_v, lsb_i, period)
    if worst_v > 1.0 + 0.001 * 4.3 / (ADC_REF_V / 1024) or worst_i > 1.0:  # plus simavr's 1023/1024 scale
        fail("V or I off by more than one ADC step")
    if worst_rpm > 2.0 + 1e-6:
        fail("encoder speed off by more than one count")

    # ---- sample period jitter over the recorded windows
    closes = [windows[s]["close"] for s in range(int(seq[0]) - 1, int(seq[-1]) + 1) if s in windows]
    nominal = window_cycles(pwm_hz, a.rate)
    dev = [abs((b - a_) - nominal) / 16.0 for a_, b in zip(closes, closes[1:])]
    jitter = max(dev)
    print(f"sample period {period * 1e6:.0f} us over {len(dev)} windows: jitter max {jitter:.3f} us")
    if jitter > a.max_jitter_us:
        fail(f"period jitter {jitter:.3f} us > {a.max_jitter_us} us")

    # ---- the main loop's work per window (busy.csv: GPIOR1 markers in uno_acq.cpp)
    busy = (work / "busy.csv").read_text().splitlines()[1:]
    for kind in ("window", "observer"):
        c = sorted(int(l.split(",")[2]) for l in busy if l.startswith(kind + ","))
        if c:
            print(f"main loop, {kind}: median {c[len(c) // 2]} max {c[-1]} cycles of the {nominal}-cycle window "
                  f"({100.0 * c[-1] / nominal:.1f} % at most), {len(c)} windows")
            if kind == "window" and c[-1] >= nominal:
                fail("the work on a window takes longer than the window")

    # ---- the figures over the recorded windows (hpddo bench --observer reads this line): the
    # main loop's work on each (it starts after the window's close) and the ADC interrupt's
    # share of the CPU (adc_isr.csv: nested interrupts included)
    t0, t1 = windows[int(seq[0]) - 1]["close"], windows[int(seq[-1])]["close"]
    rec = {kind: sorted(int(l.split(",")[2]) for l in busy if l.startswith(kind + ",")
                        and windows[int(seq[0])]["close"] <= int(l.split(",")[1]) < t1 + nominal)
           for kind in ("window", "observer")}
    rec = {k: v for k, v in rec.items() if v}
    isr = [tuple(int(x) for x in l.split(",")) for l in (work / "adc_isr.csv").read_text().splitlines()[1:]]
    adc = sum(c for e, c, _ in isr if t0 <= e < t1)
    print(f"ADC interrupt: {sum(1 for e, _, _ in isr if t0 <= e < t1)} interrupts over the {len(df)} recorded windows, "
          f"{100.0 * adc / (t1 - t0):.1f} % of the CPU ({adc} of {t1 - t0} cycles)")
    if "window" in rec:
        fig = (f"figures: adc_share_pct={100.0 * adc / (t1 - t0):.2f} loop_median={rec['window'][len(rec['window']) // 2]} "
               f"loop_max={rec['window'][-1]} window_cycles={nominal}")
        if "observer" in rec:
            fig += f" obs_median={rec['observer'][len(rec['observer']) // 2]} obs_max={rec['observer'][-1]}"
        print(fig)

    # ---- ESP8266 link frames
    out = subprocess.run([a.frame_dump, str(work / "link.bin")], capture_output=True, text=True, check=True).stdout
    flines = out.strip().splitlines()
    summary = dict(kv.split("=") for kv in flines[-1][2:].split())
    frames = {}
    for l in flines[1:-1]:
        f = [int(x) for x in l.split(",")]
        frames[f[0]] = f
    print(f"link: {summary}")
    if int(summary["crc_errors"]) or int(summary["dropped_bytes"]):
        fail("link frames with CRC errors or dropped bytes")
    fseq = sorted(frames)
    if fseq != list(range(fseq[0], fseq[0] + len(fseq))):
        fail("link frames have a seq gap")
    for row in df.itertuples():
        f = frames.get(int(row.seq) & 0xFFFF)
        if f is None:
            fail(f"no frame for seq {row.seq}")
        _, flags, duty, v_mV, i_mA, temp, rpm_x10, _ = f
        if (abs(v_mV - row.v_V * 1000) > 1 or abs(i_mA - row.i_A * 1000) > 1 or
                abs(rpm_x10 - row.rpm_ref * 10) > 1 or f[7] != period_us or
                abs(duty - row.duty * 255) > 0.51):
            fail(f"frame {f} does not match row {row}")
    print(f"link: {len(frames)} frames, all CRCs valid, each recorded row matches its frame")

    # ---- protocol
    if a.protocol:
        hold_samples = max(1, round(a.hold * a.rate))
        for k, (row, (want_duty, want_load)) in enumerate(zip(df.itertuples(), plan(a.protocol, hold_samples))):
            if abs(row.duty - want_duty) > 1e-9 or row.load != want_load:
                fail(f"row {k}: duty {row.duty} load {row.load}, want {want_duty} {want_load}")
        if not any(l.startswith(f"! end {a.protocol}") for l in lines):
            fail("no end line after the protocol")
        print(f"protocol {a.protocol}: {len(df)} rows follow the plan, then '! end'")
    print("PASS")


if __name__ == "__main__":
    main()
