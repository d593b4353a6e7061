// The ripple mode on the ATmega328P (registers, interrupt hooks, the main loop's sender);
// built only with -DACQ_RIPPLE_HZ=<Hz> (8000..20000), included by uno_acq.cpp. The timing,
// the burst length and the chunk format are in acq_ripple.h (host-tested); docs/ripple-board.md,
// "The UNO's ripple mode".
//
// Per window: the free-running V/I conversions of the normal mode (the window's V and I
// means) until stop_periods before the burst, when the overflow interrupt asks the ADC to
// wait for the trigger (arm): the free-running conversion in flight ends, is counted, and the
// ADC then converts only on the trigger. At the burst's first period (the window's last
// burst_n periods) the overflow interrupt opens the burst; each Timer1 compare B match
// (OCR1B: the sample-and-hold at the middle of the on-time) starts a conversion of the current
// in hardware (auto trigger, ADTS = 101); the ADC interrupt clears OCF1B (the trigger is its
// rising edge), puts the code into the ring and, after the burst's last one, hands the ADC
// back to the free-running conversions, which then count for the next window. The main loop
// takes the codes from the ring in chunks of 32 and writes each as a "~<base64>" line.
#ifndef HPDDO_ACQ_RIPPLE_BOARD_H
#define HPDDO_ACQ_RIPPLE_BOARD_H

#include <avr/interrupt.h>
#include <avr/io.h>

#include "acq_format.h"
#include "acq_ripple.h"
#include "bench_gen.h"
/// Ripples per motor revolution: the bench's (tools/hpddo/bench.py, generated into bench_gen.h),
/// unless the build gives its own (-DACQ_RIPPLES_PER_REV=N for another motor).
#ifndef ACQ_RIPPLES_PER_REV
#define ACQ_RIPPLES_PER_REV HPDDO_BENCH_RIPPLES_PER_REV
#endif
#include "acq_ripple_count.h"
#include "acq_coast.h"

// What the build does with the bursts: send them to the host (ACQ_RIPPLE_STREAM, item 2) or
// count them on the board (ACQ_RIPPLE_COUNT, item 5), by default the first. Both at once do
// not fit at 10 kHz: the counter in the ADC interrupt (about 210 cycles a code) and the sender
// (25 625 characters/s) together starve the main loop, the ring overflows (seen in simavr: no
// burst of 3 arrived whole at 2 Hz), and the flash exceeds 95 %.
#ifndef ACQ_RIPPLE_COUNT
#define ACQ_RIPPLE_COUNT 0
#endif
#ifndef ACQ_RIPPLE_STREAM
#define ACQ_RIPPLE_STREAM (!ACQ_RIPPLE_COUNT)
#endif
// The coast probe (acq_coast.h, issue 33 item 7): -DACQ_COAST=1 in the streaming build. A build
// of its own, as the counter's: it takes 698 bytes of flash (docs/ripple-board.md, "Coast
// probes"), which the streaming build has (86.6 % of the flash with it) but not with a model that
// names the dynamic family (92.7 %, 247 bytes over its 92 %), and without it the streaming build is the same
// image as before.
#ifndef ACQ_COAST
#define ACQ_COAST 0
#endif
#if ACQ_COAST && !ACQ_RIPPLE_STREAM
#error "the coast probe's samples are streamed to the host: build ACQ_COAST=1 without ACQ_RIPPLE_COUNT=1"
#endif

