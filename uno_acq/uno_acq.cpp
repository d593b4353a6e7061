// hpddo acquisition board (Arduino UNO, ATmega328P), the bench of the paper's
// sections 3.4-3.6: PWM drive, V and I sampling, encoder, DS18B20, load relays,
// the three protocols; bench log lines to the host over USB, binary frames to
// the ESP8266 on a second, transmit-only serial line (OC2A, D11).
//
// Interrupts do the time-critical work; the main loop formats and talks:
//   TIMER1_OVF  end of a PWM period; closes the sample window every N periods
//   ADC         one conversion done: start the next, add it to the open window
//   INT0/INT1   encoder edge: x4 quadrature count
//   TIMER2_COMPA next bit of the ESP8266 link (the pin itself is set by OC2A)
// Pure logic is in the acq_*.h headers, tested on the host (test/firmware).
//
#include <Arduino.h>
#include <avr/interrupt.h>
#include <avr/io.h>

#include "acq_command.h"
#include "acq_config.h"
#include "acq_format.h"
#include "acq_link.h"
#include "acq_onewire.h"
#include "acq_protocol.h"
#include "acq_window.h"
#include "hpddo/frame.h"
#if defined(ACQ_RIPPLE_HZ)
// The ripple mode (issue 23): the current once per PWM period at the middle of the on-time,
// sent in chunks beside each window's V and I, and counted on the board (Ra, winding
// temperature); acq_ripple_board.h, docs/ripple-board.md and docs/ripple-board-count.md.
#if defined(ACQ_NO_OBSERVER)
#error "the ripple build counts with the observer's estimate as the prior: build it with the observer"
#endif
#include "acq_ripple_board.h"
#endif
#if !defined(ACQ_NO_OBSERVER)
// The whole observer runs on the board (issue 14): the fixed-point model by default,
// the float one with -DACQ_OBSERVER_FLOAT; both from models/default (-I models/default;
// build_uno.sh's ACQ_MODEL_DIR builds with another model folder).
#include "hpddo/dynamics.h"
HPDDO_DYNAMICS_DEFAULT(hpddo_model_default)    // kDynamics: the header's, or the family off
HPDDO_DYNAMICS_DEFAULT(hpddo_model_default_q)
#include "model_default_q.h"
#endif

using namespace acq;

