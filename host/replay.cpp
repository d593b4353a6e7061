// replay: streams bench logs through the board observer (hpddo_core with one
// compiled-in model header) and reports the speed error of M1, M2 and M3.
//
//   replay [--split F] [--out-dir DIR] [--metrics FILE] [--batched] [--check-batched]
//          [--bench N] LOG...
//
// Per log: rows before the split (F of the rows, or the log's split_row
// metadata) are the training part, the rest the test part; the observer's lags
// restart at the split, so no feature crosses it. RMSE is measured on the test
// part only, pooled per condition; "average" is the mean over conditions.
// --batched evaluates the network for all rows at once with Eigen (the physics
// and the lag bookkeeping stay the per-sample code); --check-batched runs both
// and prints their largest difference. --bench N times N passes over the
// loaded rows in memory and prints samples per second.
#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "bench_log.h"
#include "hpddo_core.h"

#ifndef HPDDO_MODEL_HEADER
#define HPDDO_MODEL_HEADER "model_default.h"
#define HPDDO_MODEL_NS hpddo_model_default
#endif
#include HPDDO_MODEL_HEADER

namespace model = HPDDO_MODEL_NS;
using Net = model::Net;

namespace {

struct Row {
  float rpm_m1, rpm_m2, rpm_m3, residual, temp;
  uint8_t status;
};

size_t split_row(const hpddo_host::BenchLog& log, double fraction) {
  auto it = log.meta.find("split_row");
  if (it != log.meta.end()) {
    const long s = std::strtol(it->second.c_str(), nullptr, 10);
    if (s > 0 && static_cast<size_t>(s) < log.size()) return static_cast<size_t>(s);
  }
  return static_cast<size_t>(std::floor(fraction * static_cast<double>(log.size())));
}

float first_dt(const hpddo_host::BenchLog& log) {
  auto it = log.meta.find("sample_rate_hz");
  if (it != log.meta.end()) {
    const double r = std::strtod(it->second.c_str(), nullptr);
    if (r > 0) return static_cast<float>(1.0 / r);
  }
  if (log.size() < 2) return 1.0f;
  std::vector<double> d(log.size() - 1);
  for (size_t k = 1; k < log.size(); ++k) d[k - 1] = log.t_s[k] - log.t_s[k - 1];
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
  return static_cast<float>(d[d.size() / 2]);
}

hpddo::Sample sample_at(const hpddo_host::BenchLog& log, size_t k, float dt0) {
  hpddo::Sample s;
  s.v_V = static_cast<float>(log.v_V[k]);
  s.i_A = static_cast<float>(log.i_A[k]);
  s.temp_C = static_cast<float>(log.temp_C[k]);
  s.dt_s = k == 0 ? dt0 : static_cast<float>(log.t_s[k] - log.t_s[k - 1]);
  s.seq = static_cast<uint16_t>(log.seq[k] & 0xFFFF);
  s.has_seq = true;
  return s;
}

float m1_rpm(const hpddo::Sample& s) {
  hpddo::PhysicsInput in = {s.v_V, s.i_A, 0.0f, model::kNameplate.t_ref_C, model::kNameplate.t_ref_C};
  float n = 0.0f;
  return hpddo::physics_rpm(model::kNameplate, in, &n) ? n : 0.0f;
}

/// True when row k does not follow row k-1 by the log's full seq. The observer sees
/// only its low 16 bits (as on the link), which hide a jump by a multiple of 65536.
bool full_seq_gap(const hpddo_host::BenchLog& log, size_t k) {
  return k > 0 && log.seq[k] != log.seq[k - 1] + 1;
}

/// The board path: one Observer::step per sample.
void run_per_sample(const hpddo_host::BenchLog& log, size_t split, std::vector<Row>& out) {
  hpddo::Observer<Net> obs(model::kModel);
  const float dt0 = first_dt(log);
  out.resize(log.size());
  for (size_t k = 0; k < log.size(); ++k) {
    if (k == split || full_seq_gap(log, k)) obs.restart_lags();
    const hpddo::Sample s = sample_at(log, k, dt0);
    const hpddo::Estimate e = obs.step(s);
    out[k] = Row{m1_rpm(s), e.rpm_m2, e.rpm, e.residual_rpm, e.temp_C, e.status};
  }
}

/// Batched network: the observer's physics and lag rules per sample (a model
/// whose network is never called), then the residual network for every row in
/// the envelope at once as Eigen matrix products, then the clamp.
void run_batched(const hpddo_host::BenchLog& log, size_t split, std::vector<Row>& out) {
  const size_t n = log.size();
  out.resize(n);
  hpddo::Model<Net> physics_only = model::kModel;
  static const float kNoLo[5] = {1, 1, 1, 1, 1}, kNoHi[5] = {0, 0, 0, 0, 0};  // empty envelope
  physics_only.envelope.lo = kNoLo;
  physics_only.envelope.hi = kNoHi;
  hpddo::Observer<Net> obs(physics_only);
  const float dt0 = first_dt(log);
  Eigen::MatrixXf x(5, static_cast<Eigen::Index>(n));
  std::vector<Eigen::Index> cols;
  cols.reserve(n);
  float i_lag = 0, m2_lag = 0;
  bool has_lag = false;
  const hpddo::Envelope<5>& env = model::kModel.envelope;
  for (size_t k = 0; k < n; ++k) {
    if (k == split || full_seq_gap(log, k)) {
      obs.restart_lags();
      has_lag = false;
    }
    const hpddo::Sample s = sample_at(log, k, dt0);
    const uint32_t gaps = obs.seq_gaps(), breaks = obs.period_breaks();
    const hpddo::Estimate e = obs.step(s);
    if (obs.seq_gaps() != gaps || obs.period_breaks() != breaks) has_lag = false;
    out[k] = Row{m1_rpm(s), e.rpm_m2, e.rpm, 0.0f, e.temp_C, e.status};
    if (e.status == hpddo::kStatusInvalid) {
      has_lag = false;
      continue;
    }
    const float f[5] = {s.v_V, s.i_A, e.rpm_m2, has_lag ? i_lag : s.i_A, has_lag ? m2_lag : e.rpm_m2};
    i_lag = s.i_A;
    m2_lag = e.rpm_m2;
    has_lag = true;
    if (!env.contains(f)) continue;
    const Eigen::Index c = static_cast<Eigen::Index>(cols.size());
    for (int j = 0; j < 5; ++j) x(j, c) = f[j];
    cols.push_back(static_cast<Eigen::Index>(k));
  }
  const Eigen::Index m = static_cast<Eigen::Index>(cols.size());
  if (m == 0) return;
  using RowMajor = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const auto& w = model::kModel.weights;
  Eigen::Map<const Eigen::VectorXf> mean(model::kModel.scaler.mean, 5), scale(model::kModel.scaler.scale, 5);
  Eigen::MatrixXf z = (x.leftCols(m).colwise() - mean).array().colwise() / scale.array();
  const int h1 = Net::kHidden1, h2 = Net::kHidden2;
  Eigen::Map<const RowMajor> w0(w.w0, h1, 5);
  Eigen::Map<const Eigen::VectorXf> b0(w.b0, h1);
  Eigen::MatrixXf a1 = ((w0 * z).colwise() + b0).cwiseMax(0.0f);
  Eigen::RowVectorXf y;
  if (h2 > 0) {
    Eigen::Map<const RowMajor> w1(w.w1, h2, h1);
    Eigen::Map<const Eigen::VectorXf> b1(w.b1, h2);
    Eigen::MatrixXf a2 = ((w1 * a1).colwise() + b1).cwiseMax(0.0f);
    Eigen::Map<const RowMajor> w2(w.w2, 1, h2);
    y = (w2 * a2).array() + w.b2[0];
  } else {
    Eigen::Map<const RowMajor> w1(w.w1, 1, h1);
    y = (w1 * a1).array() + w.b1[0];
  }
  for (Eigen::Index c = 0; c < m; ++c) {
    Row& r = out[static_cast<size_t>(cols[static_cast<size_t>(c)])];
    float res = y(c);
    if (!hpddo::is_finite(res)) continue;  // stays the physics fallback
    r.status = hpddo::clamp_residual(model::kModel.clamp_rpm, &res) ? hpddo::kStatusClamped : hpddo::kStatusOk;
    r.residual = res;
    r.rpm_m3 = r.rpm_m2 + res;
  }
}

struct Acc {
  double se[3] = {0, 0, 0};
  size_t n = 0, n_rows = 0, clamped = 0, fallback = 0, invalid = 0;
};

/// s as a JSON string literal, quotes included (RFC 8259: quote, backslash and
/// control characters escaped).
std::string json_str(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += ch;
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
      out += buf;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

std::string json_num(double x) {
  if (!std::isfinite(x)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

int usage() {
  std::fprintf(stderr,
               "usage: replay [--split F] [--out-dir DIR] [--metrics FILE] [--batched] [--check-batched] "
               "[--tolerance RPM] [--bench N] LOG...\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  double fraction = 0.8;
  std::string out_dir, metrics_path;
  bool batched = false, check = false;
  double tolerance = -1.0;
  int bench = 0;
  std::vector<std::string> paths;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    auto next = [&]() -> std::string {
      if (a + 1 >= argc) throw std::runtime_error("option " + arg + " needs a value");
      return argv[++a];
    };
    try {
      if (arg == "--split") fraction = std::stod(next());
      else if (arg == "--out-dir") out_dir = next();
      else if (arg == "--metrics") metrics_path = next();
      else if (arg == "--batched") batched = true;
      else if (arg == "--check-batched") check = true;
      else if (arg == "--tolerance") tolerance = std::stod(next());
      else if (arg == "--bench") bench = std::stoi(next());
      else if (arg == "-h" || arg == "--help") return usage(), 0;
      else if (!arg.empty() && arg[0] == '-') return usage();
      else paths.push_back(arg);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "replay: %s\n", e.what());
      return 2;
    }
  }
  if (paths.empty() || !(fraction > 0 && fraction < 1)) return usage();
  if (hpddo::model_checksum(model::kModel) != model::kChecksum) {
    std::fprintf(stderr, "replay: model checksum mismatch: the model header was edited\n");
    return 1;
  }

  std::vector<hpddo_host::BenchLog> logs;
  try {
    for (const auto& p : paths) logs.push_back(hpddo_host::read_bench_log(p));
  } catch (const hpddo_host::LogError& e) {
    std::fprintf(stderr, "replay: %s\n", e.what());
    return 1;
  }

  std::map<std::string, Acc> acc;
  std::vector<std::string> order;
  double max_diff = 0.0;
  for (const auto& log : logs) {
    const size_t split = split_row(log, fraction);
    std::vector<Row> rows, other;
    if (batched) run_batched(log, split, rows); else run_per_sample(log, split, rows);
    if (check) {
      if (batched) run_per_sample(log, split, other); else run_batched(log, split, other);
      for (size_t k = 0; k < rows.size(); ++k)
        max_diff = std::max(max_diff, static_cast<double>(std::fabs(rows[k].rpm_m3 - other[k].rpm_m3)));
    }
    const std::string cond = log.condition();
    if (!acc.count(cond)) order.push_back(cond);
    Acc& a = acc[cond];
    for (size_t k = split; k < rows.size(); ++k) {
      ++a.n_rows;
      a.clamped += rows[k].status == hpddo::kStatusClamped;
      a.fallback += rows[k].status == hpddo::kStatusFallback;
      a.invalid += rows[k].status == hpddo::kStatusInvalid;
      if (!std::isfinite(log.rpm_ref[k])) continue;
      const double ref = log.rpm_ref[k];
      a.se[0] += std::pow(rows[k].rpm_m1 - ref, 2);
      a.se[1] += std::pow(rows[k].rpm_m2 - ref, 2);
      a.se[2] += std::pow(rows[k].rpm_m3 - ref, 2);
      ++a.n;
    }
    if (!out_dir.empty()) {
      std::string stem = log.path.substr(log.path.find_last_of('/') + 1);
      stem = stem.substr(0, stem.find_last_of('.'));
      const std::string path = out_dir + "/" + stem + ".estimates.csv";
      std::ofstream f(path + ".tmp");
      f << "t_s,rpm_ref,rpm_m1,rpm_m2,rpm_m3,residual_rpm,temp_used_C,status,part\n";
      char buf[256];
      for (size_t k = 0; k < rows.size(); ++k) {
        const Row& r = rows[k];
        std::snprintf(buf, sizeof buf, "%.4f,%s,%.4f,%.4f,%.4f,%.4f,%.3f,%s,%s\n", log.t_s[k],
                      std::isfinite(log.rpm_ref[k]) ? json_num(log.rpm_ref[k]).c_str() : "", r.rpm_m1, r.rpm_m2,
                      r.rpm_m3, r.residual, r.temp, hpddo::status_name(static_cast<hpddo::Status>(r.status)),
                      k < split ? "train" : "test");
        f << buf;
      }
      f.close();
      if (!f || std::rename((path + ".tmp").c_str(), path.c_str()) != 0) {
        std::fprintf(stderr, "replay: cannot write %s\n", path.c_str());
        return 1;
      }
    }
  }

  const char* names[3] = {"M1", "M2", "M3"};
  std::printf("RMSE on the test parts (RPM)%s\n", batched ? " [batched]" : "");
  std::printf("%-10s %10s %10s %10s %8s %8s %9s\n", "condition", "M1", "M2", "M3", "rows", "clamped", "fallback");
  double avg[3] = {0, 0, 0};
  for (const auto& c : order) {
    const Acc& a = acc[c];
    double r[3];
    for (int m = 0; m < 3; ++m) r[m] = a.n ? std::sqrt(a.se[m] / static_cast<double>(a.n)) : NAN;
    for (int m = 0; m < 3; ++m) avg[m] += r[m] / static_cast<double>(order.size());
    std::printf("%-10s %10.2f %10.2f %10.2f %8zu %7.1f%% %8.1f%%\n", c.c_str(), r[0], r[1], r[2], a.n_rows,
                100.0 * static_cast<double>(a.clamped) / static_cast<double>(a.n_rows),
                100.0 * static_cast<double>(a.fallback) / static_cast<double>(a.n_rows));
  }
  std::printf("%-10s %10.2f %10.2f %10.2f\n", "average", avg[0], avg[1], avg[2]);
  if (check) std::printf("largest |batched - per-sample| M3 difference: %.3g RPM\n", max_diff);
  if (check && tolerance >= 0.0 && !(max_diff <= tolerance)) {
    std::fprintf(stderr, "replay: batched and per-sample paths differ by %.3g RPM (> %.3g)\n", max_diff, tolerance);
    return 3;
  }

  if (!metrics_path.empty()) {
    std::string j = "{\n  \"rmse_rpm\": {";
    for (int m = 0; m < 3; ++m) {
      j += std::string(m ? ",\n    " : "\n    ") + "\"" + names[m] + "\": {";
      for (const auto& c : order) {
        const Acc& a = acc[c];
        j += json_str(c) + ": " + json_num(a.n ? std::sqrt(a.se[m] / static_cast<double>(a.n)) : NAN) + ", ";
      }
      j += "\"average\": " + json_num(avg[m]) + "}";
    }
    j += "\n  },\n  \"clamped_share\": {";
    std::string fb = "\n  \"fallback_share\": {", inv = "\n  \"invalid_share\": {", rows = "\n  \"test_rows\": {";
    size_t tot = 0, tc = 0, tf = 0, ti = 0;
    for (const auto& c : order) {
      const Acc& a = acc[c];
      const double nr = static_cast<double>(a.n_rows);
      j += json_str(c) + ": " + json_num(static_cast<double>(a.clamped) / nr) + ", ";
      fb += json_str(c) + ": " + json_num(static_cast<double>(a.fallback) / nr) + ", ";
      inv += json_str(c) + ": " + json_num(static_cast<double>(a.invalid) / nr) + ", ";
      rows += json_str(c) + ": " + std::to_string(a.n_rows) + ", ";
      tot += a.n_rows, tc += a.clamped, tf += a.fallback, ti += a.invalid;
    }
    const double nt = static_cast<double>(tot);
    j += "\"all\": " + json_num(static_cast<double>(tc) / nt) + "},";
    j += fb + "\"all\": " + json_num(static_cast<double>(tf) / nt) + "},";
    j += inv + "\"all\": " + json_num(static_cast<double>(ti) / nt) + "},";
    j += rows + "\"all\": " + std::to_string(tot) + "},";
    j += "\n  \"source\": \"native replay (hpddo_core observer, " + std::string(batched ? "batched" : "per-sample") +
         ")\",\n  \"model_checksum\": \"" + [] { char b[16]; std::snprintf(b, sizeof b, "0x%08x", model::kChecksum); return std::string(b); }() +
         "\"\n}\n";
    std::ofstream f(metrics_path + ".tmp");
    f << j;
    f.close();
    if (!f || std::rename((metrics_path + ".tmp").c_str(), metrics_path.c_str()) != 0) {
      std::fprintf(stderr, "replay: cannot write %s\n", metrics_path.c_str());
      return 1;
    }
  }

  if (bench > 0) {
    size_t total = 0;
    for (const auto& log : logs) total += log.size();
    std::vector<Row> rows;
    double best[2] = {1e30, 1e30};
    for (int mode = 0; mode < 2; ++mode) {
      for (int rep = 0; rep < bench; ++rep) {
        const auto t0 = std::chrono::steady_clock::now();
        for (const auto& log : logs) {
          const size_t split = split_row(log, fraction);
          if (mode == 0) run_per_sample(log, split, rows); else run_batched(log, split, rows);
        }
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        best[mode] = std::min(best[mode], s);
      }
    }
    // One JSON object on its own line, for hpddo.replay.bench.
    std::printf("{\"bench\": {\"samples\": %zu, \"repeat\": %d, \"per_sample_per_s\": %.6g, "
                "\"batched_per_s\": %.6g}}\n",
                total, bench, static_cast<double>(total) / best[0], static_cast<double>(total) / best[1]);
  }
  return 0;
}
