// Host throughput of the observer, one thread: best of N passes of Observer::step over
// every row of the given bench logs, for the float and the fixed-point form of two
// models (models/default (16, 8) and a (128, 64) timing model, tools/hpddo/perf.py).
// Prints one JSON object: samples per second per model.
//
// usage: host_step N LOG...
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_log.h"
#include "model_default_q.h"
#include "model_wide_q.h"

namespace {

std::vector<hpddo::Sample> samples_of(const std::vector<hpddo_host::BenchLog>& logs) {
  std::vector<hpddo::Sample> out;
  for (const auto& log : logs) {
    for (size_t k = 0; k < log.v_V.size(); ++k) {
      hpddo::Sample s;
      s.v_V = static_cast<float>(log.v_V[k]);
      s.i_A = static_cast<float>(log.i_A[k]);
      s.temp_C = log.has_temp_C ? static_cast<float>(log.temp_C[k]) : hpddo::absent();
      s.dt_s = k ? static_cast<float>(log.t_s[k] - log.t_s[k - 1]) : 0.5f;
      s.seq = static_cast<uint16_t>(log.seq[k] & 0xFFFF);
      s.has_seq = true;
      out.push_back(s);
    }
  }
  return out;
}

template <class Net>
double per_s(const hpddo::Model<Net>& model, const std::vector<hpddo::Sample>& rows, int repeat, double* check) {
  double best = 1e30;
  double sum = 0.0;
  for (int rep = 0; rep < repeat; ++rep) {
    hpddo::Observer<Net> obs(model);
    float acc = 0.0f;
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& s : rows) acc += obs.step(s).rpm;
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (dt < best) best = dt;
    sum = acc;
  }
  *check = sum;
  return static_cast<double>(rows.size()) / best;
}

/// Samples/s of prepare() + finish() alone (physics, envelope, gate, clamp: the network
/// skipped) and of the network alone on the prepared samples where it applies.
template <class Net>
void stages(const hpddo::Model<Net>& model, const std::vector<hpddo::Sample>& rows, int repeat, double* prep_per_s,
            double* net_per_s, double* check) {
  std::vector<typename hpddo::Observer<Net>::Prepared> prepared;
  double best_p = 1e30, best_n = 1e30;
  float acc = 0.0f;
  for (int rep = 0; rep < repeat; ++rep) {
    hpddo::Observer<Net> obs(model);
    prepared.clear();
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& s : rows) {
      typename hpddo::Observer<Net>::Prepared p = obs.prepare(s);
      acc += obs.finish(p, 0.0f).rpm;
      if (p.use_network) prepared.push_back(p);
    }
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (dt < best_p) best_p = dt;
    const auto t1 = std::chrono::steady_clock::now();
    for (const auto& p : prepared) acc += obs.residual(p);
    const double dn = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    if (dn < best_n) best_n = dn;
  }
  *prep_per_s = static_cast<double>(rows.size()) / best_p;
  *net_per_s = static_cast<double>(prepared.size()) / best_n;
  *check = acc;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: host_step N LOG...\n");
    return 2;
  }
  const int repeat = std::stoi(argv[1]);
  std::vector<hpddo_host::BenchLog> logs;
  for (int a = 2; a < argc; ++a) logs.push_back(hpddo_host::read_bench_log(argv[a]));
  const std::vector<hpddo::Sample> rows = samples_of(logs);
  double c[4];
  const double f16 = per_s(hpddo_model_default::kModel, rows, repeat, &c[0]);
  const double q16 = per_s(hpddo_model_default_q::kModel, rows, repeat, &c[1]);
  const double f128 = per_s(hpddo_model_wide::kModel, rows, repeat, &c[2]);
  const double q128 = per_s(hpddo_model_wide_q::kModel, rows, repeat, &c[3]);
  double pf, nf, pq, nq, cs[2];
  stages(hpddo_model_default::kModel, rows, repeat, &pf, &nf, &cs[0]);
  stages(hpddo_model_default_q::kModel, rows, repeat, &pq, &nq, &cs[1]);
  std::printf("{\"samples\": %zu, \"repeat\": %d, \"float_16_8\": %.6g, \"fixed_16_8\": %.6g, "
              "\"float_128_64\": %.6g, \"fixed_128_64\": %.6g, \"prepare_finish_float_16_8\": %.6g, "
              "\"network_float_16_8\": %.6g, \"prepare_finish_fixed_16_8\": %.6g, \"network_fixed_16_8\": %.6g, "
              "\"checksums\": [%.9g, %.9g, %.9g, %.9g, %.9g, %.9g]}\n",
              rows.size(), repeat, f16, q16, f128, q128, pf, nf, pq, nq, c[0], c[1], c[2], c[3], cs[0], cs[1]);
  return 0;
}