namespace {

const char kVersion[] = "uno_acq 1";

// Port bits of the pins in acq_config.h (checked against the UNO pin map).
const uint8_t kBitPwm = _BV(PB1);     // D9
const uint8_t kBitRelay2 = _BV(PB0);  // D8
const uint8_t kBitLink = _BV(PB3);    // D11
const uint8_t kBitRelay1 = _BV(PD7);  // D7
const uint8_t kBitOneWire = _BV(PD4); // D4
static_assert(kPinPwm == 9 && kPinRelay2 == 8 && kPinLinkTx == 11 && kPinRelay1 == 7 &&
                  kPinOneWire == 4 && kPinEncoderA == 2 && kPinEncoderB == 3,
              "port bits above follow the pins in acq_config.h");

enum PwmMode : uint8_t { kPwmOff = 0, kPwmRun = 1, kPwmOn = 2 };

// ---------------------------------------------------------------- interrupt state
// Sums of one channel over a window; index 0 is A0 (V), 1 is A1 (I), so the
// ADC interrupt picks the entry from the low bit of ADMUX.
struct Acc {
  uint32_t sum, n;
};
struct Bank {
  Acc ch[2];
};
static_assert(kAdcChannelV == 0 && kAdcChannelI == 1, "the ADC interrupt toggles ADMUX bit 0 between V and I");
Bank g_bank[2];
volatile uint8_t g_bank_i;                          // bank of the open window
Acc* volatile g_acc;                                // g_bank[g_bank_i].ch: where the ADC adds
volatile int32_t g_enc_total;
volatile uint8_t g_enc_ab;
int32_t g_enc_prev;                                 // g_enc_total at the previous close (main loop)
volatile uint16_t g_periods;                        // PWM periods done in the open window
volatile uint16_t g_win_periods;                    // length of the open window
volatile uint32_t g_win_us;
volatile uint16_t g_next_win_periods;               // length of the windows to come
volatile uint32_t g_next_win_us;
volatile uint32_t g_seq;                            // seq of the open window
volatile uint16_t g_duty_q;                         // in force in the open window
volatile uint8_t g_load;
volatile uint16_t g_next_duty_q;                    // requested by the main loop
volatile uint8_t g_next_load;
volatile uint16_t g_next_ocr;
#if defined(ACQ_RIPPLE_HZ)
volatile uint16_t g_next_ocr1b;                     // the ripple trigger of the next setpoint
#endif
volatile uint8_t g_next_mode;
uint16_t g_pre_duty_q;                              // latched for the next window
uint8_t g_pre_load, g_pre_mode;
struct Closed {
  uint8_t bank;
  uint32_t seq;
  int32_t enc_total;
  uint32_t period_us;
  uint16_t duty_q;
  uint8_t load;
};
volatile bool g_ready;                              // g_closed holds an unread window
Closed g_closed;
volatile uint16_t g_overruns;                       // windows overwritten before read

TxQueue<64> g_txq;
BitShifter g_shifter;

// ---------------------------------------------------------------- main-loop state
PwmTiming g_pwm;
uint32_t g_pwm_hz = kDefaultPwmHz;
float g_rate_hz = kDefaultRateHz;
float g_hold_s = kDefaultHoldS;
float g_long_s = kDefaultLongS;
bool g_recording = false;
uint32_t g_rec_start = 0;       // seq of the first recorded window
ProtocolPlan g_plan;
uint8_t g_manual_load = 0;
uint16_t g_manual_duty_q = 0;
TempSchedule g_temp;
LineBuffer<48> g_cmd;

#if !defined(ACQ_NO_OBSERVER)
#if defined(ACQ_OBSERVER_FLOAT)
namespace model = hpddo_model_default;
#else
namespace model = hpddo_model_default_q;
#endif
// The dynamic family (hpddo/dynamics.h, issue 21 item 8) is compiled exactly when the model names
// it (its header's kDynamics, a constant expression): 1.8 KB of flash, which a model without it
// does not pay (build_uno.sh's budgets; docs/firmware.md).
constexpr bool kWithDynamics = hpddo::dynamics_named(model::kDynamics);
#if defined(ACQ_RIPPLE_HZ) && ACQ_RIPPLE_COUNT
// Measured (docs/firmware.md): the counting build with the family is 32,094 bytes, 99.4 % of the
// flash, over its budget (95 % then, 96 % now); the streaming ripple build fits (91.3 % of its 92 %).
static_assert(!kWithDynamics,
              "uno_acq: the ripple counting build (ACQ_RIPPLE_COUNT=1) cannot run a model that names the "
              "dynamic family (its header's kDynamics): the family's 1.8 KB of flash does not fit beside "
              "the ripple counter (99.4 % of the flash, over its budget; docs/firmware.md). Build the counting "
              "mode with a model without the family, the streaming ripple mode (ACQ_RIPPLE_COUNT=0) or the "
              "normal build with it, or run the family on the ESP8266");
#endif
#if defined(ACQ_RIPPLE_HZ) && ACQ_COAST
// Measured (docs/ripple-board.md, "Coast probes"): the coast probe build with the family is 29,922
// bytes, 92.7 % of the flash, over the streaming build's 92 % by 247 bytes.
static_assert(!kWithDynamics,
              "uno_acq: the coast probe build (ACQ_COAST=1) cannot run a model that names the dynamic family "
              "(its header's kDynamics): the probe's 698 bytes of flash do not fit beside the family's 1.8 KB "
              "within the streaming ripple build's budget (92.7 % of the flash, over its 92 %; "
              "docs/ripple-board.md). Build the coast probe with a model without the family, or the streaming "
              "ripple build without the probe");
#endif
// One observer step per closed window, in the main loop (process()).
hpddo::Observer<model::Net, kWithDynamics> g_obs(model::kModel, model::kDynamics);
#endif

__attribute__((always_inline)) inline void apply_relays(uint8_t load) {
  const bool r1 = load == 1;
  const bool r2 = load == 2;
  if (r1 != kRelayActiveLow) PORTD |= kBitRelay1; else PORTD &= static_cast<uint8_t>(~kBitRelay1);
  if (r2 != kRelayActiveLow) PORTB |= kBitRelay2; else PORTB &= static_cast<uint8_t>(~kBitRelay2);
}

__attribute__((always_inline)) inline void apply_pwm_mode(uint8_t mode) {
  if (mode == kPwmRun) {
    TCCR1A = _BV(COM1A1) | _BV(WGM11);
  } else {
    TCCR1A = _BV(WGM11);
    if (mode == kPwmOn) PORTB |= kBitPwm; else PORTB &= static_cast<uint8_t>(~kBitPwm);
  }
}

__attribute__((always_inline)) inline void preload_next_window() {
  OCR1A = g_next_ocr;  // double-buffered: in force from the next PWM period on
#if defined(ACQ_RIPPLE_HZ)
  OCR1B = g_next_ocr1b;  // the ripple sample at the middle of the next on-time
#endif
  g_pre_duty_q = g_next_duty_q;
  g_pre_load = g_next_load;
  g_pre_mode = g_next_mode;
}

}  // namespace

