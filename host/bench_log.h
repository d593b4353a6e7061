// Host-side reader of bench logs for the native tools. The format is specified in
// docs/bench-log.md; this reader and tools/hpddo/logs/benchlog.py follow it exactly (same
// accept/refuse, same first fault line and keyword, same values), held to it by the
// conformance corpus test/fixtures/logs/ and a differential fuzz test.
#ifndef HPDDO_HOST_BENCH_LOG_H
#define HPDDO_HOST_BENCH_LOG_H

#include <algorithm>
#include <charconv>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "hpddo/limits.h"

namespace hpddo_host {

/// A format fault; what() is "file:line: message", fault() the keyword of docs/bench-log.md.
struct LogError : std::runtime_error {
  LogError(const std::string& path, size_t line, const std::string& fault, const std::string& message)
      : std::runtime_error(line ? path + ":" + std::to_string(line) + ": " + message : path + ": " + message),
        line_(line),
        fault_(fault) {}
  /// The 1-based file line of the fault, 0 when the file could not be read at all.
  size_t line() const { return line_; }
  /// The fault keyword (docs/bench-log.md, Faults), e.g. "non-numeric".
  const std::string& fault() const { return fault_; }

 private:
  size_t line_;
  std::string fault_;
};

/// A file's name without its folder and its extension: "a/b/load.csv" -> "load".
inline std::string file_stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = name.find_last_of('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

/// The columns the observer and the metrics need; optional ones are NaN where absent.
struct BenchLog {
  std::string path;
  std::map<std::string, std::string> meta;
  std::vector<double> t_s, duty, v_V, i_A, rpm_ref, temp_C;
  std::vector<std::int64_t> load;  ///< the log's load, or 0 when the log has none
  std::vector<std::int64_t> seq;   ///< the log's seq, or the row index when the log has none
  std::vector<size_t> lines;       ///< 1-based file line of each row
  bool has_rpm_ref = false, has_temp_C = false, has_load = false, has_seq = false;

  size_t size() const { return t_s.size(); }
  std::string condition() const {
    auto it = meta.find("condition");
    if (it != meta.end() && !it->second.empty()) return it->second;
    return file_stem(path);
  }
};

namespace detail {

/// Largest value of the integer columns (docs/bench-log.md, Integers).
constexpr std::uint64_t kLoadMax = 255;
constexpr std::uint64_t kSeqMax = (std::uint64_t{1} << 53) - 1;

inline std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  size_t start = 0;
  for (;;) {
    const size_t comma = line.find(',', start);
    out.push_back(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

/// Removes the format's only padding, ASCII space and tab, from both ends.
inline std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

inline bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// Offset of the first byte that is not well-formed UTF-8 (Unicode table 3-7), or npos.
inline size_t first_bad_utf8(std::string_view s) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const size_t n = s.size();
  size_t i = 0;
  while (i < n) {
    const unsigned c = p[i];
    if (c < 0x80) {
      ++i;
      continue;
    }
    size_t len = 0;
    unsigned lo = 0x80, hi = 0xBF;  // range of the second byte
    if (c >= 0xC2 && c <= 0xDF) len = 2;
    else if (c == 0xE0) len = 3, lo = 0xA0;
    else if (c >= 0xE1 && c <= 0xEC) len = 3;
    else if (c == 0xED) len = 3, hi = 0x9F;
    else if (c >= 0xEE && c <= 0xEF) len = 3;
    else if (c == 0xF0) len = 4, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3) len = 4;
    else if (c == 0xF4) len = 4, hi = 0x8F;
    else return i;
    if (i + 1 >= n || p[i + 1] < lo || p[i + 1] > hi) return i;
    for (size_t k = 2; k < len; ++k)
      if (i + k >= n || p[i + k] < 0x80 || p[i + k] > 0xBF) return i;
    i += len;
  }
  return std::string_view::npos;
}

/// How a number cell reads: a value, or which fault.
enum class Number { kOk, kNonFinite, kNonNumeric, kOutOfRange };

inline bool iequals(std::string_view s, std::string_view lower) {
  if (s.size() != lower.size()) return false;
  for (size_t k = 0; k < s.size(); ++k) {
    const char c = (s[k] >= 'A' && s[k] <= 'Z') ? static_cast<char>(s[k] - 'A' + 'a') : s[k];
    if (c != lower[k]) return false;
  }
  return true;
}

/// Reads a trimmed number cell by the grammar of docs/bench-log.md (Numbers).
inline Number parse_number(std::string_view s, double* out) {
  std::string_view word = s;
  if (!word.empty() && (word.front() == '+' || word.front() == '-')) word.remove_prefix(1);
  if (iequals(word, "inf") || iequals(word, "infinity") || iequals(word, "nan")) return Number::kNonFinite;
  // grammar: [sign] (digits ["." [digits]] | "." digits) [(e|E) [sign] digits]
  size_t k = s.size() - word.size();
  size_t int_digits = 0, frac_digits = 0;
  bool nonzero = false;
  while (k < s.size() && is_digit(s[k])) nonzero |= s[k++] != '0', ++int_digits;
  if (k < s.size() && s[k] == '.') {
    ++k;
    while (k < s.size() && is_digit(s[k])) nonzero |= s[k++] != '0', ++frac_digits;
  }
  if (int_digits + frac_digits == 0) return Number::kNonNumeric;
  if (k < s.size() && (s[k] == 'e' || s[k] == 'E')) {
    ++k;
    if (k < s.size() && (s[k] == '+' || s[k] == '-')) ++k;
    size_t exp_digits = 0;
    while (k < s.size() && is_digit(s[k])) ++k, ++exp_digits;
    if (exp_digits == 0) return Number::kNonNumeric;
  }
  if (k != s.size()) return Number::kNonNumeric;
  const char* first = s.data() + (s.front() == '+' ? 1 : 0);  // from_chars takes no '+'
  double x = 0.0;
  const auto res = std::from_chars(first, s.data() + s.size(), x, std::chars_format::general);
  if (res.ec == std::errc::result_out_of_range) return Number::kOutOfRange;
  if (res.ec != std::errc() || res.ptr != s.data() + s.size()) return Number::kNonNumeric;
  // the double must state the decimal: not infinite, not zero or subnormal for a non-zero text
  if (std::isinf(x) || (x != 0.0 && std::fabs(x) < DBL_MIN) || (x == 0.0 && nonzero)) return Number::kOutOfRange;
  *out = x;
  return Number::kOk;
}

/// What one column of the file is to the reader.
enum class Role { kExtra, kT, kDuty, kV, kI, kRpm, kTemp, kLoad, kSeq };

inline Role role_of(std::string_view name) {
  if (name == "t_s") return Role::kT;
  if (name == "duty") return Role::kDuty;
  if (name == "v_V") return Role::kV;
  if (name == "i_A") return Role::kI;
  if (name == "rpm_ref") return Role::kRpm;
  if (name == "temp_C") return Role::kTemp;
  if (name == "load") return Role::kLoad;
  if (name == "seq") return Role::kSeq;
  return Role::kExtra;
}

inline std::string quoted(std::string_view s) { return "'" + std::string(s) + "'"; }

inline bool is_key_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || is_digit(c) || c == '_' || c == '.' || c == '-';
}

}  // namespace detail

/// Parses the bytes of a bench log (path only names it in faults); throws LogError.
inline BenchLog parse_bench_log(const std::string& path, std::string_view text) {
  using detail::Number;
  using detail::Role;
  auto fail = [&path](size_t line, const char* fault, const std::string& message) {
    throw LogError(path, line, fault, message);
  };
  if (text.size() >= 3 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  if (text.empty()) fail(1, "empty file", "empty file");
  const size_t bad = detail::first_bad_utf8(text);
  if (bad != std::string_view::npos) {
    static const char* kHex = "0123456789abcdef";
    const auto b = static_cast<unsigned char>(text[bad]);
    const size_t line = static_cast<size_t>(std::count(text.begin(), text.begin() + static_cast<long>(bad), '\n')) + 1;
    fail(line, "not UTF-8", std::string("not UTF-8 text (byte 0x") + kHex[b >> 4] + kHex[b & 15] + ")");
  }

  BenchLog log;
  log.path = path;
  std::vector<Role> roles;
  size_t header_line = 0;
  size_t lineno = 0;
  double prev_t = 0.0;
  std::string_view rest = text;
  while (!rest.empty()) {
    const size_t nl = rest.find('\n');
    std::string_view line = rest.substr(0, nl);
    rest = nl == std::string_view::npos ? std::string_view() : rest.substr(nl + 1);
    ++lineno;
    if (nl != std::string_view::npos && !line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.find('\r') != std::string_view::npos)
      fail(lineno, "carriage return", "carriage return inside a line (only CR LF ends a line)");
    if (detail::trim(line).empty()) fail(lineno, "blank line", "blank line");

    if (!header_line) {
      if (line.front() == '#') {  // metadata: '#' [pad] key [pad] '=' value
        const size_t eq = line.find('=');
        const std::string_view key = eq == std::string_view::npos ? std::string_view() : detail::trim(line.substr(1, eq - 1));
        bool ok = !key.empty();
        for (char c : key) ok = ok && detail::is_key_char(c);
        if (!ok)
          fail(lineno, "malformed metadata",
               "malformed metadata line " + detail::quoted(line) +
                   " (expected '# key=value', key of A-Z a-z 0-9 _ . -)");
        const std::string k(key);
        if (log.meta.count(k)) fail(lineno, "duplicate metadata key", "duplicate metadata key " + detail::quoted(k));
        log.meta[k] = std::string(detail::trim(line.substr(eq + 1)));
        continue;
      }
      std::vector<std::string> names;
      for (const std::string_view field : detail::split(line)) {
        const std::string name(detail::trim(field));
        if (name.empty()) fail(lineno, "empty column name", "empty column name in header");
        for (const auto& seen : names)
          if (seen == name) fail(lineno, "duplicate column", "duplicate column " + detail::quoted(name) + " in header");
        names.push_back(name);
        roles.push_back(detail::role_of(name));
      }
      std::string missing;
      const char* required[] = {"t_s", "duty", "v_V", "i_A"};
      for (const char* r : required) {
        bool found = false;
        for (const auto& n : names) found = found || n == r;
        if (!found) missing += (missing.empty() ? "" : ", ") + std::string(r);
      }
      if (!missing.empty())
        fail(lineno, "missing required column", "missing required column(s) " + missing + " in header");
      for (Role r : roles) {
        log.has_rpm_ref = log.has_rpm_ref || r == Role::kRpm;
        log.has_temp_C = log.has_temp_C || r == Role::kTemp;
        log.has_load = log.has_load || r == Role::kLoad;
        log.has_seq = log.has_seq || r == Role::kSeq;
      }
      header_line = lineno;
      continue;
    }

    if (line.front() == '#') fail(lineno, "metadata after header", "metadata after header: " + detail::quoted(line));
    const auto cells = detail::split(line);
    if (cells.size() != roles.size())
      fail(lineno, "field count",
           "field count: row has " + std::to_string(cells.size()) + " fields, header has " +
               std::to_string(roles.size()));
    const size_t row = log.size();
    double t = 0, d = 0, v = 0, i = 0, rpm = std::nan(""), temp = std::nan("");
    std::int64_t load = 0, seq = static_cast<std::int64_t>(row);
    for (size_t c = 0; c < cells.size(); ++c) {
      const Role role = roles[c];
      if (role == Role::kExtra) continue;
      const std::string_view s = detail::trim(cells[c]);
      const char* name = role == Role::kT ? "t_s" : role == Role::kDuty ? "duty" : role == Role::kV ? "v_V"
                         : role == Role::kI ? "i_A" : role == Role::kRpm ? "rpm_ref" : role == Role::kTemp ? "temp_C"
                         : role == Role::kLoad ? "load" : "seq";
      if (role == Role::kLoad || role == Role::kSeq) {
        if (s.empty()) fail(lineno, "empty value", std::string("empty value in column ") + name);
        for (char ch : s)
          if (!detail::is_digit(ch))
            fail(lineno, "non-integer", "non-integer value " + detail::quoted(s) + " in column " + name + " (digits only)");
        const std::uint64_t max = role == Role::kLoad ? detail::kLoadMax : detail::kSeqMax;
        std::uint64_t n = 0;
        for (char ch : s) {
          n = n * 10 + static_cast<std::uint64_t>(ch - '0');
          if (n > max)
            fail(lineno, "out of range",
                 "out of range value " + detail::quoted(s) + " in column " + name + " (0.." + std::to_string(max) + ")");
        }
        (role == Role::kLoad ? load : seq) = static_cast<std::int64_t>(n);
        continue;
      }
      const bool optional = role == Role::kRpm || role == Role::kTemp;
      if (s.empty()) {
        if (optional) continue;  // not measured: NaN
        fail(lineno, "empty value", std::string("empty value in required column ") + name);
      }
      double x = 0.0;
      switch (detail::parse_number(s, &x)) {
        case Number::kOk: break;
        case Number::kNonFinite:
          fail(lineno, "non-finite", "non-finite value " + detail::quoted(s) + " in column " + name);
          break;
        case Number::kNonNumeric:
          fail(lineno, "non-numeric", "non-numeric value " + detail::quoted(s) + " in column " + name);
          break;
        case Number::kOutOfRange:
          fail(lineno, "out of range", "out of range value " + detail::quoted(s) + " in column " + name);
          break;
      }
      switch (role) {
        case Role::kT:
          if (row > 0 && !(x > prev_t))
            fail(lineno, "t_s not increasing", "t_s not increasing: " + std::string(s) + " after " + std::to_string(prev_t));
          t = x;
          break;
        case Role::kDuty:
          if (x < 0.0 || x > 1.0) fail(lineno, "duty outside 0..1", "duty outside 0..1: " + std::string(s));
          d = x;
          break;
        case Role::kV: v = x; break;
        case Role::kI: i = x; break;
        case Role::kRpm: rpm = x; break;
        case Role::kTemp: temp = x; break;
        default: break;
      }
    }
    prev_t = t;
    log.t_s.push_back(t);
    log.duty.push_back(d);
    log.v_V.push_back(v);
    log.i_A.push_back(i);
    log.rpm_ref.push_back(rpm);
    log.temp_C.push_back(temp);
    log.load.push_back(load);
    log.seq.push_back(seq);
    log.lines.push_back(lineno);
  }
  if (!header_line) fail(lineno, "no header", "no header row after the metadata");
  if (log.size() == 0) fail(header_line, "no rows", "header with no rows");
  return log;
}

/// Reads and validates a bench log; throws LogError naming file, line and fault.
inline BenchLog read_bench_log(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw LogError(path, 0, "cannot open", "cannot open");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  return parse_bench_log(path, text);
}

/// The case temperature per row as the observer takes it from the acquisition board: the
/// row's reading where it lies within [lo_C, hi_C] (the sensor's range), else the last such
/// reading up to hpddo::kTempMaxAge_ms before it by the log's clock (the board repeats its
/// last reading that long), NaN elsewhere; a log declaring kind=steady_state (rows points
/// apart) has no hold. tools/hpddo/logs/dataset.py temp_read_C reads a log so (it also
/// takes a table it detects as one without the hold).
inline std::vector<double> held_temperatures(const BenchLog& log, double lo_C, double hi_C) {
  const double max_age_s = static_cast<double>(hpddo::kTempMaxAge_ms) / 1000.0;
  auto kind = log.meta.find("kind");
  const bool table = kind != log.meta.end() && kind->second == "steady_state";
  std::vector<double> out(log.size(), std::nan(""));
  size_t last = log.size();  // none yet
  for (size_t k = 0; k < log.size(); ++k) {
    const double t = log.temp_C[k];
    if (std::isfinite(t) && t >= lo_C && t <= hi_C) {
      out[k] = t;
      last = k;
    } else if (!table && last < log.size()) {
      const double age = log.t_s[k] - log.t_s[last];
      if (age >= 0.0 && age <= max_age_s) out[k] = log.temp_C[last];
    }
  }
  return out;
}

/// The log with its temperatures as the observer takes them (held_temperatures).
inline BenchLog as_observed(BenchLog log, double lo_C, double hi_C) {
  log.temp_C = held_temperatures(log, lo_C, hi_C);
  return log;
}

/// The first row of a log's test part: its metadata split_row where that is a row of it
/// (what hpddo writes into the logs it prepares), else floor(fraction x rows).
inline size_t split_row(const BenchLog& log, double fraction) {
  auto it = log.meta.find("split_row");
  if (it != log.meta.end()) {
    const long s = std::strtol(it->second.c_str(), nullptr, 10);
    if (s >= 0 && static_cast<size_t>(s) < log.size()) return static_cast<size_t>(s);
  }
  return static_cast<size_t>(std::floor(fraction * static_cast<double>(log.size())));
}

}  // namespace hpddo_host

#endif
