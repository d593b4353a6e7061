// replay: streams bench logs through the board observer (hpddo_core with one
// compiled-in model header) and writes its estimates, one file per log.
//
//   replay [--split F] [--out-dir DIR] [--batched] [--check-batched [--tolerance RPM]]
//          [--bench N] LOG...
//
// Per log: rows before the split (F of the rows, or the log's split_row
// metadata; 0 makes every row a test row) are the training part, the rest the
// test part; the observer's lags restart at the split, so no feature crosses it.
// --out-dir writes DIR/<log stem>.estimates.csv with every row's M1, M2 and M3
// estimates, status and part (hpddo.evaluation.metrics scores them). --batched runs the
// same Observer in two passes (Observer::prepare for every row, the residual
// network for all rows in the envelope at once as Eigen matrix products, then
// Observer::finish for every row); --check-batched runs both and prints their
// largest difference. --bench N times N passes over the loaded rows in memory
// and prints samples per second as one JSON line.
#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench_log.h"
#include "hpddo_core.h"

#ifndef HPDDO_MODEL_HEADER
#define HPDDO_MODEL_HEADER "model_default.h"
#define HPDDO_MODEL_NS hpddo_model_default
#endif
HPDDO_DYNAMICS_DEFAULT(HPDDO_MODEL_NS)  // model::kDynamics: the header's, or the family off
#include HPDDO_MODEL_HEADER

namespace model = HPDDO_MODEL_NS;
using Net = model::Net;

namespace {

struct Row {
  float rpm_m1, rpm_m2, rpm_m3, residual, temp, confidence;
  uint8_t status;
};

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
  hpddo::Observer<Net> obs(model::kModel, model::kDynamics);
  const float dt0 = first_dt(log);
  out.resize(log.size());
  for (size_t k = 0; k < log.size(); ++k) {
    if (k == split || full_seq_gap(log, k)) obs.restart_lags();
    const hpddo::Sample s = sample_at(log, k, dt0);
    const hpddo::Estimate e = obs.step(s);
    out[k] = Row{m1_rpm(s), e.rpm_m2, e.rpm, e.residual_rpm, e.temp_C, e.confidence, e.status};
  }
}

/// Batched network: Observer::prepare for every row (physics, lags, envelope),
/// the residual network for every row in the envelope at once as Eigen matrix
/// products, then Observer::finish for every row in order (clamp, held estimates).
void run_batched(const hpddo_host::BenchLog& log, size_t split, std::vector<Row>& out) {
  using Observer = hpddo::Observer<Net>;
  const size_t n = log.size();
  out.resize(n);
  Observer obs(model::kModel, model::kDynamics);
  const float dt0 = first_dt(log);
  std::vector<typename Observer::Prepared> prep(n);
  std::vector<float> m1(n);
  Eigen::MatrixXf x(hpddo::kFeatureCount, static_cast<Eigen::Index>(n));
  std::vector<size_t> cols;
  cols.reserve(n);
  for (size_t k = 0; k < n; ++k) {
    if (k == split || full_seq_gap(log, k)) obs.restart_lags();
    const hpddo::Sample s = sample_at(log, k, dt0);
    m1[k] = m1_rpm(s);
    prep[k] = obs.prepare(s);
    if (!prep[k].use_network) continue;
    const Eigen::Index c = static_cast<Eigen::Index>(cols.size());
    for (int j = 0; j < hpddo::kFeatureCount; ++j) x(j, c) = prep[k].x[j];
    cols.push_back(k);
  }
  std::vector<float> res(n, 0.0f);
  const Eigen::Index m = static_cast<Eigen::Index>(cols.size());
  if (m > 0) {
    using RowMajor = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const auto& w = model::kModel.weights;
    const int nf = hpddo::kFeatureCount, h1 = Net::kHidden1, h2 = Net::kHidden2;
    Eigen::Map<const Eigen::VectorXf> mean(model::kModel.scaler.mean, nf), scale(model::kModel.scaler.scale, nf);
    Eigen::MatrixXf z = (x.leftCols(m).colwise() - mean).array().colwise() / scale.array();
    Eigen::Map<const RowMajor> w0(w.w0, h1, nf);
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
    for (Eigen::Index c = 0; c < m; ++c) res[cols[static_cast<size_t>(c)]] = y(c);
  }
  for (size_t k = 0; k < n; ++k) {
    const hpddo::Estimate e = obs.finish(prep[k], res[k]);
    out[k] = Row{m1[k], e.rpm_m2, e.rpm, e.residual_rpm, e.temp_C, e.confidence, e.status};
  }
}