ISR(TIMER1_OVF_vect) {
  uint16_t p = static_cast<uint16_t>(g_periods + 1u);
  if (p >= g_win_periods) {
    // Kept short: the link bit interrupt must never wait more than a bit time.
    GPIOR0 = static_cast<uint8_t>(g_seq);  // window-close marker (cycle-exact in simulation)
    const uint8_t closed = g_bank_i;
    g_acc = g_bank[closed ^ 1u].ch;  // the ADC fills the other bank from now on
    g_bank_i = static_cast<uint8_t>(closed ^ 1u);
    if (g_ready) {
      ++g_overruns;  // the main loop missed a window: clear the bank it did not read
      Bank& b = g_bank[closed ^ 1u];
      b.ch[0].sum = b.ch[0].n = b.ch[1].sum = b.ch[1].n = 0;
    }
    g_closed.bank = closed;
    g_closed.seq = g_seq;
    g_closed.enc_total = g_enc_total;
    g_closed.period_us = g_win_us;
    g_closed.duty_q = g_duty_q;
    g_closed.load = g_load;
    g_ready = true;
    g_seq = g_seq + 1u;
    g_win_periods = g_next_win_periods;
    g_win_us = g_next_win_us;
    apply_pwm_mode(g_pre_mode);
    apply_relays(g_pre_load);
    g_duty_q = g_pre_duty_q;
    g_load = g_pre_load;
    p = 0;
  }
  g_periods = p;
  if (static_cast<uint16_t>(p + 1u) == g_win_periods) preload_next_window();
#if defined(ACQ_RIPPLE_HZ)
  ripple::on_period(p, g_seq);
#endif
}

// The window close must not wait behind the other interrupts: its latency is
// the sample period jitter. So the ADC and encoder interrupts are
// interruptible (ISR_NOBLOCK: sei is their first instruction) and keep
// interrupts off only around the few instructions that must be atomic with
// respect to a window close (the only other interrupt that touches their
// data). Counted in the generated code: the close now waits at most about
// 10 (ADC) and 52 (encoder) cycles behind them instead of their whole length,
// about 150 and 120 cycles; docs/firmware.md has the measured jitter.
//
// ADC: a conversion belongs to the window open when its result is read.
// Reading ADC and the bank pointer in one atomic step keeps the two
// consistent. (An earlier interruptible version read ADC, then the bank
// index with interrupts on: a close between the two put a code of the closed
// window into the new one, which simavr shows at once because it samples the
// input when ADCL is read and the test changes the input at the close.)
// The conversion that just ended converted the channel in ADMUX (set when it
// was started), so ADMUX bit 0 selects V or I and no channel variable is needed.
static const uint8_t kAdcsraStart =
    _BV(ADEN) | _BV(ADIE) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0) | _BV(ADSC);  // 125 kHz ADC clock
ISR(ADC_vect, ISR_NOBLOCK) {
  cli();
  const uint16_t code = ADC;
  Acc* const acc = g_acc;
  sei();
#if defined(ACQ_RIPPLE_HZ)
  if (ripple::on_adc(code, acc)) return;
#endif
  const uint8_t mux = ADMUX;
  ADMUX = static_cast<uint8_t>(mux ^ 1u);  // the other channel for the next conversion
  ADCSRA = kAdcsraStart;                   // starts it: 13 ADC clocks
  Acc* const a = (mux & 1u) ? acc + 1 : acc;  // not acc[mux & 1]: avr-gcc shifts in a loop
  a->sum += code;
  ++a->n;
}

// Encoder: each call compares the pins with the last state it saw, so calls
// may come late or nest during the entry and exit code (an INT1 edge during
// an INT0 prologue, say): the later call just sees no change. Only reading
// the pins, the state update and the count update are atomic, so the close
// latches a whole count and no step is counted twice.
ISR(INT0_vect, ISR_NOBLOCK) {
  cli();
  const uint8_t pins = PIND;
  const uint8_t ab = static_cast<uint8_t>(((pins >> 1) & 2u) | ((pins >> 3) & 1u));  // A = PD2, B = PD3
  g_enc_total = g_enc_total + quadrature_step(g_enc_ab, ab);
  g_enc_ab = ab;
  sei();
}

