// Host throughput of the observer, one thread: best of N passes (and at least half a
// second of them) of Observer::step over
// every row of the given bench logs, for the float and the fixed-point form of two
// models (models/default (16, 8) and a (128, 64) timing model, tools/hpddo/studies/perf.py),
// and the int8 form of the first (model_default_q8.h).
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
#include "model_default_q8.h"
#include "model_wide_q.h"

namespace {

// Passes run until there are at least N of each and all of them took at least this long: a
// pass of the (16, 8) model over the bundled rows lasts 2-3 ms, shorter than the
// scheduler's slices on a shared machine, and the best of 20 such passes moved between 2.9
// and 4.9 million samples/s from run to run.
const double kMinSeconds = 3.0;

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

/// One pass of Observer::step over every row: its duration in seconds; *check receives
/// the sum of the estimates (so that the work is not optimised away).
template <class Net>
double pass(const hpddo::Model<Net>& model, const std::vector<hpddo::Sample>& rows, double* check) {
  hpddo::Observer<Net> obs(model);
  float acc = 0.0f;
  const auto t0 = std::chrono::steady_clock::now();
  for (const auto& s : rows) acc += obs.step(s).rpm;
  const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  *check = acc;
  return dt;
}

/// One pass of prepare() + finish() alone (physics, envelope, gate, clamp: the network
/// skipped) and one of the network alone on the prepared samples where it applies:
/// their durations in *dt_prep and *dt_net; returns how many samples the network ran on.
template <class Net>
size_t stage_pass(const hpddo::Model<Net>& model, const std::vector<hpddo::Sample>& rows, double* dt_prep,
                  double* dt_net, double* check) {
  std::vector<typename hpddo::Observer<Net>::Prepared> prepared;
  prepared.reserve(rows.size());
  hpddo::Observer<Net> obs(model);
  float acc = 0.0f;
  const auto t0 = std::chrono::steady_clock::now();
  for (const auto& s : rows) {
    typename hpddo::Observer<Net>::Prepared p = obs.prepare(s);
    acc += obs.finish(p, 0.0f).rpm;
    if (p.use_network) prepared.push_back(p);
  }
  *dt_prep = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto t1 = std::chrono::steady_clock::now();
  for (const auto& p : prepared) acc += obs.residual(p);
  *dt_net = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  *check = acc;
  return prepared.size();
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
  // The passes of the four models and of the two stage splits take turns, so that a burst
  // of load on this shared machine falls on all of them alike (the ratios are taken in
  // the same run); the best pass of each counts.
  double best[9];
  for (double& b : best) b = 1e30;
  double c[5], cs[2];
  size_t net_rows[2] = {0, 0};
  double total = 0.0;
  for (int rep = 0; rep < repeat || total < kMinSeconds; ++rep) {
    double dt[9];
    dt[0] = pass(hpddo_model_default::kModel, rows, &c[0]);
    dt[1] = pass(hpddo_model_default_q::kModel, rows, &c[1]);
    dt[2] = pass(hpddo_model_wide::kModel, rows, &c[2]);
    dt[3] = pass(hpddo_model_wide_q::kModel, rows, &c[3]);
    net_rows[0] = stage_pass(hpddo_model_default::kModel, rows, &dt[4], &dt[5], &cs[0]);
    net_rows[1] = stage_pass(hpddo_model_default_q::kModel, rows, &dt[6], &dt[7], &cs[1]);
    dt[8] = pass(hpddo_model_default_q8::kModel, rows, &c[4]);
    for (int k = 0; k < 9; ++k) {
      if (dt[k] < best[k]) best[k] = dt[k];
      total += dt[k];
    }
  }
  const double n = static_cast<double>(rows.size());
  const double f16 = n / best[0], q16 = n / best[1], f128 = n / best[2], q128 = n / best[3];
  const double pf = n / best[4], nf = static_cast<double>(net_rows[0]) / best[5];
  const double pq = n / best[6], nq = static_cast<double>(net_rows[1]) / best[7];
  const double i16 = n / best[8];
  std::printf("{\"samples\": %zu, \"repeat\": %d, \"float_16_8\": %.6g, \"fixed_16_8\": %.6g, "
              "\"float_128_64\": %.6g, \"fixed_128_64\": %.6g, \"prepare_finish_float_16_8\": %.6g, "
              "\"network_float_16_8\": %.6g, \"prepare_finish_fixed_16_8\": %.6g, \"network_fixed_16_8\": %.6g, "
              "\"int8_16_8\": %.6g, \"checksums\": [%.9g, %.9g, %.9g, %.9g, %.9g, %.9g, %.9g]}\n",
              rows.size(), repeat, f16, q16, f128, q128, pf, nf, pq, nq, i16, c[0], c[1], c[2], c[3], cs[0], cs[1], c[4]);
  return 0;
}
