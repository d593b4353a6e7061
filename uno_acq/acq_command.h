// Serial commands of the acquisition board, one per line:
//
//   run sweep|load|long   start a protocol and a recording of it
//   rec [condition]       start a recording by hand (condition defaults to manual)
//   stop                  end the protocol or recording; duty 0, loads off
//   duty <0..1>           PWM duty by hand
//   load <0..2>           load relays by hand
//   rate <Hz>             sample rate (not while recording)
//   pwm <Hz>              PWM frequency, 31..100000 (not while recording)
//   hold <s>              step length of sweep and load (0: the bench's, 30 s and 25 s)
//   long <s>              length of long
//   coast 0|1             coast probes off / on (the ripple build with -DACQ_COAST=1; acq_coast.h)
//   status, help
#ifndef HPDDO_ACQ_COMMAND_H
#define HPDDO_ACQ_COMMAND_H

#include <stdint.h>

#include "acq_protocol.h"
#include "hpddo/limits.h"

namespace acq {

enum CommandKind : uint8_t {
  kCmdNone = 0,   ///< empty line
  kCmdBad,        ///< not understood
  kCmdRun,
  kCmdRec,
  kCmdStop,
  kCmdDuty,
  kCmdLoad,
  kCmdRate,
  kCmdPwm,
  kCmdHold,
  kCmdLong,
  kCmdStatus,
  kCmdHelp,
  kCmdCoast,
};

/// A parsed command line.
struct Command {
  CommandKind kind;
  Protocol protocol;  ///< for run
  float value;        ///< for duty, load, rate, pwm, hold, long, coast
  char word[16];      ///< for rec: the condition word
};

namespace detail {
inline bool word_eq(const char* s, const char* end, const char* w) {
  while (s < end && *w && *s == *w) {
    ++s;
    ++w;
  }
  return s == end && *w == '\0';
}
inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

/// Parses a plain decimal number ("12", "-0.5", ".25") spanning [s, end).
inline bool parse_number(const char* s, const char* end, float* out) {
  bool neg = false;
  if (s < end && (*s == '-' || *s == '+')) neg = (*s++ == '-');
  float v = 0.0f;
  float scale = 1.0f;
  bool digits = false;
  bool dot = false;
  for (; s < end; ++s) {
    if (*s >= '0' && *s <= '9') {
      digits = true;
      if (dot) {
        scale *= 0.1f;
        v += static_cast<float>(*s - '0') * scale;
      } else {
        v = v * 10.0f + static_cast<float>(*s - '0');
      }
    } else if (*s == '.' && !dot) {
      dot = true;
    } else {
      return false;
    }
  }
  if (!digits) return false;
  *out = neg ? -v : v;
  return true;
}
}  // namespace detail

/// Parses one line (without or with its line ending).
inline Command parse_command(const char* line) {
  Command c;
  c.kind = kCmdBad;
  c.protocol = kProtoNone;
  c.value = 0.0f;
  c.word[0] = '\0';
  const char* tok[3];
  const char* tend[3];
  uint8_t n = 0;
  const char* p = line;
  while (*p) {
    while (*p && detail::is_space(*p)) ++p;
    if (!*p) break;
    if (n == 3) return c;
    tok[n] = p;
    while (*p && !detail::is_space(*p)) ++p;
    tend[n++] = p;
  }
  if (n == 0) {
    c.kind = kCmdNone;
    return c;
  }
  const char* s = tok[0];
  const char* e = tend[0];
  if (n == 1) {
    if (detail::word_eq(s, e, "stop")) c.kind = kCmdStop;
    else if (detail::word_eq(s, e, "status")) c.kind = kCmdStatus;
    else if (detail::word_eq(s, e, "help")) c.kind = kCmdHelp;
    else if (detail::word_eq(s, e, "rec")) {
      c.kind = kCmdRec;
      const char m[] = "manual";
      for (uint8_t k = 0; k < sizeof m; ++k) c.word[k] = m[k];
    }
    return c;
  }
  if (n != 2) return c;
  const char* a = tok[1];
  const char* ae = tend[1];
  if (detail::word_eq(s, e, "run")) {
    if (detail::word_eq(a, ae, "sweep")) c.protocol = kProtoSweep;
    else if (detail::word_eq(a, ae, "load")) c.protocol = kProtoLoad;
    else if (detail::word_eq(a, ae, "long")) c.protocol = kProtoLong;
    else return c;
    c.kind = kCmdRun;
    return c;
  }
  if (detail::word_eq(s, e, "rec")) {
    if (ae - a >= static_cast<long>(sizeof c.word)) return c;
    uint8_t k = 0;
    for (const char* q = a; q < ae; ++q) {
      const char ch = *q;
      const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
                      ch == '_' || ch == '-';
      if (!ok) return c;
      c.word[k++] = ch;
    }
    c.word[k] = '\0';
    c.kind = kCmdRec;
    return c;
  }
  float v = 0.0f;
  if (!detail::parse_number(a, ae, &v)) return c;
  c.value = v;
  if (detail::word_eq(s, e, "duty")) c.kind = (v >= 0.0f && v <= 1.0f) ? kCmdDuty : kCmdBad;
  else if (detail::word_eq(s, e, "load")) c.kind = (v == 0.0f || v == 1.0f || v == 2.0f) ? kCmdLoad : kCmdBad;
  else if (detail::word_eq(s, e, "rate")) c.kind = (v >= hpddo::kAcqRateMin_Hz && v <= hpddo::kAcqRateMax_Hz) ? kCmdRate : kCmdBad;
  else if (detail::word_eq(s, e, "pwm")) c.kind = (v >= 31.0f && v <= 100000.0f) ? kCmdPwm : kCmdBad;
  else if (detail::word_eq(s, e, "hold")) c.kind = (v >= 0.0f && v <= 86400.0f) ? kCmdHold : kCmdBad;
  else if (detail::word_eq(s, e, "long")) c.kind = (v > 0.0f && v <= 604800.0f) ? kCmdLong : kCmdBad;
#if !defined(ARDUINO) || ACQ_COAST  // the board parses it only in the build that has the probe (68 bytes)
  else if (detail::word_eq(s, e, "coast")) c.kind = (v == 0.0f || v == 1.0f) ? kCmdCoast : kCmdBad;
#endif
  return c;
}

/// Collects serial bytes into lines; over-long lines are dropped whole.
template <uint8_t N>
class LineBuffer {
 public:
  constexpr LineBuffer() : buf_(), len_(0), overflow_(false) {}  // an empty line
  /// Feeds a byte; true when a line is complete (read it with line()).
  bool push(char c) {
    if (c == '\n' || c == '\r') {
      const bool done = !overflow_ && len_ > 0;
      buf_[len_] = '\0';
      if (!done) len_ = 0;
      overflow_ = false;
      return done;
    }
    if (len_ + 1 >= N) {
      overflow_ = true;
      len_ = 0;
      return false;
    }
    buf_[len_++] = c;
    return false;
  }
  /// The completed line; call clear() after handling it.
  const char* line() const { return buf_; }
  void clear() {
    len_ = 0;
    buf_[0] = '\0';
  }

 private:
  char buf_[N];
  uint8_t len_;
  bool overflow_;
};

}  // namespace acq

#endif  // HPDDO_ACQ_COMMAND_H