ISR(INT1_vect, ISR_ALIASOF(INT0_vect));

ISR(TIMER2_COMPA_vect) {
  const uint8_t level = g_shifter.next(g_txq);
  // The level of the next bit, put on OC2A by the next compare match.
  TCCR2A = static_cast<uint8_t>(_BV(WGM21) | _BV(COM2A1) | (level ? _BV(COM2A0) : 0));
  if (level && !g_shifter.busy() && g_txq.empty()) TIMSK2 &= static_cast<uint8_t>(~_BV(OCIE2A));
}

namespace {

// ---------------------------------------------------------------- link
void link_begin() {
  DDRB |= kBitLink;
  TCCR2B = 0;
  TCNT2 = 0;
  OCR2A = static_cast<uint8_t>((kCpuHz / 8 + kLinkBaud / 2) / kLinkBaud - 1);  // 51: 52 ticks of 0.5 us a bit
  TCCR2A = _BV(WGM21) | _BV(COM2A1) | _BV(COM2A0);          // CTC, set OC2A on match: idle high
  TCCR2B = _BV(FOC2A);                                       // force it now
  TCCR2B = _BV(CS21);                                        // clk/8
  TIMSK2 = 0;
}

void link_send(const uint8_t* data, uint8_t n) {
  if (!g_txq.push(data, n)) return;
  if (!(TIMSK2 & _BV(OCIE2A))) {
    TIFR2 = _BV(OCF2A);
    TIMSK2 |= _BV(OCIE2A);
  }
}

bool link_idle() { return !(TIMSK2 & _BV(OCIE2A)); }

// ---------------------------------------------------------------- sampling setup
void set_next_setpoint(uint16_t duty_q, uint8_t load) {
  const uint16_t ocr = pwm_compare(g_pwm, duty_q);
  const uint8_t mode = duty_q == 0 ? kPwmOff : (duty_q >= 10000 ? kPwmOn : kPwmRun);
#if defined(ACQ_RIPPLE_HZ)
  const uint16_t ocr1b = ripple::trigger_for(g_pwm, ocr, duty_q);
#endif
  const uint8_t s = SREG;
  cli();
#if defined(ACQ_RIPPLE_HZ)
  g_next_ocr1b = ocr1b;
#endif
  g_next_duty_q = duty_q;
  g_next_load = load;
  g_next_ocr = ocr;
  g_next_mode = mode;
  SREG = s;
}

bool set_rate(float rate_hz) {
  const uint16_t n = periods_per_window(g_pwm, rate_hz);
  if (!n) return false;
  const uint32_t us = window_us(g_pwm, n);
  const uint8_t s = SREG;
  cli();
  g_next_win_periods = n;
  g_next_win_us = us;
#if defined(ACQ_RIPPLE_HZ)
  ripple::configure(g_pwm_hz, n, kRippleHostBaud);  // the burst length follows the window
#endif
  SREG = s;
  g_rate_hz = rate_hz;
  return true;
}

float actual_rate_hz() {
  const uint8_t s = SREG;
  cli();
  const uint32_t us = g_next_win_us;
  SREG = s;
  return 1.0e6f / static_cast<float>(us);
}

/// (Re)starts Timer1 at pwm_hz and a fresh window; the window in progress is dropped.
bool start_sampling(uint32_t pwm_hz) {
  PwmTiming t;
  if (!pwm_timing(pwm_hz, &t)) return false;
  const uint16_t n = periods_per_window(t, g_rate_hz);
  if (!n) return false;
#if defined(ACQ_RIPPLE_HZ)
  RippleTiming rt;
  if (!ripple_timing(pwm_hz, &rt)) return false;  // the PWM is the sample rate: 8..20 kHz
#endif
  const uint8_t s = SREG;
  cli();
#if defined(ACQ_RIPPLE_HZ)
  ripple::configure(pwm_hz, n, kRippleHostBaud);
#endif
  g_pwm = t;
  g_pwm_hz = pwm_hz;
  TCCR1B = 0;
  TIMSK1 = 0;
  TCNT1 = 0;
  ICR1 = t.top;
  g_next_win_periods = n;
  g_next_win_us = window_us(t, n);
  g_win_periods = n;
  g_win_us = g_next_win_us;
  g_periods = 0;
  for (uint8_t k = 0; k < 2; ++k) g_bank[k] = Bank();
  g_acc = g_bank[g_bank_i].ch;
  g_enc_prev = g_enc_total;
  g_seq = g_seq + 1u;  // the dropped window leaves a seq gap
  g_next_ocr = pwm_compare(t, g_next_duty_q);
#if defined(ACQ_RIPPLE_HZ)
  g_next_ocr1b = ripple::trigger_for(t, g_next_ocr, g_next_duty_q);
#endif
  preload_next_window();
  g_duty_q = g_pre_duty_q;
  g_load = g_pre_load;
  apply_pwm_mode(g_pre_mode);
  apply_relays(g_pre_load);
  TIFR1 = _BV(TOV1);
  TIMSK1 = _BV(TOIE1);
  TCCR1B = static_cast<uint8_t>(_BV(WGM13) | _BV(WGM12) | (t.prescale == 1 ? _BV(CS10) : _BV(CS11)));
  SREG = s;
  return true;
}

void adc_begin() {
  ADCSRA = 0;
  ADCSRB = 0;
  DIDR0 = _BV(ADC0D) | _BV(ADC1D);
  ADMUX = static_cast<uint8_t>(_BV(REFS0) | kAdcChannelV);  // AVcc reference
  ADCSRA = kAdcsraStart;
}

void encoder_begin() {
  DDRD &= static_cast<uint8_t>(~(_BV(PD2) | _BV(PD3)));
  PORTD |= _BV(PD2) | _BV(PD3);  // pull-ups for open-collector encoders
  const uint8_t pins = PIND;
  g_enc_ab = static_cast<uint8_t>(((pins >> 1) & 2u) | ((pins >> 3) & 1u));
  EICRA = _BV(ISC00) | _BV(ISC10);  // any edge
  EIFR = _BV(INTF0) | _BV(INTF1);
  EIMSK = _BV(INT0) | _BV(INT1);
}

// ---------------------------------------------------------------- DS18B20, one small step at a time
bool ow_reset() {
  PORTD &= static_cast<uint8_t>(~kBitOneWire);
  DDRD |= kBitOneWire;
  delayMicroseconds(480);
  DDRD &= static_cast<uint8_t>(~kBitOneWire);
  delayMicroseconds(70);
  const bool present = !(PIND & kBitOneWire);
  delayMicroseconds(410);
  return present;
}

void ow_write_byte(uint8_t b) {
  for (uint8_t k = 0; k < 8; ++k, b = static_cast<uint8_t>(b >> 1)) {
    const uint8_t s = SREG;
    cli();
    DDRD |= kBitOneWire;
    if (b & 1u) {
      delayMicroseconds(5);
      DDRD &= static_cast<uint8_t>(~kBitOneWire);
      SREG = s;
      delayMicroseconds(60);
    } else {
      SREG = s;  // a longer low slot is still a valid 0 (60..120 us)
      delayMicroseconds(62);
      DDRD &= static_cast<uint8_t>(~kBitOneWire);
      delayMicroseconds(4);
    }
  }
}

uint8_t ow_read_byte() {
  uint8_t b = 0;
  for (uint8_t k = 0; k < 8; ++k) {
    const uint8_t s = SREG;
    cli();
    DDRD |= kBitOneWire;
    delayMicroseconds(3);
    DDRD &= static_cast<uint8_t>(~kBitOneWire);
    delayMicroseconds(9);
    const uint8_t bit = (PIND & kBitOneWire) ? 1u : 0u;
    SREG = s;
    b = static_cast<uint8_t>(b | (bit << k));
    delayMicroseconds(55);
  }
  return b;
}

struct OneWireJob {
  uint8_t step;   // 0: idle
  bool reading;
  uint8_t pad[9];
} g_ow = {0, false, {0}};

/// True when a bus step (at most ~1 ms, with interrupt-free slots of ~12 us)
/// can neither delay a window close nor a link bit: the link is idle and the
/// open window has more than 2 ms to go.
bool onewire_slot_free() {
  if (!link_idle()) return false;
#if defined(ACQ_RIPPLE_HZ)
  if (ripple::g.left) return false;  // a bus step (up to 1 ms) would fill the burst's ring
#endif
  const uint8_t s = SREG;
  cli();
  const uint16_t left = static_cast<uint16_t>(g_win_periods - g_periods);
  SREG = s;
  return static_cast<uint32_t>(left) * pwm_period_cycles(g_pwm) > 2UL * (kCpuHz / 1000UL);
}

void temperature_step() {
  const uint32_t now = millis();
  if (g_ow.step == 0) {
    const TempSchedule::Action a = g_temp.poll(now);
    if (a == TempSchedule::kIdle) return;
    g_ow.reading = a == TempSchedule::kReadScratchpad;
    g_ow.step = 1;
  }
  if (!onewire_slot_free()) return;
  const uint8_t st = g_ow.step;
  if (st == 1) {
    if (!ow_reset()) {
      if (g_ow.reading) g_temp.read(now, false, 0); else g_temp.started(now, false);
      g_ow.step = 0;
      return;
    }
  } else if (st == 2) {
    ow_write_byte(0xCC);  // skip ROM: the one sensor on the bus
  } else if (st == 3) {
    ow_write_byte(g_ow.reading ? 0xBE : 0x44);  // read scratchpad / convert T
    if (!g_ow.reading) {
      g_temp.started(now, true);
      g_ow.step = 0;
      return;
    }
  } else {
    g_ow.pad[st - 4] = ow_read_byte();
    if (st == 12) {
      int16_t t = 0;
      const bool ok = ds18b20_decode(g_ow.pad, &t);
      g_temp.read(now, ok, t);
      g_ow.step = 0;
      return;
    }
  }
  g_ow.step = static_cast<uint8_t>(st + 1);
}

// ---------------------------------------------------------------- host output
char g_line[kLineMax];

void say(const char* text) {
  Serial.write('!');
  Serial.write(' ');
  Serial.write(text);
  Serial.write('\n');
}

void say(const __FlashStringHelper* text) {
  Serial.write('!');
  Serial.write(' ');
  Serial.print(text);
  Serial.write('\n');
}

void print_status(const char* head) {
  LineWriter w(g_line, sizeof g_line);
  w.str(head);
  w.str(" rate=");
  w.compact(actual_rate_hz());
  w.str(" pwm=");
  w.u32(g_pwm_hz);
  w.str(" duty=");
  w.fixed(g_next_duty_q, 4);
  w.str(" load=");
  w.u32(g_next_load);
  w.str(" hold=");
  w.compact(g_hold_s);
  w.str(" long=");
  w.compact(g_long_s);
  w.str(" rec=");
  w.u32(g_recording ? 1u : 0u);
  w.str(" overruns=");
  w.u32(g_overruns);
  w.str(" link_drops=");
  w.u32(g_txq.dropped());
#if defined(ACQ_RIPPLE_HZ)
  w.str(" ripple_n=");
  w.u32(ripple::g.burst_n);
  w.str(" ripple_lost=");
  w.u32(static_cast<uint32_t>(ripple::g.not_started) + ripple::g.overflows);
  w.str(" ring_peak=");
  w.u32(ripple::g_ring.peak());
#endif
  say(w.c_str());
}

void meta(const __FlashStringHelper* key, const char* value) {
  Serial.write('#');
  Serial.write(' ');
  Serial.print(key);
  Serial.write('=');
  Serial.write(value);
  Serial.write('\n');
}

// One "# key=value" line of a number (compact: up to 4 decimals; u32: a whole number), out of
// line: each metadata line a call of a few instructions, not the writer inlined at each (154
// bytes of flash less in the counting build, 78 in the normal one, than each line written in
// begin_recording; the same lines).
__attribute__((noinline)) void meta_compact(const __FlashStringHelper* key, float value) {
  LineWriter w(g_line, sizeof g_line);
  w.compact(value);
  meta(key, g_line);
}

__attribute__((noinline)) void meta_u32(const __FlashStringHelper* key, uint32_t value) {
  LineWriter w(g_line, sizeof g_line);
  w.u32(value);
  meta(key, g_line);
}

void begin_recording(const char* condition, uint32_t first_seq) {
  meta(F("condition"), condition);
  meta_compact(F("sample_rate_hz"), actual_rate_hz());
  meta(F("motor"), kMotor);
  meta(F("firmware"), kVersion);
  meta_u32(F("pwm_hz"), g_pwm_hz);
  meta_compact(F("divider_ratio"), kCalibration.divider_ratio);
  meta_compact(F("shunt_ohm"), kCalibration.shunt_ohm);
  meta_compact(F("adc_ref_V"), kCalibration.adc_ref_V);
  meta_compact(F("encoder_cpr"), kEncoderCountsPerRev);
#if defined(ACQ_RIPPLE_HZ)
  // The bursts ("~" lines): hpddo capture writes them to <condition>.ripple.csv.
  meta_u32(F("ripple_hz"), g_pwm_hz);
  meta_u32(F("ripple_n"), ripple::g.burst_n);
  meta_compact(F("shunt_gain"), kCalibration.shunt_gain);
#endif
  Serial.print(reinterpret_cast<const __FlashStringHelper*>(kLogHeader));
#if !defined(ACQ_NO_OBSERVER)
  Serial.print(reinterpret_cast<const __FlashStringHelper*>(kLogHeaderEstimate));
#if defined(ACQ_RIPPLE_HZ) && ACQ_RIPPLE_COUNT
  Serial.print(reinterpret_cast<const __FlashStringHelper*>(ripple::kLogHeaderRipple));
#endif
  g_obs.reset();
#endif
  Serial.write('\n');
  g_rec_start = first_seq;
  g_recording = true;
#if defined(ACQ_RIPPLE_HZ) && ACQ_RIPPLE_COUNT
  ripple::on_recording(first_seq);
#endif
}

uint32_t open_seq() {
  const uint8_t s = SREG;
  cli();
  const uint32_t q = g_seq;
  SREG = s;
  return q;
}

void end_recording(const char* why) {
  if (!g_recording) return;
  g_recording = false;
  LineWriter w(g_line, sizeof g_line);
  w.str("end ");
  w.str(why);
  w.str(" overruns=");
  w.u32(g_overruns);
  say(w.c_str());
  if (g_plan.protocol() != kProtoNone) {
    g_plan = ProtocolPlan();
    set_next_setpoint(0, 0);
  }
}

void handle_command(const char* line) {
  const Command c = parse_command(line);
  const bool busy = g_recording;
  switch (c.kind) {
    case kCmdNone: return;
    case kCmdRun: {
      if (busy) return say(F("error busy: stop first"));
      const uint32_t hold = samples_for(step_seconds(c.protocol, g_hold_s), actual_rate_hz());
      const uint32_t len = samples_for(g_long_s, actual_rate_hz());
      g_plan = ProtocolPlan(c.protocol, hold, len);
      // The window after the open one may already have its setpoint latched:
      // the protocol starts with the one after that.
      const uint32_t first = open_seq() + 2u;
      Setpoint sp;
      g_plan.at(0, &sp);
      set_next_setpoint(sp.duty_q, sp.load);
      begin_recording(protocol_name(c.protocol), first);
      return;
    }
    case kCmdRec:
      if (busy) return say(F("error busy: stop first"));
      begin_recording(c.word, open_seq() + 1u);
      return;
    case kCmdStop:
      if (g_recording) end_recording("stopped");
      g_plan = ProtocolPlan();
      g_manual_duty_q = 0;
      g_manual_load = 0;
      set_next_setpoint(0, 0);
      return say(F("ok stop"));
    case kCmdDuty:
    case kCmdLoad:
      if (g_plan.protocol() != kProtoNone) return say(F("error busy: a protocol runs"));
      if (c.kind == kCmdDuty) g_manual_duty_q = static_cast<uint16_t>(c.value * 10000.0f + 0.5f);
      else g_manual_load = static_cast<uint8_t>(c.value);
      set_next_setpoint(g_manual_duty_q, g_manual_load);
      return print_status("ok");
    case kCmdRate:
      if (busy) return say(F("error busy: stop first"));
      if (!set_rate(c.value)) return say(F("error rate"));
      return print_status("ok");
    case kCmdPwm:
      if (busy) return say(F("error busy: stop first"));
      if (!start_sampling(static_cast<uint32_t>(c.value + 0.5f))) return say(F("error pwm"));
      set_next_setpoint(g_manual_duty_q, g_manual_load);
      return print_status("ok");
    case kCmdHold:
      g_hold_s = c.value;
      return print_status("ok");
    case kCmdLong:
      g_long_s = c.value;
      return print_status("ok");
    case kCmdStatus:
      return print_status("status");
#if defined(ACQ_RIPPLE_HZ) && ACQ_COAST
    case kCmdCoast:  // a probe every ripple::g.coast_every windows from the next one on (acq_coast.h)
      ripple::g.coast_off = c.value == 0.0f;
      return print_status("ok");
#endif
    case kCmdHelp:
      return say(F("commands: run sweep|load|long, rec [condition], stop, duty <0..1>, load <0..2>, "
                   "rate <Hz>, pwm <Hz>, hold <s>, long <s>, status"));
    default:
      return say(F("error unknown command (try help)"));
  }
}

void process(const WindowSums& w) {
  const Measurement m = measure(w, kCalibration, kEncoderCountsPerRev);
  int16_t temp_c16 = 0;
  const bool has_temp = g_temp.current(millis(), &temp_c16);

  uint8_t frame[hpddo::kFrameSize];
  hpddo::encode_frame(make_frame(w, m, has_temp, temp_c16), frame);
  link_send(frame, hpddo::kFrameSize);

#if !defined(ACQ_NO_OBSERVER)
  hpddo::Sample s;
  s.v_V = m.v_V;
  s.i_A = m.i_A;
  s.temp_C = has_temp ? static_cast<float>(temp_c16) * 0.0625f : hpddo::absent();
  s.dt_s = static_cast<float>(w.period_us) * 1e-6f;
  s.seq = static_cast<uint16_t>(w.seq);
  s.has_seq = true;
  GPIOR1 = 3;  // observer marker (timed in simulation)
  const hpddo::Estimate est = g_obs.step(s);
  GPIOR1 = 4;
#if defined(ACQ_RIPPLE_HZ) && ACQ_RIPPLE_COUNT
  GPIOR1 = 5;  // ripple counter's window marker (timed in simulation)
  const ripple::WindowRipple rip = ripple::on_window(model::kModel.physics, w.seq, m.v_V, m.i_A, s.dt_s, est.rpm);
  GPIOR1 = 6;
#endif
#endif

  if (g_plan.protocol() != kProtoNone) {
    // Setpoint of the window after the open one (latched at the end of the open one).
    const uint32_t next = open_seq() + 1u;
    Setpoint sp = {0, 0};
    if (next >= g_rec_start) {
      if (!g_plan.at(next - g_rec_start, &sp)) sp.duty_q = 0, sp.load = 0;
    } else {
      g_plan.at(0, &sp);
    }
    set_next_setpoint(sp.duty_q, sp.load);
  }

  if (g_recording && static_cast<int32_t>(w.seq - g_rec_start) >= 0) {
    LogRow r;
    r.elapsed_samples = w.seq - g_rec_start;
    r.period_us = w.period_us;
    r.duty_q = w.duty_q;
    r.v_V = m.v_V;
    r.i_A = m.i_A;
    r.rpm = m.rpm;
    r.has_temp = has_temp;
    r.temp_c16 = temp_c16;
    r.load = w.load;
    r.seq = w.seq;
    LineWriter lw(g_line, sizeof g_line);
    format_row(lw, r);
#if !defined(ACQ_NO_OBSERVER)
    format_estimate(lw, est.rpm, static_cast<uint8_t>(est.status));
#if defined(ACQ_RIPPLE_HZ) && ACQ_RIPPLE_COUNT
    ripple::format_window(lw, rip);
#endif
#endif
    lw.put('\n');
    Serial.write(lw.c_str(), lw.length());
    if (g_plan.protocol() != kProtoNone && r.elapsed_samples + 1u >= g_plan.total()) {
      end_recording(protocol_name(g_plan.protocol()));
    }
  }
}

}  // namespace