namespace acq {
namespace ripple {

static const uint8_t kRing = 64;  ///< codes in flight between the ADC interrupt and the sender (peak 33 in simavr)
static const uint8_t kSlots = 4;   ///< bursts in flight (a power of two)
static const uint8_t kAdcsraTriggered =
    static_cast<uint8_t>(_BV(ADEN) | _BV(ADIE) | _BV(ADATE));  // | ADPS of the timing

struct Slot {
  uint32_t seq;
  uint16_t total;
  uint16_t start_period;  ///< the window's period of sample 0
  uint16_t phase_cycles;  ///< a period's start to its sample-and-hold
#if ACQ_COAST
  uint8_t sync1;          ///< kRippleSync1: a burst of the current; kCoastSync1: a coast probe (acq_coast.h)
#endif
  volatile uint16_t pushed;
  volatile bool open;
};

struct State {
  RippleTiming rt;
  uint16_t burst_n;             ///< samples a burst, for the window length in force
  uint16_t burst_period;        ///< the window's period at whose start the burst opens
  uint16_t arm_period;          ///< the period at whose start the ADC is armed
  volatile uint16_t left;       ///< samples still to take in the open burst (ADC interrupt)
  volatile bool arm;            ///< the next free-running completion arms the trigger
  volatile bool triggered;      ///< the ADC waits for compare B
  volatile uint8_t slot_w;      ///< bursts opened (window close)
  uint8_t slot_r;               ///< bursts done by the sender
  uint16_t sent;                ///< samples of slot_r taken from the ring
  Slot slot[kSlots];
  volatile uint16_t not_started;  ///< windows whose burst could not start (the ADC was not armed)
  volatile uint16_t overflows;    ///< bursts cut short by a full ring; codes lost to nesting
  volatile bool busy;             ///< the ADC interrupt is taking a triggered code
  volatile bool has_pend;         ///< a nested interrupt left its code in pend
  volatile uint16_t pend;
  volatile uint16_t deferred;     ///< codes taken from a nested interrupt
  uint32_t chunks;                ///< chunks sent
#if ACQ_COAST
  // the coast probe (acq_coast.h): in the burst's place of every coast_every-th window
  uint16_t coast_n;               ///< samples of a probe; 0: none fits the window
  uint16_t coast_every;           ///< windows from one probe to the next
  uint16_t coast_count;           ///< windows since the last probe
  volatile bool coast_off;        ///< probes stopped (`coast 0`; on from power-up, `coast 1`)
  bool coast_win;                 ///< the open window carries a probe
  bool coast_cut;                 ///< the drive is held off
  volatile bool coast;            ///< the probe's conversions run: the channel alternates
  uint16_t coast_ocr;             ///< OCR1A in force before the probe
  uint8_t coast_tccr1a;           ///< TCCR1A (the PWM's output mode) before the probe
  uint8_t coast_pin;              ///< the PWM pin's PORTB bit before the probe (high: duty 1)
#endif
  // the ripple counter (acq_ripple_count.h): the ADC interrupt counts, the main loop reads
  struct Band {
    uint32_t seq;                 ///< the window whose burst this band is for
    uint16_t t_exp;               ///< expected ripple period, PWM periods (0: none)
    uint8_t k;                    ///< low-pass shift
    bool valid;
  } band[2];                      ///< by the burst's seq & 1 (main loop writes, the burst's open reads)
  uint8_t band_lag;               ///< windows from the prior's to the burst's (ripple_band_lag)
  volatile bool counted_burst;    ///< a burst has been counted since configure()
  volatile uint32_t reset_seq;    ///< the counter starts afresh at this window's burst
  volatile bool reset_pending;
  struct Count {
    uint32_t seq;
    uint16_t cyc, span;
    uint8_t k;
    bool valid;
  } count;                        ///< the last whole burst's count (set at its last sample)
};

State g;
SampleRing<kRing> g_ring;
RippleCounter g_counter;

/// ADC back to the free-running V/I conversions of the normal mode.
__attribute__((always_inline)) inline void free_running() {
  g.triggered = false;
  ADCSRA = 0;
  ADMUX = static_cast<uint8_t>(_BV(REFS0) | kAdcChannelV);
  ADCSRA = static_cast<uint8_t>(_BV(ADEN) | _BV(ADIE) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0) | _BV(ADSC));
}

#if ACQ_COAST
/// The drive as it was before the probe (TIMER1_OVF or configure, interrupts off): OCR1A from
/// the next period on, the output mode and pin now.
__attribute__((noinline)) void coast_restore() {
  OCR1A = g.coast_ocr;
  if (g.coast_cut) {
    PORTB |= g.coast_pin;
    TCCR1A = g.coast_tccr1a;
  }
  g.coast_cut = false;
  g.coast_win = false;
}

/// The coast probe's part of the start of period p (TIMER1_OVF, interrupts off; probes on): a
/// probe in the burst's place of every coast_every-th window (acq_coast.h). OCR1A 0 in the period
/// before the cut (the cut period's on-time shrinks to one cycle at its start: the output goes low
/// at its first compare match, whatever this interrupt's latency), the output held low at the cut
/// (the burst's first period, once on_period has opened the probe's slot: the ADC waits for the
/// trigger; else on_period restores the drive, no probe), the drive back from the period after the
/// probe's last sample. Not inlined: TIMER1_OVF saves every register a
/// call clobbers anyway (its prologue, seen in the disassembly), so the call costs no pushes.
__attribute__((noinline)) void coast_period(uint16_t p) {
  if (p == 0 && g.coast_n && ++g.coast_count >= g.coast_every) {
    g.coast_count = 0;
    g.coast_win = true;
  }
  if (!g.coast_win) return;
  if (p == static_cast<uint16_t>(g.burst_period - 1u)) {
    g.coast_ocr = OCR1A;  // the buffer: the value in force (written at the window's start)
    OCR1A = 0;
  } else if (p == g.burst_period) {  // the ADC waits for the trigger (on_period checked it)
    g.coast_tccr1a = TCCR1A;
    g.coast_pin = static_cast<uint8_t>(PORTB & _BV(PB1));
    TCCR1A = _BV(WGM11);  // OC1A disconnected: the pin follows PORTB
    PORTB &= static_cast<uint8_t>(~_BV(PB1));
    g.coast_cut = true;
    g.coast = true;
  } else if (p == static_cast<uint16_t>(g.burst_period + g.coast_n - 1u)) {
    coast_restore();
  }
}
#endif

/// Sets the timing for hz and the burst length for a window of window_periods; interrupts off.
inline bool configure(uint32_t hz, uint16_t window_periods, uint32_t baud) {
  RippleTiming rt;
  if (!ripple_timing(hz, &rt)) return false;
#if ACQ_COAST
  if (g.coast_win) coast_restore();  // a probe in progress: the drive comes back
  g.coast = false;
#endif
  g.rt = rt;
  g.burst_n = ripple_burst_samples(rt, window_periods, baud);
  g.burst_period = static_cast<uint16_t>(window_periods - g.burst_n);
  g.arm_period = static_cast<uint16_t>(g.burst_period - rt.stop_periods);
#if ACQ_COAST
  const uint16_t period = static_cast<uint16_t>(rt.pwm.top + 1u);  // prescaler 1 (ripple_timing)
  const uint16_t probe_n = coast_samples(period);
  g.coast_n = coast_fits(g.burst_n, probe_n) ? probe_n : 0;
  g.coast_every = coast_every_windows(period, window_periods);
  g.coast_count = 0;
#endif
  g.left = 0;
  g.arm = false;
  g.triggered = false;
  g.slot_w = g.slot_r = 0;
  g.sent = 0;
  g_ring.clear();
  ripple_counter_reset(&g_counter);
  g.band[0].valid = g.band[1].valid = false;
  g.band_lag = ripple_band_lag(g.burst_period, pwm_period_cycles(rt.pwm));
  g.counted_burst = false;
  g.count.valid = false;
  ADCSRB = 0;
  free_running();  // it may have waited for a trigger
  return true;
}

/// Start of period p of the open window seq (TIMER1_OVF, interrupts off; p 0 right after a
/// close): arms the trigger, opens the burst. A burst still open at a close (a window made
/// shorter by `rate`) ends there, incomplete; an ADC still waiting for the trigger then goes
/// back to the free-running conversions.
__attribute__((always_inline)) inline void on_period(uint16_t p, uint32_t seq) {
  if (p == 0 && (g.left || g.triggered)) {
    if (g.left) {
      g.slot[static_cast<uint8_t>(g.slot_w - 1u) & (kSlots - 1)].open = false;
      g.left = 0;
      ++g.not_started;
    }
    free_running();
  }
  if (!g.burst_n) return;
  if (p == g.arm_period) g.arm = true;
  // The coast probe's call comes last on each path, and only at p 0 or in a probe's window: the
  // interrupt took a median 132 cycles a period without the probe, 183 with the call first and in
  // every period (values kept across it in call-saved registers, 6 more pushes and pops), 156 so
  // (simavr, ovf_isr.csv; docs/ripple-board.md "Coast probes").
  if (p != g.burst_period) {
#if ACQ_COAST
    if (g.coast_win || (p == 0 && !g.coast_off)) coast_period(p);
#endif
    return;
  }
  if (!g.triggered) {
    ++g.not_started;
#if ACQ_COAST
    if (g.coast_win) coast_restore();  // no burst starts: no probe
#endif
    return;
  }
  Slot& s = g.slot[g.slot_w & (kSlots - 1)];
  s.seq = seq;
  s.total = g.burst_n;
#if ACQ_COAST
  s.sync1 = kRippleSync1;
  if (g.coast_win) {  // the probe's samples in the burst's place
    s.total = g.coast_n;
    s.sync1 = kCoastSync1;
  }
#endif
  s.start_period = p;
  s.phase_cycles = static_cast<uint16_t>(OCR1B + 1u + g.rt.sh_cycles);  // compare match at OCR1B + 1 ticks
  s.pushed = 0;
  s.open = true;
  g.slot_w = static_cast<uint8_t>(g.slot_w + 1);
  g.left = s.total;
#if ACQ_COAST
  if (g.coast_win) coast_period(p);  // the cut
#endif
  // The counter begins the burst at its first code, in the ADC interrupt (begin_count), not
  // here: this interrupt runs with interrupts off, and the link's bit interrupt must not wait
  // behind it (a burst's opening here took 439 cycles, and 100 Hz windows had framing errors
  // on the ESP8266 link in simavr).
}

#if ACQ_RIPPLE_COUNT
/// The count of the burst of window seq begins (its first code, the ADC interrupt, interrupts
/// on): the band from the prior of window seq - band_lag (on_window), none yet: the reset's;
/// from a cold start at a recording's first window. g.count (the last burst's, tagged with its
/// seq) stays until this burst's last code: at 100 Hz windows the main loop may read the window
/// before's after this burst began.
__attribute__((noinline)) void begin_count(uint32_t seq) {
  cli();
  const State::Band b = g.band[seq & 1u];
  const bool reset = g.reset_pending && seq == g.reset_seq;
  if (reset) g.reset_pending = false;
  sei();
  uint8_t k = kRippleLpReset;
  uint16_t t_exp = 0;
  if (b.valid && b.seq == seq) k = b.k, t_exp = b.t_exp;
  if (reset) {
    ripple_counter_reset(&g_counter);
    k = g_counter.k;
    g.counted_burst = false;
  }
  ripple_counter_begin(&g_counter, k, t_exp, g.burst_period, !g.counted_burst, g.burst_n);
}
#endif

/// OCR1B of a setpoint: the middle of its on-time (main loop; preload copies it).
inline uint16_t trigger_for(const PwmTiming& t, uint16_t ocr1a, uint16_t duty_q) {
  return ripple_trigger(t, ocr1a, duty_q, g.rt.sh_cycles);
}

/// One triggered conversion's code (on_adc, not nested).
__attribute__((always_inline)) inline void triggered_sample(uint16_t code) {
  cli();
  const uint16_t left = g.left;
  const uint8_t w = g.slot_w;
  if (left) g.left = static_cast<uint16_t>(left - 1u);
  sei();
  if (!left) return;  // a trigger between the arm and the burst: not a sample
  Slot& s = g.slot[static_cast<uint8_t>(w - 1u) & (kSlots - 1)];
#if ACQ_RIPPLE_COUNT
  if (left == g.burst_n) begin_count(s.seq);
  ripple_counter_sample(&g_counter, code);
  if (left == 1u) {  // the burst's last sample: its count, for the main loop's window
    g.count.seq = s.seq;
    g.count.cyc = g_counter.cyc;
    g.count.span = g_counter.span;
    g.count.k = g_counter.k;
    g_counter.cyc = g_counter.span = 0;
    g.count.valid = true;
    g.counted_burst = true;
  }
#endif
#if ACQ_RIPPLE_STREAM
  if (g_ring.push(code)) {
    s.pushed = static_cast<uint16_t>(s.pushed + 1u);
  } else {
    ++g.overflows;  // the burst ends here; the host sees it incomplete and leaves it out
    cli();
    g.left = 0;
    sei();
  }
#else
  s.pushed = static_cast<uint16_t>(s.pushed + 1u);
#endif
  if (left == 1u || !g.left) {
    s.open = false;
#if ACQ_COAST
    if (g.coast) {  // the probe's last: the ADC stays on the trigger (discarded) to the window's end,
      g.coast = false;  // whose V and I are the first part's, before the cut
      return;
    }
#endif
    free_running();  // the V/I conversions of the next window
  }
}

/// ADC interrupt, after the atomic read of code and the window's sums: true when the
/// conversion was the ripple mode's (a triggered one, or the last free-running one before
/// the trigger is armed, added to acc here); false: the normal path goes on.
template <class AccT>
__attribute__((always_inline)) inline bool on_adc(uint16_t code, AccT* acc) {
  if (ADCSRA & _BV(ADATE)) {
    TIFR1 = _BV(OCF1B);  // the trigger is the flag's rising edge: clear it for the next one
#if ACQ_COAST
    if (g.coast) ADMUX ^= 1u;  // a probe: the other channel for the next period's conversion
#endif
    // The interrupt runs with interrupts on, so others (the window close, the USART) can
    // hold it past the next conversion, whose interrupt would then nest: that one hands its
    // code to this one, which takes it in order when done (two held at once: one lost, counted).
    cli();
    if (g.busy) {
      if (g.has_pend) ++g.overflows;
      g.pend = code;
      g.has_pend = true;
      sei();
      return true;
    }
    g.busy = true;
    sei();
    for (;;) {
      triggered_sample(code);
      cli();
      if (!g.has_pend) break;
      code = g.pend;
      g.has_pend = false;
      ++g.deferred;
      sei();
    }
    g.busy = false;
    sei();
    return true;
  }
  if (!g.arm) return false;
  const uint8_t mux = ADMUX;
  AccT* const a = (mux & 1u) ? acc + 1 : acc;
  a->sum += code;
  ++a->n;
  g.arm = false;
  ADMUX = static_cast<uint8_t>(_BV(REFS0) | kAdcChannelI);
  ADCSRB = static_cast<uint8_t>(_BV(ADTS2) | _BV(ADTS0));  // Timer/Counter1 compare match B
  ADCSRA = static_cast<uint8_t>(kAdcsraTriggered | g.rt.adps);
  // Cleared after ADATE is on: a match between the two would otherwise raise the flag while
  // no trigger is enabled, and the next matches would find it set (no rising edge, no
  // conversion: the whole burst lost; seen in simavr once in 50 windows).
  TIFR1 = _BV(OCF1B);
  g.triggered = true;
  return true;
}

/// What the counter gives for a closed window.
struct WindowRipple {
  float rpm;       ///< the ripple speed, RPM (NaN: no count)
  bool confident;  ///< within kRippleCountPriorTol of the prior it was counted with
  bool have_ra;    ///< ra and tw hold values
  float ra_ohm;
  float tw_C;
};

RippleRa g_ra;
uint32_t g_ra_from_seq;  ///< Ra is tracked from this window on (a recording's first)
RippleSpan g_span;  ///< the count's span (acq_ripple_count.h)

/// A recording starts with window first_seq (main loop): the counter starts afresh at that
/// window's burst (its band from the reset, k = 5), and Ke is calibrated again from there: the
/// motor is taken to be cold, at the model's t_ref_C.
inline void on_recording(uint32_t first_seq) {
  cli();
  g.reset_seq = first_seq;
  g.reset_pending = true;
  sei();
  ripple_ra_reset(&g_ra);
  g_ra_from_seq = first_seq;
  g_span.cyc = g_span.span = g_span.n = g_span.i2 = g_span.rpm = g_span.i_last = 0.0f;
  g_span.age = kRippleSettleWindows;
}

/// Main loop, after the observer's step on window seq (v_V, i_A its means, dt_s its length,
/// rpm_prior the observer's estimate, the back-EMF prior): the window's ripple speed, whether
/// it is the prior's line, Ra and the winding temperature; sets a later burst's band. The
/// host's reference, step for step: ripple/board.py track.
__attribute__((noinline)) WindowRipple on_window(const hpddo::PhysicsParams& p, uint32_t seq, float v_V, float i_A,
                                                 float dt_s, float rpm_prior) {
  WindowRipple out;
  out.rpm = hpddo::absent();
  out.confident = false;
  const float fs = static_cast<float>(kCpuHz) / static_cast<float>(pwm_period_cycles(g.rt.pwm));
  const float per_rev = static_cast<float>(ACQ_RIPPLES_PER_REV) * HPDDO_BENCH_GEAR_RATIO;  // ripples per output rev
  cli();
  const State::Count c = g.count;
  sei();
  RippleSpan* s = &g_span;
  __asm__("" : "+r"(s));  // through a pointer register: 2-byte loads and stores, not 4-byte absolute ones
  const bool rec = static_cast<int32_t>(seq - g_ra_from_seq) >= 0;
  if (c.valid && c.seq == seq && rec) {
    float keep = dt_s < kRippleCountTauS ? 1.0f - dt_s / kRippleCountTauS : 0.0f;
    // The window's current: the sum of its own and the window before's (a short window's mean
    // current aliases the ripple, in opposite sense from one window to the next; 0 before the
    // recording's first: its second window then begins the span again). Against the span's
    // mean, both sides times the span's weight n and the current twice: where
    // Ra |I - I_span| > kRippleSteadyTol Ke w_span (a load or voltage step: the speed moves by
    // more than that share at constant voltage) the span begins again at this window (keep 0:
    // its current and prior are the new span's first), and the counts of this window and the
    // next kRippleSettleWindows - 1 are left out.
    const float i2 = s->i_last + i_A;
    s->i_last = i_A;
    if (keep > 0.0f && fabsf(p.ra_ohm * (i2 * s->n - s->i2)) >
                           2.0f * kRippleSteadyTol / hpddo::kRpmPerRadS * p.ke_vs_per_rad * s->rpm) {
      keep = 0.0f;
      s->age = 0;
    } else if (s->age < kRippleSettleWindows) {
      ++s->age;
    }
    float cyc = static_cast<float>(c.cyc), periods = static_cast<float>(c.span);
    float keep_cyc = keep;
    if (s->age < kRippleSettleWindows) {
      cyc = periods = 0.0f;
    } else if (c.cyc >= static_cast<uint16_t>(kRippleMinCycles)) {  // a burst holding enough cycles is the count alone
      keep_cyc = 0.0f;
    }
    s->cyc = s->cyc * keep_cyc + cyc;
    s->span = s->span * keep_cyc + periods;
    s->n = s->n * keep + 1.0f;
    s->i2 = s->i2 * keep + i2;
    s->rpm = s->rpm * keep + (rpm_prior > 0.0f ? rpm_prior : 0.0f);  // no NaN into the sums: it would stay
  }
  float f = 0.0f;
  if (ripple_counter_hz(s->cyc, s->span, fs, &f)) out.rpm = f * 60.0f / per_rev;
  // the span's mean prior as a ripple frequency (NaN before the span's first window: none)
  float f_prior = s->rpm * (per_rev / 60.0f) / s->n;
  if (!(f_prior > 0.0f)) f_prior = 0.0f;
  if (f > 0.0f && s->cyc >= kRippleMinCycles) out.confident = ripple_count_confident(f, f_prior);
  const bool track = out.confident && rec;
  out.have_ra = track ? ripple_ra_step(p, v_V, i_A, out.rpm, dt_s, &g_ra) : g_ra.have;
  out.ra_ohm = g_ra.ra_ohm;
  out.tw_C = g_ra.tw_C;
  // The burst of window seq + band_lag (its last periods: it has not begun) is counted in the
  // band of the count where it is confident, else of the span's mean prior (one 100 Hz window's
  // prior is 15-25 % off with its voltage's PWM noise: enough to count a gap of two ripple
  // periods as one), at the decimated rate, and across its gap with this expected period. From
  // a recording's windows only: the reference starts there (no band before).
  if (rec) {
    const float f_band = out.confident ? f : f_prior;
    const float t_exp = f_band > 0.0f ? fs / f_band + 0.5f : 0.0f;
    State::Band b;
    b.seq = seq + g.band_lag;
    b.k = ripple_lp_shift(f_band, 0.5f * fs);
    b.t_exp = static_cast<uint16_t>(t_exp > 65535.0f ? 65535.0f : t_exp);
    b.valid = true;
    cli();
    g.band[b.seq & 1u] = b;
    sei();
  }
  return out;
}

/// Columns the ripple build appends to a row (after rpm_est,est_status): the ripple speed
/// where the count is the prior's line, the tracked Ra and winding temperature once Ke is
/// calibrated; empty cells otherwise.
HPDDO_FLASH static const char kLogHeaderRipple[] = ",rpm_rip,ra_ohm,tw_C";

inline void format_window(LineWriter& lw, const WindowRipple& r) {
  lw.put(',');
  if (r.confident) lw.real(r.rpm, 2);
  lw.put(',');
  if (r.have_ra) lw.real(r.ra_ohm, 4);
  lw.put(',');
  if (r.have_ra) lw.real(r.tw_C, 2);
}

/// Main loop: sends at most one chunk of the oldest burst (when 32 codes are there, or the
/// burst's last ones); bursts of windows outside a recording are taken and dropped.
/// write(buf, n) writes n characters to the host. Not inlined: its 200 bytes of buffers are
/// on the stack only while it runs, not beside the observer's in loop()'s frame.
template <class Write>
__attribute__((noinline)) void drain(bool recording, uint32_t rec_start, Write write) {
#if !ACQ_RIPPLE_STREAM
  g.slot_r = g.slot_w;  // nothing is sent: the bursts are counted (on_window)
  (void)recording, (void)rec_start, (void)write;
  return;
#endif
  if (g.slot_r == g.slot_w) return;
  Slot& s = g.slot[g.slot_r & (kSlots - 1)];
  cli();
  const uint16_t pushed = s.pushed;
  const bool open = s.open;
  sei();
  const uint16_t avail = static_cast<uint16_t>(pushed - g.sent);
  if (avail >= kRippleChunkSamples || (!open && avail)) {
    const uint8_t n = static_cast<uint8_t>(avail < kRippleChunkSamples ? avail : kRippleChunkSamples);
    uint16_t codes[kRippleChunkSamples];
    g_ring.pop(codes, n);
    if (recording && static_cast<int32_t>(s.seq - rec_start) >= 0) {
      RippleChunk c;
      c.seq = s.seq;
      c.first = g.sent;
      c.total = s.total;
      c.start_period = s.start_period;
      c.phase_cycles = s.phase_cycles;
      c.n = n;
      c.codes = codes;
      uint8_t frame[kRippleChunkMax];
      const uint8_t len = encode_ripple_chunk(c, frame
#if ACQ_COAST
                                            , s.sync1
#endif
      );
      char line[kRippleLineMax];
      write(line, ripple_line(frame, len, line));
      ++g.chunks;
    }
    g.sent = static_cast<uint16_t>(g.sent + n);
  }
  if (!open && g.sent == pushed) {
    g.slot_r = static_cast<uint8_t>(g.slot_r + 1);
    g.sent = 0;
  }
}

}  // namespace ripple
}  // namespace acq

#endif  // HPDDO_ACQ_RIPPLE_BOARD_H
