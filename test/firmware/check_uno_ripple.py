#!/usr/bin/env python3
"""Runs uno_acq's ripple build (-DACQ_RIPPLE_HZ) in simavr and checks the ripple mode
(issue 23, item 2; docs/ripple-board.md, "The UNO's ripple mode"; with --count, docs/ripple-board-count.md,
"The ripple counter on the board").

The harness (uno_sim.c with uno_sim_ripple.h) feeds the current channel one value per
triggered conversion from a feed file (one line per window), plays V, I and speed per
window as in check_uno_sim.py, and records each Timer1 compare B match (the trigger), its
period's start, whether the ADC started, and every ADC interrupt. Then:

* the host stream's "~" lines decode (hpddo.logs.ripple_link) with no bad line and give one
  whole burst per recorded window, of ripple_n codes, equal to the codes fed to the first
  ripple_n triggers of that window: no sample lost, duplicated or out of order;
* the trigger comes once per PWM period (sample rate from the cycle counts), every compare
  match with the trigger armed started a conversion, OCR1B is the middle of the on-time
  for the duty less the sample-and-hold delay (acq_ripple.h), and the phase from the
  period's start is OCR1B + 1 cycles within simavr's instruction granularity (the chip's
  hardware trigger has none);
* each triggered conversion's interrupt ends before the next trigger; its cycles and the
  CPU share of the ADC interrupt are printed, and the bytes/s of the bursts against the
  line (500000 baud);
* the log rows' V and I are the means of the free-running conversions the board read in each
  window (ripple_reads.csv), each the driven value (free_running_means says the one exception);
* no window lost (the rows' seq without a gap), the main loop's work on every recorded window
  within the window (printed, with the ADC interrupt's share, as a "figures:" line that hpddo
  bench --observer reads); with --frame-dump, every recorded row's frame on the ESP8266 link,
  no CRC error and no dropped byte (the harness fails on a framing error);
* the bursts written as <condition>.ripple.csv (ripple_link.bursts_file) read back with
  hpddo.logs.ripple.read;
* the stack's low-water mark stays above the static RAM (printed).

With --count (uno_acq built with -DACQ_RIPPLE_COUNT=1, item 5: the bursts counted on the
board, not sent), every row's rpm_rip, ra_ohm and tw_C must equal the host's reference
(hpddo.ripple.board.track: the same integer counter, the same Ra tracker) run on the
codes fed and the window's V and I, and the count, Ra and winding temperature are compared
with the twin's truth. Without --twin it makes one (`hpddo twin --protocol load`).

With --twin LOG (a twin bench log with its <condition>.ripple.csv, `hpddo twin --ripple-hz
10000`), the board is driven with the twin's V, I and speed and fed the twin's current codes,
and the speed from the board's bursts (hpddo.ripple, as `hpddo ripple`) is compared with
the twin's encoder and with the speed from the twin's own whole-window bursts.
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
from hpddo.logs import ripple as ripple_file  # noqa: E402
from hpddo.logs import ripple_link  # noqa: E402
from hpddo.logs.benchlog import read_log  # noqa: E402

HW = bench.HARDWARE
F_CPU = HW.cpu_hz
RATIO = HW.divider_ratio
SHUNT_OHM = HW.shunt_ohm * HW.shunt_gain
ADC_REF_V = HW.adc_ref_V
BAUD = 500000  # acq_ripple.h, kRippleHostBaud


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


MEASURE = []  # --measure: the budget faults seen (lost windows, a window's work over its length)


def fail_or_note(msg):
    """A fault of the CPU budget: fails, or with --measure is noted and the figures go on."""
    if MEASURE_MODE:
        print("NOT A PASS:", msg)
        MEASURE.append(msg)
    else:
        fail(msg)


MEASURE_MODE = False


def mv_for_code(code):
    """The pin mV that simavr converts to code (code = mV * 1023 // 5000)."""
    mv = -(-code * 5000 // 1023)
    assert mv * 1023 // 5000 == code
    return mv


def expected_ocr1b(top, duty):
    """acq_ripple.h ripple_trigger with acq_window.h pwm_compare, for the ripple timing at top."""
    duty_q = round(duty * 10000)
    ocr1a = ((top + 1) * duty_q + 5000) // 10000
    on = top + 1 if duty_q in (0, 10000) or duty_q >= 10000 else ocr1a + 1
    period = top + 1
    adps = 6
    while adps > 2 and 27 * (1 << adps) // 2 > period * 3 // 10:
        adps -= 1
    sh = 2 * (1 << adps) + 3
    mid = on // 2
    return (mid - sh if mid > sh else 0), sh, adps


def compare_with_twin(a, twin, path, df, windows):
    """The ripple speed from the board's bursts against the twin's encoder and against the
    speed from the twin's own whole-window bursts (the same estimator, hpddo.ripple)."""
    import numpy as np
    from hpddo.ripple.log import speed_of_log
    from hpddo.ripple.options import Options
    opts = Options(ripples_per_rev=bench.HARDWARE.ripples_per_rev, gear_ratio=bench.HARDWARE.gear_ratio)
    ra = float(twin.meta["ra_ohm"])
    board, _, _ = speed_of_log(path.with_name("ripple.csv"), df, {"ra_ohm": ra}, opts)
    own, _, _ = speed_of_log(a.twin, twin.df, twin.meta, opts)
    idx = [windows[int(s)]["index"] % len(twin.df) for s in df["seq"]]
    enc = twin.df["rpm_ref"].to_numpy()[idx]
    own_rpm = own.set_index("row")["rpm"].reindex(idx).to_numpy()
    own_conf = own.set_index("row")["confident"].reindex(idx).to_numpy()
    b = board.set_index("row")
    rpm = b["rpm"].reindex(range(len(df))).to_numpy()
    conf = b["confident"].reindex(range(len(df))).fillna(False).to_numpy(bool)
    ok = conf & (enc > 0)
    e_enc = (rpm[ok] - enc[ok]) / enc[ok]
    both = ok & own_conf.astype(bool)
    e_own = (rpm[both] - own_rpm[both]) / own_rpm[both]
    e_twin_enc = (own_rpm[both] - enc[both]) / enc[both]
    rms = lambda e: 100 * np.sqrt(np.mean(e ** 2))  # noqa: E731
    med = lambda e: 100 * np.median(np.abs(e))  # noqa: E731
    print(f"twin {a.twin.name}: {len(df)} windows through the board, {int(conf.sum())} confident ripple speeds "
          f"(from the twin's own whole-window bursts: {int(np.nansum(own_conf.astype(float)))})")
    print(f"  against the encoder: the board's bursts RMS {rms(e_enc):.3f} %, median |error| {med(e_enc):.3f} %, "
          f"max {100 * np.max(np.abs(e_enc)):.2f} %; the twin's own bursts RMS {rms(e_twin_enc):.3f} %, median "
          f"{med(e_twin_enc):.3f} %, max {100 * np.max(np.abs(e_twin_enc)):.2f} % (encoder glitches included)")
    print(f"  the board's against the twin's own: RMS {rms(e_own):.3f} %, max {100 * np.max(np.abs(e_own)):.2f} % "
          f"({int(both.sum())} windows)")


def free_running_means(work, windows, df, lsb_v, lsb_i):
    """Each row's V and I against the free-running conversions the board read in its window.

    The harness records every read of the ADC's result (ripple_reads.csv: cycle, code, ADMUX's
    channel bit, ADATE). The firmware reads it in an atomic section with the window's bank, so a
    read belongs to the window open at its cycle (between two closes), and every read with
    ADATE clear goes into that window's V or I sum (the free-running ones and the last one
    before the arm); the triggered ones (ADATE set) do not. Each V code must be the window's
    driven V (simavr converts A0 when the result is read) and each I code the window's driven
    current, except that the window's first I conversion, when it began before the close,
    holds the previous window's current: the chip samples at the conversion's start (the
    sample-and-hold) and the harness feeds A1 there, while the firmware counts a conversion in
    the window in which its result is read (uno_acq.cpp, the ADC interrupt), as in the normal
    mode. After a burst the conversion in flight at the close is a V one (the burst's last
    triggered conversion restarts the free-running ones with V, just before the close), so this
    happens only where the window before had no burst: the first recorded window after `rate`
    (seq 3 at 100 Hz, whose I mean then holds 1 of its 16 codes from the window before: 0.9271
    A, not the 0.9131 driven; not a firmware fault, a one-conversion shift of the means that
    the normal mode has at every close too). So a twin feed whose current changes from window to window is
    checked exactly, and a code that is neither (a triggered code in the means) fails.
    Returns {seq: (v_V, i_A)}, the means the rows must hold (and that check_count's reference
    takes)."""
    import bisect
    closes = sorted((w["close"], s) for s, w in windows.items())
    close_cycles = [c for c, _ in closes]
    per = {}
    for line in (work / "ripple_reads.csv").read_text().splitlines()[1:]:
        cyc, code, ch, adate = (int(x) for x in line.split(","))
        k = bisect.bisect_right(close_cycles, cyc)
        if adate or k == 0 or k >= len(closes):
            continue
        per.setdefault(closes[k][1], []).append((cyc, code, ch))  # the window closed by closes[k]
    code_of = lambda mv: mv * 1023 // 5000  # noqa: E731 (simavr's scale, avr_adc.c)
    out, carried = {}, 0
    for row in df.itertuples():
        s = int(row.seq)
        reads = per.get(s, [])
        w, prev = windows[s], windows.get(s - 1)
        if prev is None:
            fail(f"seq {s}: the window's start is not in the simulation")
        vs = [c for _, c, ch in reads if ch == 0]
        i_reads = [(cyc, c) for cyc, c, ch in reads if ch == 1]
        if not vs or not i_reads:
            fail(f"seq {s}: {len(vs)} V and {len(i_reads)} I conversions read in the window")
        if any(c != code_of(w["v_mV"]) for c in vs):
            fail(f"seq {s}: V codes {sorted(set(vs))}, driven {code_of(w['v_mV'])}")
        for k, (cyc, c) in enumerate(i_reads):
            if c == code_of(w["i_mV"]):
                continue
            began_before = cyc - prev["close"] < 2 * 13 * 128  # read within two free-running conversions
            if k == 0 and began_before and c == code_of(prev["i_mV"]):
                carried += 1
                continue
            fail(f"seq {s}: I code {c} read at cycle {cyc} ({cyc - prev['close']} after the window's start) is "
                 f"neither the window's driven {code_of(w['i_mV'])} nor, for its first conversion, the one before's")
        is_ = [c for _, c in i_reads]
        v_exact = (sum(vs) / len(vs) + 0.5) * lsb_v
        i_exact = (sum(is_) / len(is_) + 0.5) * lsb_i
        for got, exact, name in ((row.v_V, v_exact, "v_V"), (row.i_A, i_exact, "i_A")):
            if abs(got - exact) > 6e-5:
                fail(f"seq {s}: {name} {got} is not the mean of the conversions read in the window ({exact:.6f})")
        out[s] = (v_exact, i_exact)
    n_v = sum(sum(1 for _, _, ch in per.get(int(s), []) if ch == 0) for s in df["seq"])
    n_i = sum(sum(1 for _, _, ch in per.get(int(s), []) if ch == 1) for s in df["seq"])
    print(f"V and I: every row the mean of the free-running conversions read in its window ({n_v / len(df):.1f} V "
          f"and {n_i / len(df):.1f} I a window), each the driven value; {carried} windows whose first I conversion "
          f"began before the close and holds the window before's current")
    return out


def check_count(a, twin, df, windows, feed_codes, n_feed_windows, win_periods, n_burst, means):
    """The board's rpm_rip, ra_ohm, tw_C against the host's reference on the same codes and
    means, then against the twin's truth."""
    import numpy as np
    from hpddo.model import export
    from hpddo.ripple import board as rc
    for col in ("rpm_rip", "ra_ohm", "tw_C"):
        if col not in df:
            fail(f"no {col} column: not the counting build")
    model = export.read_model_header((ROOT / "models" / "default" / "model_default.h").read_text())
    start = win_periods - n_burst
    bursts, v, i = [], [], []
    for s in df["seq"]:
        w = windows[int(s)]
        bursts.append(feed_codes[w["index"] % n_feed_windows][start:start + n_burst])
        v.append(means[int(s)][0])  # the window's V and I as the board measured them (free_running_means)
        i.append(means[int(s)][1])
    per_rev = 6 * HW.gear_ratio
    ref = rc.track(bursts, v, i, df["rpm_est"].to_numpy(), 1.0 / a.rate, model.physics, float(a.hz), per_rev,
                   win_periods - n_burst)
    worst = [0.0, 0.0, 0.0]
    first_off = None
    for row, r in zip(df.itertuples(), ref):
        if first_off is None and ((np.isfinite(row.rpm_rip) and abs(row.rpm_rip - r["rpm"]) > 0.006)
                                  or (r["have_ra"] and abs(row.ra_ohm - r["ra_ohm"]) > 2e-3)):
            first_off = (f"first at seq {row.seq}: board {row.rpm_rip} RPM, Ra {row.ra_ohm}; reference "
                         f"{r['rpm']:.3f} RPM ({r['cyc']} cycles, k {r['k']}), Ra {r['ra_ohm']:.5f}")
        got_conf = np.isfinite(row.rpm_rip)
        if got_conf != r["confident"]:
            fail(f"seq {row.seq}: board confident={got_conf} ({row.rpm_rip}), reference {r['confident']} "
                 f"({r['rpm']:.3f} RPM, {r['cyc']} cycles, k {r['k']})")
        if got_conf:
            worst[0] = max(worst[0], abs(row.rpm_rip - r["rpm"]))
        if np.isfinite(row.ra_ohm) != r["have_ra"]:
            fail(f"seq {row.seq}: board has Ra {row.ra_ohm}, reference {r['have_ra']}")
        if r["have_ra"]:
            worst[1] = max(worst[1], abs(row.ra_ohm - r["ra_ohm"]))
            worst[2] = max(worst[2], abs(row.tw_C - r["tw_C"]))
    print(f"counter: {len(df)} windows, {int(np.isfinite(df['rpm_rip']).sum())} confident; the board equals the "
          f"reference: rpm_rip within {worst[0]:.4f} RPM (printed with 2 decimals), Ra within {worst[1]:.5f} ohm, "
          f"T within {worst[2]:.3f} K")
    if worst[0] > 0.006 or worst[1] > 2e-3 or worst[2] > 0.15:
        fail(f"the board's counter or Ra tracker differs from the reference ({first_off})")
    # against the twin's truth
    truth = read_log(a.twin).df  # noqa: F841 (the encoder)
    tcsv = np.genfromtxt(str(a.twin).replace(".csv", ".truth.csv"), delimiter=",", names=True)
    idx = np.array([windows[int(s)]["index"] % n_feed_windows for s in df["seq"]])
    rpm_true = tcsv["rpm_true"][idx]
    ok = np.isfinite(df["rpm_rip"].to_numpy())
    e = (df["rpm_rip"].to_numpy()[ok] - rpm_true[ok]) / rpm_true[ok]
    ra_ok = np.isfinite(df["ra_ohm"].to_numpy())
    era = (df["ra_ohm"].to_numpy()[ra_ok] - tcsv["ra_ohm"][idx][ra_ok]) / tcsv["ra_ohm"][idx][ra_ok]
    etw = df["tw_C"].to_numpy()[ra_ok] - tcsv["winding_C"][idx][ra_ok]
    print(f"against the twin's truth: ripple speed RMS {100 * np.sqrt(np.mean(e ** 2)):.3f} %, max "
          f"{100 * np.max(np.abs(e)):.2f} % ({ok.sum()} windows); Ra max |error| {100 * np.max(np.abs(era)):.2f} %, "
          f"winding temperature max |error| {np.max(np.abs(etw)):.2f} K ({ra_ok.sum()} windows with Ra)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--harness", required=True)
    ap.add_argument("--elf", required=True, help="uno_acq built with -DACQ_RIPPLE_HZ=<hz>")
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--hz", type=int, default=10000, help="the build's ACQ_RIPPLE_HZ")
    ap.add_argument("--rate", type=float, default=10.0, help="windows per second")
    ap.add_argument("--rows", type=int, default=8)
    ap.add_argument("--duty", type=float, default=0.8)
    ap.add_argument("--twin", type=pathlib.Path, default=None,
                    help="drive and feed from this twin log and its bursts (2 Hz, ripple at --hz); --rate "
                         "and --duty then come from it")
    ap.add_argument("--count", action="store_true", help="the counting build (-DACQ_RIPPLE_COUNT=1)")
    ap.add_argument("--twin-rate", type=float, default=2.0,
                    help="--count without --twin: the windows per second of the twin it makes")
    ap.add_argument("--twin-time-scale", type=float, default=0.1,
                    help="--count without --twin: the time scale of the twin it makes")
    ap.add_argument("--frame-dump", default=None,
                    help="frame_dump (test/firmware/frame_dump.cpp): decode the ESP8266 link and check its frames")
    ap.add_argument("--measure", action="store_true",
                    help="print the figures even when the harness reports link errors or missing rows (not a test)")
    a = ap.parse_args()
    global MEASURE_MODE
    MEASURE_MODE = a.measure
    twin = None
    if a.count and a.twin is None:
        a.twin = pathlib.Path(a.workdir) / "twin" / "load.csv"
        subprocess.run([sys.executable, "-m", "hpddo", "twin", "--protocol", "load", "--ripple-hz", str(a.hz),
                        "--rate-hz", f"{a.twin_rate:g}", "--time-scale", f"{a.twin_time_scale:g}",
                        "--out", str(a.twin.parent)], check=True, capture_output=True,
                       env={"PYTHONPATH": str(ROOT / "tools"), "PATH": "/usr/bin:/bin"})
    if a.twin is not None:
        twin = read_log(a.twin)
        tb = ripple_file.read(ripple_file.path_for(a.twin))
        a.rate = twin.sample_rate_hz
        a.duty = float(twin.df["duty"].iloc[0])
        if (twin.df["duty"] != a.duty).any() or tb.sample_hz != a.hz:
            fail(f"{a.twin}: the check needs one duty and bursts at {a.hz} Hz")

    work = pathlib.Path(a.workdir)
    work.mkdir(parents=True, exist_ok=True)
    rng = random.Random(20261125)
    top = F_CPU // a.hz - 1
    period_cycles = top + 1
    win_periods = round(a.hz / a.rate)
    n_feed_windows = 11
    feed_codes = [[rng.randint(8, 400) for _ in range(win_periods)] for _ in range(n_feed_windows)]
    if twin is not None:
        feed_codes = [c.tolist() for c in tb.codes]
        n_feed_windows = len(feed_codes)
    (work / "feed.txt").write_text("".join(" ".join(str(mv_for_code(c)) for c in row) + "\n" for row in feed_codes))
    # V, I, speed of the test part of data/default/long.csv (duty 0.8): points the default
    # model was trained around, so that the observer's network runs (its deepest stack)
    long = read_log(ROOT / "data" / "default" / "long.csv").df
    part = long.iloc[int(0.8 * len(long)):].iloc[:13]
    if twin is not None:
        part = twin.df
    drive = [(round(v, 4), round(i, 4), round(r, 3)) for v, i, r in zip(part["v_V"], part["i_A"], part["rpm_ref"])]
    (work / "drive.csv").write_text("".join(f"{v},{i},{r}\n" for v, i, r in drive))

    # pwm restarts Timer1 with the duty in force: simavr 1.6 computes a compare match's
    # timing when the timer is configured, not when OCR1B changes (avr_timer.c)
    commands = [f"duty {a.duty:g}", f"pwm {a.hz}", f"rate {a.rate:g}", "rec ripple"]
    cmd = [a.harness, a.elf, str(work / "drive.csv"), str(work), str(a.rows)] + commands
    print("UNO_SIM_RIPPLE=feed.txt", " ".join(cmd))
    # The ring's peak fill (acq_ripple.h SampleRing: 2-byte codes, then head, tail, peak), read
    # from the simulated RAM at the end: how close the ring came to losing samples.
    ring = [l.split() for l in subprocess.run(["avr-nm", "-S", a.elf], capture_output=True, text=True,
                                               check=True).stdout.splitlines() if l.endswith("_ZN3acq6ripple6g_ringE")]
    env = {"UNO_SIM_RIPPLE": str(work / "feed.txt"), "PATH": "/usr/bin:/bin"}
    if ring:  # the sending build's ring (the counting build has none)
        ring_addr, ring_size = int(ring[0][0], 16) & 0xFFFF, int(ring[0][1], 16)
        ring_n = (ring_size - 3) // 2
        env["UNO_SIM_PEEK"] = hex(ring_addr + 2 * ring_n + 2)
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env)
    print(res.stdout.strip())
    if res.returncode != 0 and not (a.measure and res.returncode == 1):
        fail(f"harness exit {res.returncode}: {res.stderr.strip()}")
    if res.returncode:
        print(f"MEASURE ONLY: the harness reported link framing or marker errors, or missing rows (exit 1); "
              f"the figures below are printed, not a pass")
    summary = [l for l in res.stdout.splitlines() if l.startswith("uno_sim ripple:") and " triggers, " in l][0]
    no_edge = int(summary.split(" triggers, ")[1].split()[0])
    sp_room = int(summary.split("(")[1].split()[0])
    ring_peak = int([l for l in res.stdout.splitlines() if "peek" in l][0].split("= ")[1]) if ring else None

    # ---- the host stream: the log without the '!' and '~' lines, the chunks
    host = (work / "host.txt").read_text()
    lines = host[:host.rfind("\n") + 1].splitlines()
    start = max(k for k, l in enumerate(lines) if l.startswith("# condition="))
    log_lines = [l for l in lines[start:] if not l.startswith(("!", "~"))]
    (work / "capture.csv").write_text("\n".join(log_lines) + "\n")
    log = read_log(work / "capture.csv")
    df = log.df.iloc[:a.rows]
    meta = log.meta
    n_burst = int(meta["ripple_n"])
    if int(meta["ripple_hz"]) != a.hz or n_burst <= 0:
        fail(f"metadata ripple_hz={meta.get('ripple_hz')} ripple_n={meta.get('ripple_n')}")
    asm = ripple_link.Assembler()
    chunk_lines = [(k + 1, l) for k, l in enumerate(lines[start:]) if l.startswith("~")]
    for no, l in chunk_lines:
        asm.feed(l, no)
    if asm.bad or asm.duplicates:
        fail(f"{asm.bad} bad chunk lines {asm.faults[:3]}, {asm.duplicates} duplicates")
    bursts, incomplete = asm.bursts()
    by_seq = {b.seq: b for b in bursts}
    seqs = [int(s) for s in df["seq"]]
    print(f"log: {len(df)} rows, seq {seqs[0]}..{seqs[-1]}; {len(chunk_lines)} chunk lines, {asm.chunks} chunks, "
          f"{len(bursts)} whole bursts of {n_burst} codes, {len(incomplete)} incomplete (seq {incomplete})")
    if len(df) < a.rows:
        fail_or_note(f"{len(df)} rows, want {a.rows}")
    if seqs != list(range(seqs[0], seqs[0] + len(seqs))):
        fail_or_note(f"seq has a gap: windows lost ({sorted(set(range(seqs[0], seqs[-1] + 1)) - set(seqs))[:5]} ...)")

    # ---- windows and triggers
    windows = {}
    order = []
    for l in (work / "windows.csv").read_text().splitlines()[1:]:
        s, close, vmv, imv, rpm, edges = l.split(",")
        windows[int(s)] = dict(close=int(close), v_mV=int(vmv), i_mV=int(imv), index=len(order))
        order.append(int(s))
    trig = []
    for l in (work / "ripple_triggers.csv").read_text().splitlines()[1:]:
        k, t, ps, started, mv, code, o1a, o1b = (int(x) for x in l.split(",")[:8])
        trig.append(dict(t=t, ps=ps, started=started, mv=mv, code=code, ocr1a=o1a, ocr1b=o1b))
    # A match with the trigger enabled that started no conversion (the flag still set: no edge;
    # or the ADC busy) loses a sample when it falls in a burst; the bursts' checks below
    # (every period of each burst, each code) catch that. Those before a burst, between the
    # arm and its first period, are counted here.
    not_started = sum(1 for t in trig if t["started"] != 1)
    if no_edge != sum(1 for t in trig if t["started"] == -1):
        fail("the harness's count of matches without an edge disagrees with its trigger file")

    # ---- every recorded window has its whole burst, equal to the codes fed
    lost = 0
    for s in ([] if a.count else seqs):
        b = by_seq.get(s)
        if b is None:
            lost += 1
            continue
        w_close = windows[s]["close"]
        w_open = windows[s - 1]["close"] if (s - 1) in windows else None
        if w_open is None:
            fail(f"seq {s}: the window's start is not in the simulation")
        # the burst: the window's last n_burst periods (the triggers before them, after the
        # arm, are converted and dropped by the firmware)
        in_win = [t for t in trig if w_open <= t["t"] < w_close][-n_burst:]
        if any(t["started"] != 1 for t in in_win):
            fail(f"seq {s}: {sum(1 for t in in_win if t['started'] != 1)} matches in the burst started no conversion")
        if len(in_win) < n_burst:
            fail(f"seq {s}: {len(in_win)} triggers in the window, fewer than the burst's {n_burst}")
        if b.start_period != win_periods - n_burst:
            fail(f"seq {s}: burst starts at period {b.start_period}, want {win_periods - n_burst}")
        first_period = round((in_win[0]["ps"] - w_open) / period_cycles)
        if first_period != b.start_period:
            fail(f"seq {s}: the burst's first trigger is in period {first_period}, the chunks say {b.start_period}")
        want = [t["code"] for t in in_win]
        feed_row = feed_codes[windows[s]["index"] % n_feed_windows][b.start_period:b.start_period + n_burst]
        if want != feed_row:
            fail(f"seq {s}: the harness fed other codes than the feed file's row (harness bookkeeping)")
        got = b.codes.tolist()
        if got != want:
            diff = next(k for k, (x, y) in enumerate(zip(got, want)) if x != y) if len(got) == len(want) else "length"
            fail(f"seq {s}: burst differs from the codes fed (first at {diff})")
        rate_gaps = {in_win[k + 1]["t"] - in_win[k]["t"] for k in range(n_burst - 1)}
        if max(abs(g - period_cycles) for g in rate_gaps) > 4:
            fail(f"seq {s}: trigger spacing {sorted(rate_gaps)} cycles, want {period_cycles}")
        if b.phase_cycles != in_win[0]["ocr1b"] + 1 + expected_ocr1b(top, a.duty)[1]:
            fail(f"seq {s}: chunk phase {b.phase_cycles} != OCR1B {in_win[0]['ocr1b']} + sample-and-hold")
    if lost:
        fail(f"{lost} recorded windows without a whole burst")
    for s in seqs:  # every period of each burst triggered a conversion
        w_open, w_close = windows[s - 1]["close"], windows[s]["close"]
        in_win = [t for t in trig if w_open <= t["t"] < w_close][-n_burst:]
        if len(in_win) < n_burst or any(t["started"] != 1 for t in in_win):
            fail(f"seq {s}: the burst's {n_burst} periods did not each start a conversion")
    if not a.count:
        print(f"bursts: {len(seqs)} windows, each burst's {n_burst} codes equal those fed in its last {n_burst} "
              f"periods (no sample lost, duplicated or out of order)")
    print(f"triggers: every one of the {n_burst} periods of each of the {len(seqs)} bursts started a conversion; "
          f"{not_started} matches before a burst (after the arm) started none")

    # ---- rate and phase
    in_bursts = [t for s in seqs for t in [t for t in trig if windows[s - 1]["close"] <= t["t"] < windows[s]["close"]][-n_burst:]]
    gaps = [y["t"] - x["t"] for x, y in zip(in_bursts, in_bursts[1:]) if y["t"] - x["t"] < 2 * period_cycles]
    mean_gap = sum(gaps) / len(gaps)
    want_ocr1b, sh, adps = expected_ocr1b(top, a.duty)
    ocr_seen = {t["ocr1b"] for t in in_bursts}
    if ocr_seen != {want_ocr1b}:
        fail(f"OCR1B {sorted(ocr_seen)} in the bursts, want {want_ocr1b} (middle of the on-time at duty {a.duty})")
    phases = [t["t"] - t["ps"] for t in in_bursts]
    ph_min, ph_max = min(phases), max(phases)
    if ph_min < want_ocr1b + 1 - 4 or ph_max > want_ocr1b + 1 + 4:
        fail(f"phase {ph_min}..{ph_max} cycles from the period's start, want {want_ocr1b + 1}")
    ocr1a = in_bursts[0]["ocr1a"]
    sh_at = want_ocr1b + 1 + sh
    print(f"rate: {len(gaps) + 1} triggers in bursts, mean spacing {mean_gap:.3f} cycles = "
          f"{F_CPU / mean_gap:.2f} Hz (PWM period {period_cycles}), spacing {min(gaps)}..{max(gaps)}")
    print(f"phase: OCR1B {want_ocr1b} at duty {a.duty} (OCR1A {ocr1a}, on-time {ocr1a + 1} cycles, middle "
          f"{(ocr1a + 1) / 2:g}); compare match {ph_min}..{ph_max} cycles after the period's start "
          f"(jitter {ph_max - ph_min} cycles = {1e6 * (ph_max - ph_min) / F_CPU:.3f} us, simavr's instruction "
          f"granularity; the ADC starts on the match in hardware); sample-and-hold {sh} cycles later, at "
          f"{sh_at} (ADC clock F_CPU/{1 << adps})")

    # ---- ADC interrupt: cycles, ends before the next trigger, CPU share
    isr = []
    for l in (work / "adc_isr.csv").read_text().splitlines()[1:]:
        e, c, tr = (int(x) for x in l.split(","))
        isr.append((e, c, tr))
    t0, t1 = windows[seqs[0] - 1]["close"], windows[seqs[-1]]["close"]
    trig_isr = sorted(c for e, c, tr in isr if tr and t0 <= e < t1)
    free_isr = sorted(c for e, c, tr in isr if not tr and t0 <= e < t1)
    busy_all = sum(c for e, c, tr in isr if t0 <= e < t1)
    trig_times = [t["t"] for t in trig]
    import bisect
    late = 0
    for e, c, tr in isr:
        if not tr or not t0 <= e < t1:
            continue
        k = bisect.bisect_right(trig_times, e)
        if k < len(trig_times) and e + c > trig_times[k]:
            late += 1
    # One held past the next trigger (nested interrupts) hands over the next code
    # (acq_ripple_board.h on_adc): no loss, as the bursts' and the counter's checks show.
    share = busy_all / (t1 - t0)
    print(f"ADC interrupt, triggered conversions: median {trig_isr[len(trig_isr) // 2]} cycles, max {trig_isr[-1]} "
          f"(nested interrupts included), {len(trig_isr)} interrupts; free-running: median "
          f"{free_isr[len(free_isr) // 2]} max {free_isr[-1]}; {late} held past the next trigger")
    print(f"CPU share of the ADC interrupt over {len(seqs)} windows: {100 * share:.1f} % "
          f"({busy_all} of {t1 - t0} cycles)")

    # ---- the main loop's work on each recorded window (GPIOR1 markers: it starts after the
    # window's close), beside the sender or the counter; it must end within a window
    window_cycles = round(F_CPU / a.rate)
    w_first, w_last = windows[seqs[0]]["close"], windows[seqs[-1]]["close"]
    busy = [l.split(",") for l in (work / "busy.csv").read_text().splitlines()[1:]]
    loop = {}
    for kind in ("window", "observer", "ripple"):
        c = sorted(int(cyc) for k, start, cyc in busy if k == kind and w_first <= int(start) < w_last + window_cycles)
        if c:
            loop[kind] = dict(median=c[len(c) // 2], max=c[-1], n=len(c))
            print(f"main loop, {kind}: median {c[len(c) // 2]} max {c[-1]} cycles of the {window_cycles}-cycle window "
                  f"({100.0 * c[len(c) // 2] / window_cycles:.1f} % median, {100.0 * c[-1] / window_cycles:.1f} % at "
                  f"most), {len(c)} windows")
    if "window" not in loop:
        fail("no main-loop markers for the recorded windows")
    if loop["window"]["max"] >= window_cycles:
        fail_or_note(f"the work on a window takes up to {loop['window']['max']} cycles, longer than the window")
    fig = (f"figures: adc_share_pct={100 * share:.2f} loop_median={loop['window']['median']} "
           f"loop_max={loop['window']['max']} window_cycles={window_cycles}")
    for kind, key in (("observer", "obs"), ("ripple", "rip")):
        if kind in loop:
            fig += f" {key}_median={loop[kind]['median']} {key}_max={loop[kind]['max']}"
    print(fig)

    # ---- the ESP8266 link: every recorded window's frame, CRCs valid, no byte dropped
    if a.frame_dump:
        out = subprocess.run([a.frame_dump, str(work / "link.bin")], capture_output=True, text=True,
                             check=True).stdout.strip().splitlines()
        summary = dict(kv.split("=") for kv in out[-1][2:].split())
        frames = {int(l.split(",")[0]): [int(x) for x in l.split(",")] for l in out[1:-1]}
        if int(summary["crc_errors"]) or int(summary["dropped_bytes"]):
            fail(f"link: {summary}")
        for row in df.itertuples():
            f = frames.get(int(row.seq) & 0xFFFF)
            if f is None:
                fail(f"link: no frame for seq {row.seq}")
            if abs(f[3] - row.v_V * 1000) > 1 or abs(f[4] - row.i_A * 1000) > 1 or abs(f[2] - row.duty * 255) > 0.51:
                fail(f"link: frame {f} does not match row {row}")
        print(f"link: {summary['frames']} frames, no CRC error, no dropped byte; every recorded row's frame "
              f"holds its V, I and duty")

    # ---- bytes/s on the USB line
    sim_s = (t1 - t0) / F_CPU
    chunk_chars = sum(len(l) + 1 for _, l in chunk_lines if True)
    all_chars = sum(len(l) + 1 for l in lines[start:])
    per_s = chunk_chars / sim_s
    n_chunks_rec = sum(1 for _, l in chunk_lines)
    if chunk_lines:
        print(f"line: the bursts take {chunk_chars / len(seqs):.0f} characters a window "
              f"({chunk_chars / len(seqs) * a.rate:.0f}/s average, {82 * a.hz / 32:.0f}/s while a burst runs) of "
              f"{BAUD // 10} characters/s at {BAUD} baud; all lines {all_chars / len(seqs) * a.rate:.0f}/s "
              f"({100 * all_chars / len(seqs) * a.rate / (BAUD / 10):.0f} %); at 115200 baud the bursts alone would "
              f"need {100 * 82 * a.hz / 32 / 11520:.0f} % of the line while they run")
    del per_s, n_chunks_rec

    # ---- V and I means of the free-running part
    lsb_v = ADC_REF_V / 1024 * RATIO
    lsb_i = ADC_REF_V / 1024 / SHUNT_OHM
    means = free_running_means(work, windows, df, lsb_v, lsb_i)

    if a.count:
        check_count(a, twin, df, windows, feed_codes, n_feed_windows, win_periods, n_burst, means)
        print(f"stack: low-water mark {sp_room} bytes above the static RAM")
        if sp_room < 64:
            fail("the stack came within 64 bytes of the static RAM")
        print("MEASURED, NOT A PASS: " + "; ".join(MEASURE) if MEASURE else "PASS")
        return

    # ---- the burst file hpddo ripple reads
    t_start = {int(r.seq): float(r.t_s) for r in df.itertuples()}
    path, kept = ripple_link.bursts_file(work / "ripple.ripple.csv", bursts, meta, t_start)
    back = ripple_file.read(path)
    if len(back) != kept or kept != len(seqs) or any(len(c) != n_burst for c in back.codes):
        fail(f"{path}: {len(back)} bursts read back, want {len(seqs)}")
    t_want = float(df["t_s"].iloc[0]) + ((win_periods - n_burst) * period_cycles + want_ocr1b + 1 + sh) / F_CPU
    if abs(back.t_s[0] - t_want) > 1e-9:
        fail(f"first burst t_s {back.t_s[0]} != {t_want}")
    a_code = ripple_link.a_per_code(meta)
    if not math.isclose(a_code, ADC_REF_V / 1024 / SHUNT_OHM):
        fail(f"a_per_code {a_code}")
    print(f"{path.name}: {kept} bursts, sample_hz {back.sample_hz:g}, a_per_code {back.a_per_code:g}, first t_s "
          f"{back.t_s[0]:.6f}")

    if twin is not None:
        compare_with_twin(a, twin, path, df, windows)

    # ---- stack
    print(f"ring: at most {ring_peak} of {ring_n} codes waiting for the sender")
    print(f"stack: low-water mark {sp_room} bytes above the static RAM")
    if sp_room < 64:
        fail("the stack came within 64 bytes of the static RAM")
    print("MEASURED, NOT A PASS: " + "; ".join(MEASURE) if MEASURE else "PASS")


if __name__ == "__main__":
    main()
