"""An independent simulation of a brushed PMDC motor's armature current, per rotor angle, for checking
the ripple count on signals it was not built beside (docs/ripple-independent.md). Written from the physics below with numpy only; it shares no code with
the twin (hpddo.twin) and writes its recordings with the project's writers (hpddo.logs).

The armature (a two-pole machine, so the electrical angle is the rotor's angle theta):

* S commutator bars on a ring, S coils, coil k from bar k to bar k + 1, resistance r_k, and the
  EMF of a full-pitch coil in a sinusoidal air-gap field, e_k = c_k w sin(theta + (k + 1/2) p -
  neutral) (p = 2 pi / S the bar pitch): zero while the brush at 0 shorts it (the magnetic
  neutral), largest a quarter turn on.
* Two brushes, at 0 and at pi (+ an offset: a brush off its diametral axis), each of a width of
  some bar pitches; a brush touches every bar its arc overlaps, through a contact conductance in
  proportion to the overlap (its full contact resistance on one whole bar). Bars are separated by
  an insulating gap narrower than a brush, so a brush always touches a bar and, while it bridges
  a gap, shorts the coil between the two bars.
* Per angle the network (S bar nodes and the brush at 0; the brush at pi the reference) is solved
  twice by nodal analysis: with the coils' EMFs at w = 1 rad/s and the terminals open (the
  back-EMF constant ke(theta), V s/rad), and with the EMFs off and 1 A into the brush (the
  brush-to-brush resistance r(theta)). The armature is then v = ke(theta) w + r(theta) i + L di/dt,
  and its torque ke(theta) i (the power the EMFs take).
* Coil asymmetry (r_k, c_k a few % apart) makes ke and r differ from bar to bar: lines at the
  multiples of the rotation frequency. A dynamic eccentricity (the rotor's air gap turning with
  it) scales every coil's flux by 1 + ecc cos(theta + phase): a once-per-revolution modulation.

**Ripples per revolution.** The ripple is the change of ke and r each time a brush's edge meets a
bar's gap. The gaps pass the brush at 0 at theta = -(k + 1/2) p, S times a revolution. The brush at
pi meets a gap when pi = (j + 1/2) p + theta for some j: for even S, pi = (S / 2) p is a whole
number of pitches, so both brushes meet gaps at the same angles and the network's state repeats
S times a revolution; for odd S, pi = ((S - 1) / 2 + 1/2) p puts the brush at pi half a pitch off
the lattice of the brush at 0, so its events fall midway between them: 2 S ripples a revolution
(`ripples_per_rev`). `angle_harmonics` takes the Fourier series of a symmetric network's ke(theta)
and r(theta) over one revolution; its strongest harmonic is that number (test_ripple_independent).

The drive and the measurement:

* A low-side PWM switch from a supply Vs (with a freewheel diode of drop `diode_V` across the
  motor): on, Vs across the motor; off, the current freewheels through the diode (-diode_V), and
  where it reaches zero it stays there (discontinuous conduction; the terminals then show the
  back-EMF). The supply may carry a rectified-mains ripple (a full-wave bridge and its capacitor:
  lines at 2 f_mains and its multiples), and the current channel a mains pickup (f_mains and its
  harmonics).
* The current is integrated exactly over each piece of time with a constant switch state (an
  exponential towards (V - E) / R at L / R); the angle and the shaft speed step with it
  (torque balance: inertia, viscous and Coulomb friction, a load torque that brakes; or an imposed
  speed profile: steps, ramps, a creep, a stall).
* Sampling: `synchronous`, one sample per PWM period in the middle of the on-time; or `free`, a
  free-running ADC (9.6 kHz under a 490.196 Hz PWM), so the PWM's own L / R current ripple is in
  the samples. Brush bounce: short random spikes of a brush's contact resistance (in series with
  the armature). White and 1/f noise and the ADC's quantisation on the samples.
* The bench log's row per window: duty, the mean terminal voltage and current (with the board's
  noise), seq; `ra_ohm` a multimeter's reading of the mean brush-to-brush resistance, a few % off.
  The truth per window: the shaft's mean speed (the angle travelled over the window).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

ANGLES = 8192            # rotor angles per revolution of the network's tables
WINDOW_S = 0.5           # one bench-log row and one burst per window (the log's 2 Hz)
FREE_SAMPLE_HZ = 9600.0  # the free-running ADC
FREE_PWM_HZ = 490.196    # the UNO's default analogWrite (16 MHz / 64 / 510)


def ripples_per_rev(segments: int) -> int:
    """Commutation ripples per revolution of an S-bar commutator under two diametral brushes: S for
    even S (both brushes meet a gap at once), 2 S for odd S (the module's docstring derives it)."""
    return segments if segments % 2 == 0 else 2 * segments


@dataclasses.dataclass(frozen=True)
class Motor:
    """A brushed PMDC motor's armature, commutator and shaft (motor side, no gearbox)."""

    segments: int                 # commutator bars (= coils)
    ra_ohm: float                 # brush-to-brush resistance, mean over a revolution (coils and contacts)
    ke_vs_per_rad: float          # back-EMF constant, mean over a revolution
    la_H: float                   # armature inductance
    contact_share: float = 0.1    # one brush's full contact resistance, as a share of ra_ohm
    brush_pitches: float = 0.3    # a brush's arc, in bar pitches
    gap_pitches: float = 0.08     # the insulation between two bars, in bar pitches (under the brush's arc)
    coil_r: tuple = ()            # per coil, its resistance's relative deviation (asymmetry); () none
    coil_emf: tuple = ()          # per coil, its EMF's relative deviation; () none
    ecc: float = 0.0              # dynamic eccentricity: the flux's once-per-revolution relative modulation
    ecc_phase_rad: float = 0.0
    brush_offset_rad: float = 0.0  # the brush at pi off its diametral position
    neutral_rad: float = 0.0      # the brush axis off the magnetic neutral
    j_kgm2: float = 2e-5          # rotor and load inertia
    b_nms: float = 1e-5           # viscous friction, N m s/rad
    tc_nm: float = 2e-3           # Coulomb friction, N m
    diode_V: float = 0.7          # the freewheel diode's drop


def _deviation(values: tuple, s: int) -> np.ndarray:
    return np.ones(s) if not values else 1.0 + np.asarray(values, float)


def network(m: Motor, angles=None, coil_ohm: float = 1.0, contact_ohm: float | None = None,
            coil_v: float = 1.0) -> tuple:
    """ke(theta) (V s/rad) and r(theta) (ohm) of the armature between its brushes at the rotor angles
    (rad; ANGLES over a revolution by default), for coils of coil_ohm and coil_v V s/rad (before their
    deviations) and brushes of contact_ohm (default: contact_share x ra_ohm). Nodal analysis per
    angle (the module's docstring)."""
    s = m.segments
    th = np.linspace(0.0, 2 * math.pi, ANGLES, endpoint=False) if angles is None else np.asarray(angles, float)
    pitch = 2 * math.pi / s
    half_bar = (1.0 - m.gap_pitches) * pitch / 2
    half_brush = m.brush_pitches * pitch / 2
    if not half_brush > m.gap_pitches * pitch / 2:
        raise ValueError("a brush narrower than a bar's gap loses contact")
    rc = m.contact_share * m.ra_ohm if contact_ohm is None else contact_ohm
    centres = th[:, None] + pitch * np.arange(s)[None, :]

    def contact(at):  # conductance of each bar to a brush centred at angle `at`
        d = (centres - at + math.pi) % (2 * math.pi) - math.pi
        over = np.clip(np.minimum(d + half_bar, half_brush) - np.maximum(d - half_bar, -half_brush), 0.0, None)
        return over / (2 * half_brush) / rc

    g_a, g_b = contact(0.0), contact(math.pi + m.brush_offset_rad)
    gc = 1.0 / (coil_ohm * _deviation(m.coil_r, s))
    flux = 1.0 + m.ecc * np.cos(th + m.ecc_phase_rad)
    emf = (coil_v * _deviation(m.coil_emf, s))[None, :] * flux[:, None] * np.sin(
        th[:, None] + pitch * (np.arange(s) + 0.5)[None, :] - m.neutral_rad)
    n = s + 1                       # the bars, then the brush at 0; the brush at pi is the reference
    g = np.zeros((len(th), n, n))
    rhs = np.zeros((len(th), n, 2))
    k = np.arange(s)
    nxt = (k + 1) % s
    np.add.at(g, (slice(None), k, k), gc)
    np.add.at(g, (slice(None), nxt, nxt), gc)
    np.add.at(g, (slice(None), k, nxt), -gc)
    np.add.at(g, (slice(None), nxt, k), -gc)
    g[:, k, k] += g_a + g_b
    g[:, s, s] = g_a.sum(axis=1)
    g[:, k, s] -= g_a
    g[:, s, k] -= g_a
    # coil k, bar k to bar k + 1, EMF e_k: its current leaves bar k by (V_k - V_k+1 + e_k) / r_k
    src = emf * gc[None, :]
    np.add.at(rhs, (slice(None), k, 0), -src)
    np.add.at(rhs, (slice(None), nxt, 0), src)
    rhs[:, s, 1] = 1.0              # 1 A into the brush at 0, the EMFs off
    v = np.linalg.solve(g, rhs)
    ke, r = v[:, s, 0], v[:, s, 1]
    return (ke if ke.mean() >= 0 else -ke), r


def tables(m: Motor) -> tuple:
    """ke(theta), r(theta) over ANGLES angles of a revolution, scaled so their means are the motor's
    ke_vs_per_rad and ra_ohm (the coils' and contacts' resistances scaled together)."""
    ke, r = network(m)
    scale = m.ra_ohm / r.mean()
    ke, r = network(m, coil_ohm=scale, contact_ohm=m.contact_share * m.ra_ohm * scale)
    return ke * (m.ke_vs_per_rad / ke.mean()), r


def angle_harmonics(m: Motor, harmonics: int = 64) -> tuple:
    """The amplitudes of ke(theta) and r(theta)'s Fourier series over one revolution, harmonics
    1..harmonics (relative to their means)."""
    ke, r = tables(m)
    out = []
    for x in (ke, r):
        a = np.abs(np.fft.rfft(x)) / len(x) * 2
        out.append(a[1:harmonics + 1] / x.mean())
    return tuple(out)


@dataclasses.dataclass(frozen=True)
class Drive:
    """The supply, the PWM, the sampling and the measurement."""

    vs_V: float = 12.0
    sampling: str = "synchronous"    # or "free"
    pwm_hz: float = 10000.0          # synchronous: the sample rate too (an even integer: 0.5 s windows whole)
    sample_hz: float = 10000.0
    mains_hz: float = 0.0            # 0: no mains interference
    mains_supply_rel: float = 0.0    # the rectified supply's ripple (peak to peak) over Vs
    mains_pickup_A: float = 0.0      # the mains pickup on the current channel, its fundamental's amplitude
    bounce_per_s: float = 0.0        # brush bounce: spikes of contact resistance per second
    bounce_ohm: float = 0.0          # a spike's largest added resistance (uniform 0..this)
    bounce_s: float = 1e-4           # a spike's longest duration (uniform 0.2..1 of this)
    white_A: float = 0.003           # white noise on the samples, rms
    pink_A: float = 0.002            # 1/f noise on the samples, rms over the record
    a_per_code: float = 5.0 / 1024 / 0.5   # 10-bit ADC on a 0.5 ohm shunt
    offset_code: int = 0             # the code of zero current
    bits: int = 10
    v_noise_V: float = 0.01          # the bench log's mean voltage and current: the board's noise
    i_noise_A: float = 0.002


@dataclasses.dataclass(frozen=True)
class Protocol:
    """Per window: the duty and the load torque (N m, braking); or an imposed shaft speed (rad/s) at
    breakpoints (t_s, w), linear between them, instead of the torque balance."""

    duty: tuple
    load_nm: tuple = ()
    imposed: tuple = ()             # ((t_s, w_rad_s), ...); () = the torque balance


def _segments(drive: Drive, duty: np.ndarray):
    """The pieces of time with a constant switch state: (start, length, on, the index of the pieces
    after which a sample is taken)."""
    n_win = len(duty)
    t_end = n_win * WINDOW_S
    if drive.sampling == "synchronous":
        per = int(round(drive.pwm_hz * WINDOW_S))
        if abs(per - drive.pwm_hz * WINDOW_S) > 1e-9:
            raise ValueError("synchronous: pwm_hz x the window must be whole")
        period = 1.0 / drive.pwm_hz
        d = np.repeat(duty, per)
        t0 = np.arange(n_win * per) * period
        length = np.stack([d * period / 2, d * period / 2, (1 - d) * period], axis=1).ravel()
        start = np.stack([t0, t0 + d * period / 2, t0 + d * period], axis=1).ravel()
        on = np.tile([True, True, False], len(t0))
        sample_after = np.arange(len(t0)) * 3    # the end of the first half of the on-time
        return start, length, on, sample_after
    period = 1.0 / drive.pwm_hz
    n_per = int(math.ceil(t_end / period)) + 1
    p0 = np.arange(n_per) * period
    dp = duty[np.minimum((p0 / WINDOW_S).astype(int), n_win - 1)]
    samples = np.arange(int(round(t_end * drive.sample_hz))) / drive.sample_hz
    edges = np.concatenate([p0, p0 + dp * period, samples, [t_end]])
    kind = np.concatenate([np.zeros(2 * n_per, int), np.ones(len(samples), int), [0]])
    keep = edges <= t_end
    edges, kind = edges[keep], kind[keep]
    order = np.argsort(edges, kind="stable")
    edges, kind = edges[order], kind[order]
    start, length = edges[:-1], np.diff(edges)
    mid = start + length / 2
    k = np.minimum((mid / period).astype(int), n_per - 1)
    on = (mid - p0[k]) < dp[k] * period
    # a sample at edge j is the current at the end of piece j - 1 (the first, at t = 0, at rest)
    sample_after = np.flatnonzero(kind[1:] == 1)
    return start, length, on, sample_after, np.flatnonzero(kind[:1] == 1)


def _bounce(drive: Drive, start, length, rng) -> np.ndarray:
    """The added series resistance per piece of time (its mean over the piece)."""
    out = np.zeros(len(start))
    t_end = float(start[-1] + length[-1])
    n = rng.poisson(drive.bounce_per_s * t_end)
    if n == 0 or drive.bounce_ohm <= 0:
        return out
    t0 = np.sort(rng.uniform(0, t_end, n))
    dur = drive.bounce_s * rng.uniform(0.2, 1.0, n)
    amp = drive.bounce_ohm * rng.uniform(0.0, 1.0, n)
    end = start + length
    for a, d, r in zip(t0, dur, amp):
        lo, hi = np.searchsorted(end, a), np.searchsorted(start, a + d)
        for j in range(lo, hi):
            ov = min(end[j], a + d) - max(start[j], a)
            if ov > 0 and length[j] > 0:
                out[j] += r * ov / length[j]
    return out


def _supply(drive: Drive, t) -> np.ndarray:
    """The supply voltage at t: Vs with a full-wave rectified ripple (zero mean) where mains_hz."""
    if not drive.mains_hz or not drive.mains_supply_rel:
        return np.full(len(t), drive.vs_V)
    rect = np.abs(np.sin(2 * math.pi * drive.mains_hz * t))
    return drive.vs_V * (1.0 + drive.mains_supply_rel * (rect - 2 / math.pi))


def _pink(n: int, fs: float, rms: float, rng) -> np.ndarray:
    """1/f noise (power ~ 1/f above 1 / the record), rms over the record."""
    if rms <= 0 or n < 4:
        return np.zeros(n)
    spec = (rng.normal(size=n // 2 + 1) + 1j * rng.normal(size=n // 2 + 1))
    f = np.fft.rfftfreq(n, 1.0 / fs)
    spec[0] = 0
    spec[1:] /= np.sqrt(f[1:])
    x = np.fft.irfft(spec, n)
    return x * (rms / x.std())


def simulate(motor: Motor, drive: Drive, protocol: Protocol, seed: int) -> dict:
    """One recording: {"log": the bench log's rows (t_s, duty, v_V, i_A, seq), "meta": its metadata
    (ra_ohm a multimeter's reading), "bursts": (t_s, codes, metadata) as logs.ripple.write takes
    them, "rpm_true": the shaft's mean speed per window (RPM), "i_true_A": the mean current per
    window}."""
    import pandas as pd
    rng = np.random.default_rng(seed)
    duty = np.asarray(protocol.duty, float)
    n_win = len(duty)
    load = np.zeros(n_win) if not protocol.load_nm else np.asarray(protocol.load_nm, float)
    seg = _segments(drive, duty)
    start, length, on, sample_after = seg[:4]
    sample_at_zero = len(seg) > 4 and len(seg[4]) > 0
    mid = start + length / 2
    vs = _supply(drive, mid)
    r_b = _bounce(drive, start, length, rng)
    win = np.minimum((mid / WINDOW_S).astype(int), n_win - 1)
    tload = load[win] + motor.tc_nm
    imposed = None
    if protocol.imposed:
        bt, bw = np.asarray(protocol.imposed, float).T
        imposed = np.interp(mid, bt, bw)
    ke_tab, r_tab = tables(motor)
    ke_l, r_l = ke_tab.tolist(), r_tab.tolist()
    per_rad = ANGLES / (2 * math.pi)
    la, j, b, vd = motor.la_H, motor.j_kgm2, motor.b_nms, motor.diode_V
    n = len(start)
    i_end = np.empty(n)
    charge = np.empty(n)      # integral of i over the piece (A s)
    volt = np.empty(n)        # integral of the terminal voltage over the piece (V s)
    theta_end = np.empty(n)
    i, th, w = 0.0, 0.0, 0.0 if imposed is None else float(imposed[0])
    exp = math.exp
    on_l, len_l, vs_l, rb_l, tl_l = on.tolist(), length.tolist(), vs.tolist(), r_b.tolist(), tload.tolist()
    imp_l = None if imposed is None else imposed.tolist()
    for q in range(n):
        h = len_l[q]
        if imp_l is not None:
            w = imp_l[q]
        a = int((th + 0.5 * w * h) * per_rad) % ANGLES
        ke, r = ke_l[a], r_l[a] + rb_l[q]
        e = ke * w
        v_on = vs_l[q] if on_l[q] else -vd
        i_inf = (v_on - e) / r
        tau = la / r
        if h <= 0.0:
            i_end[q], charge[q], volt[q], theta_end[q] = i, 0.0, 0.0, th
            continue
        x = exp(-h / tau)
        i1 = i_inf + (i - i_inf) * x
        if i1 >= 0.0:
            qa = i_inf * h + (i - i_inf) * tau * (1.0 - x)
            va = v_on * h
        elif i > 0.0:      # the current reaches zero inside the piece and stays there: the terminals show e
            t0 = tau * math.log((i - i_inf) / -i_inf)
            qa = i_inf * t0 + (i - i_inf) * tau * (1.0 - exp(-t0 / tau))
            va = v_on * t0 + e * (h - t0)
            i1 = 0.0
        else:
            qa, va, i1 = 0.0, e * h, 0.0
        if imp_l is None:
            torque = ke * qa / h - b * w
            if w > 0.0 or torque > tl_l[q]:
                w1 = w + h * (torque - tl_l[q]) / j
                w1 = w1 if w1 > 0.0 else 0.0
            else:
                w1 = 0.0
            th += 0.5 * (w + w1) * h
            w = w1
        else:
            th += w * h
        i = i1
        i_end[q], charge[q], volt[q], theta_end[q] = i, qa, va, th
    # the bench log's rows: means over each window
    edges = np.arange(n_win + 1) * WINDOW_S
    cum_t = np.concatenate([[0.0], np.cumsum(length)])
    first = np.searchsorted(cum_t, edges[:-1] - 1e-12)
    first = np.minimum(first, n - 1)
    q_win = np.add.reduceat(charge, first)
    v_win = np.add.reduceat(volt, first)
    i_mean = q_win / WINDOW_S
    v_mean = v_win / WINDOW_S
    th_at = np.interp(edges, np.concatenate([[0.0], start + length]), np.concatenate([[0.0], theta_end]))
    rpm_true = np.diff(th_at) / WINDOW_S * 60 / (2 * math.pi)
    # the samples
    i_s = i_end[sample_after]
    if sample_at_zero:
        i_s = np.concatenate([[0.0], i_s])
    fs = drive.sample_hz if drive.sampling == "free" else drive.pwm_hz
    t_s = np.arange(len(i_s)) / fs
    meas = i_s + rng.normal(0, drive.white_A, len(i_s)) + _pink(len(i_s), fs, drive.pink_A, rng)
    if drive.mains_hz and drive.mains_pickup_A:
        for h_m, amp in ((1, 1.0), (2, 0.3), (3, 0.5), (5, 0.25)):
            meas += drive.mains_pickup_A * amp * np.sin(2 * math.pi * h_m * drive.mains_hz * t_s + rng.uniform(0, 6.3))
    codes = np.clip(np.round(meas / drive.a_per_code + drive.offset_code), 0, 2 ** drive.bits - 1).astype(np.int64)
    per = int(round(fs * WINDOW_S))
    if len(codes) < per * n_win:
        raise ValueError("fewer samples than windows")
    bursts = [codes[k * per:(k + 1) * per] for k in range(n_win)]
    meta = {"sample_hz": f"{fs:g}", "a_per_code": repr(drive.a_per_code), "sampling": drive.sampling}
    if drive.offset_code:
        meta["offset_code"] = str(drive.offset_code)
    if drive.sampling == "free":
        meta["pwm_hz"] = f"{drive.pwm_hz:g}"
    log = pd.DataFrame({"t_s": edges[:-1], "duty": duty,
                        "v_V": v_mean + rng.normal(0, drive.v_noise_V, n_win),
                        "i_A": i_mean + rng.normal(0, drive.i_noise_A, n_win),
                        "seq": np.arange(n_win, dtype=np.int64)})
    return {"log": log, "bursts": (edges[:-1].copy(), bursts, meta), "rpm_true": rpm_true, "i_true_A": i_mean,
            "ke_table": ke_tab, "r_table": r_tab}
