// Host-side reader of bench logs (shared/spec bench-log.md) for the native
// tools: every fault is reported with file, line and what is wrong.
#ifndef HPDDO_HOST_BENCH_LOG_H
#define HPDDO_HOST_BENCH_LOG_H

#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace hpddo_host {

/// A format fault; what() is "file:line: fault".
struct LogError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The columns the observer and the metrics need; optional ones are NaN where absent.
struct BenchLog {
  std::string path;
  std::map<std::string, std::string> meta;
  std::vector<double> t_s, duty, v_V, i_A, rpm_ref, temp_C;
  std::vector<long> seq;  ///< the log's seq, or the row index when the log has none
  bool has_seq = false;

  size_t size() const { return t_s.size(); }
  std::string condition() const {
    auto it = meta.find("condition");
    if (it != meta.end() && !it->second.empty()) return it->second;
    const size_t slash = path.find_last_of('/');
    std::string stem = slash == std::string::npos ? path : path.substr(slash + 1);
    const size_t dot = stem.find_last_of('.');
    return dot == std::string::npos ? stem : stem.substr(0, dot);
  }
};

namespace detail {

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

inline std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

[[noreturn]] inline void fail(const std::string& path, size_t line, const std::string& fault) {
  throw LogError(path + ":" + std::to_string(line) + ": " + fault);
}

inline bool parse_number(std::string_view s, double* out) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), *out);
  return res.ec == std::errc() && res.ptr == s.data() + s.size();
}

}  // namespace detail

/// Reads and validates a bench log; throws LogError naming file, line and fault.
inline BenchLog read_bench_log(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw LogError(path + ": cannot open");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  if (text.size() >= 3 && static_cast<unsigned char>(text[0]) == 0xEF) text.erase(0, 3);  // BOM

  BenchLog log;
  log.path = path;
  std::string_view rest(text);
  size_t lineno = 0;
  int col_t = -1, col_duty = -1, col_v = -1, col_i = -1, col_rpm = -1, col_temp = -1, col_seq = -1;
  size_t ncols = 0;
  bool header = false;
  while (!rest.empty()) {
    const size_t nl = rest.find('\n');
    std::string_view line = rest.substr(0, nl);
    rest = nl == std::string_view::npos ? std::string_view() : rest.substr(nl + 1);
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (!header) {
      if (!line.empty() && line.front() == '#') {
        std::string_view kv = detail::trim(line.substr(1));
        const size_t eq = kv.find('=');
        if (eq == std::string_view::npos) detail::fail(path, lineno, "metadata line without key=value");
        log.meta[std::string(detail::trim(kv.substr(0, eq)))] = std::string(detail::trim(kv.substr(eq + 1)));
        continue;
      }
      const auto cols = detail::split(line);
      ncols = cols.size();
      for (size_t c = 0; c < cols.size(); ++c) {
        const std::string_view name = detail::trim(cols[c]);
        const int ci = static_cast<int>(c);
        if (name == "t_s") col_t = ci;
        else if (name == "duty") col_duty = ci;
        else if (name == "v_V") col_v = ci;
        else if (name == "i_A") col_i = ci;
        else if (name == "rpm_ref") col_rpm = ci;
        else if (name == "temp_C") col_temp = ci;
        else if (name == "seq") col_seq = ci;
      }
      std::string missing;
      if (col_t < 0) missing += " t_s";
      if (col_duty < 0) missing += " duty";
      if (col_v < 0) missing += " v_V";
      if (col_i < 0) missing += " i_A";
      if (!missing.empty()) detail::fail(path, lineno, "missing required column(s):" + missing);
      header = true;
      log.has_seq = col_seq >= 0;
      continue;
    }
    if (line.empty() && rest.empty()) break;  // final newline
    const auto cells = detail::split(line);
    if (cells.size() != ncols)
      detail::fail(path, lineno, "expected " + std::to_string(ncols) + " fields, found " + std::to_string(cells.size()));
    auto required = [&](int c, const char* name) -> double {
      double x = 0;
      if (!detail::parse_number(cells[static_cast<size_t>(c)], &x) || !std::isfinite(x))
        detail::fail(path, lineno, std::string("non-numeric or non-finite value in required column ") + name);
      return x;
    };
    auto optional = [&](int c, const char* name) -> double {
      if (c < 0) return std::nan("");
      const std::string_view s = detail::trim(cells[static_cast<size_t>(c)]);
      if (s.empty()) return std::nan("");
      double x = 0;
      if (!detail::parse_number(s, &x)) detail::fail(path, lineno, std::string("non-numeric value in column ") + name);
      return x;
    };
    const double t = required(col_t, "t_s");
    const double d = required(col_duty, "duty");
    if (!log.t_s.empty() && !(t > log.t_s.back())) detail::fail(path, lineno, "t_s not strictly increasing");
    if (d < 0.0 || d > 1.0) detail::fail(path, lineno, "duty outside 0..1");
    log.t_s.push_back(t);
    log.duty.push_back(d);
    log.v_V.push_back(required(col_v, "v_V"));
    log.i_A.push_back(required(col_i, "i_A"));
    log.rpm_ref.push_back(optional(col_rpm, "rpm_ref"));
    log.temp_C.push_back(optional(col_temp, "temp_C"));
    if (col_seq >= 0) {
      const double s = optional(col_seq, "seq");
      if (!(std::isfinite(s) && s == std::floor(s))) detail::fail(path, lineno, "seq is not an integer");
      log.seq.push_back(static_cast<long>(s));
    } else {
      log.seq.push_back(static_cast<long>(log.t_s.size() - 1));
    }
  }
  if (!header) throw LogError(path + ":" + std::to_string(lineno) + ": empty file (no header)");
  if (log.size() == 0) detail::fail(path, lineno, "header with no rows");
  return log;
}

}  // namespace hpddo_host

#endif