int usage() {
  std::fprintf(stderr,
               "usage: replay [--split F] [--out-dir DIR] [--batched] [--check-batched [--tolerance RPM]] "
               "[--bench N] LOG...\n");
  return 2;
}

/// Writes every row's estimates to path, through a temporary file renamed into place.
bool write_estimates(const std::string& path, const hpddo_host::BenchLog& log, size_t split,
                     const std::vector<Row>& rows) {
  std::ofstream f(path + ".tmp");
  f << "t_s,rpm_ref,rpm_m1,rpm_m2,rpm_m3,residual_rpm,temp_used_C,confidence,status,part\n";
  char buf[320];
  for (size_t k = 0; k < rows.size(); ++k) {
    const Row& r = rows[k];
    char ref[32] = "";
    if (std::isfinite(log.rpm_ref[k])) std::snprintf(ref, sizeof ref, "%.10g", log.rpm_ref[k]);
    // %.9g: every float32 estimate reads back exactly.
    std::snprintf(buf, sizeof buf, "%.10g,%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%s,%s\n", log.t_s[k], ref, r.rpm_m1,
                  r.rpm_m2, r.rpm_m3, r.residual, r.temp, r.confidence, hpddo::status_name(static_cast<hpddo::Status>(r.status)),
                  k < split ? "train" : "test");
    f << buf;
  }
  f.close();
  return f && std::rename((path + ".tmp").c_str(), path.c_str()) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  double fraction = 0.8;
  std::string out_dir;
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
  if (paths.empty() || !(fraction >= 0 && fraction < 1)) return usage();
  if (hpddo::model_checksum(model::kModel, model::kDynamics) != model::kChecksum) {
    std::fprintf(stderr, "replay: model checksum mismatch: the model header was edited\n");
    return 1;
  }

  std::vector<hpddo_host::BenchLog> logs;
  try {
    for (const auto& p : paths)  // the temperatures as the acquisition board passes them on (held)
      logs.push_back(hpddo_host::as_observed(hpddo_host::read_bench_log(p), model::kModel.limits.temp_min_C,
                                             model::kModel.limits.temp_max_C));
  } catch (const hpddo_host::LogError& e) {
    std::fprintf(stderr, "replay: %s\n", e.what());
    return 1;
  }

  double max_diff = 0.0;
  for (const auto& log : logs) {
    const size_t split = hpddo_host::split_row(log, fraction);
    std::vector<Row> rows, other;
    if (batched) run_batched(log, split, rows); else run_per_sample(log, split, rows);
    if (check) {
      if (batched) run_per_sample(log, split, other); else run_batched(log, split, other);
      for (size_t k = 0; k < rows.size(); ++k)
        max_diff = std::max(max_diff, static_cast<double>(std::fabs(rows[k].rpm_m3 - other[k].rpm_m3)));
    }
    if (!out_dir.empty()) {
      const std::string stem = hpddo_host::file_stem(log.path);
      const std::string path = out_dir + "/" + stem + ".estimates.csv";
      if (!write_estimates(path, log, split, rows)) {
        std::fprintf(stderr, "replay: cannot write %s\n", path.c_str());
        return 1;
      }
    }
  }
  if (check) std::printf("largest |batched - per-sample| M3 difference: %.3g RPM\n", max_diff);
  if (check && tolerance >= 0.0 && !(max_diff <= tolerance)) {
    std::fprintf(stderr, "replay: batched and per-sample paths differ by %.3g RPM (> %.3g)\n", max_diff, tolerance);
    return 3;
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
          const size_t split = hpddo_host::split_row(log, fraction);
          if (mode == 0) run_per_sample(log, split, rows); else run_batched(log, split, rows);
        }
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        best[mode] = std::min(best[mode], s);
      }
    }
    // One JSON object on its own line, for hpddo.evaluation.replay.bench.
    std::printf("{\"bench\": {\"samples\": %zu, \"repeat\": %d, \"per_sample_per_s\": %.6g, "
                "\"batched_per_s\": %.6g}}\n",
                total, bench, static_cast<double>(total) / best[0], static_cast<double>(total) / best[1]);
  }
  return 0;
}