void setup() {
  apply_relays(0);
  DDRD |= kBitRelay1;
  DDRB |= kBitRelay2 | kBitPwm;
  PORTB &= static_cast<uint8_t>(~kBitPwm);
#if defined(ACQ_RIPPLE_HZ)
  Serial.begin(kRippleHostBaud);
#else
  Serial.begin(kHostBaud);
#endif
  link_begin();
  encoder_begin();
  set_next_setpoint(0, 0);
#if defined(ACQ_RIPPLE_HZ)
  start_sampling(ACQ_RIPPLE_HZ);
#else
  start_sampling(kDefaultPwmHz);
#endif
  adc_begin();
  print_status("uno_acq 1 ready");
}

void loop() {
  while (Serial.available() > 0) {
    if (g_cmd.push(static_cast<char>(Serial.read()))) {
      handle_command(g_cmd.line());
      g_cmd.clear();
    }
  }
  if (g_ready) {
    cli();
    const Closed c = g_closed;
    g_ready = false;
    sei();
    // The ADC fills the other bank now; this one is ours until the next close.
    Bank& b = g_bank[c.bank];
    WindowSums w;
    w.seq = c.seq;
    w.sum_v = b.ch[0].sum;
    w.sum_i = b.ch[1].sum;
    w.n_v = b.ch[0].n;
    w.n_i = b.ch[1].n;
    b = Bank();
    w.enc_counts = c.enc_total - g_enc_prev;
    g_enc_prev = c.enc_total;
    w.period_us = c.period_us;
    w.duty_q = c.duty_q;
    w.load = c.load;
    GPIOR1 = 1;  // busy marker: the main loop's work on a window (timed in simulation)
    process(w);
    GPIOR1 = 2;
  }
#if defined(ACQ_RIPPLE_HZ)
  ripple::drain(g_recording, g_rec_start, [](const char* text, uint8_t n) { Serial.write(text, n); });
#endif
#ifndef ACQ_NO_TEMP
  temperature_step();
#endif
}
