// compare_observers: the classical competitors of hpddo compare (docs/compare.md),
// tuned and replayed on bench logs like the board observer.
//
//   compare_observers tune --ke KE --ra RA [--coarse] [--ripple RDIR] LOG...
//       Identifies the friction (steady-state torque balance) and grid-tunes the EKF
//       (J, q_w, q_T, r) and the SMO (k, phi, tau) on every row of the LOGs, which must
//       be training rows only (hpddo compare writes the training part of each recording
//       to its own log); prints the result as one JSON object. --coarse: about half
//       the grid points per axis and one refinement instead of two (hpddo compare --quick).
//       --ripple: also the EKF with the ripple count as a second measurement ("ekf_ripple"),
//       the counts of each LOG's rows in RDIR/<stem>.ripple_speed.csv.
//   compare_observers run --motor KE,RA,B,TC --ekf J,QW,QT,R --smo K,PHI,TAU
//                         [--mlp FILE] [--ripple RDIR --ekf-ripple J,QW,QT,R] [--split F]
//                         --out-dir DIR LOG...
//       Replays each LOG through the EKF, the SMO and (with --mlp) the pure network and
//       writes DIR/<stem>.observers.csv (t_s, rpm_ref, rpm_ekf, rpm_smo, rpm_nn,
//       rpm_ekf_ripple, part). With --ripple, the EKF tuned for it (--ekf-ripple) runs with the
//       ripple count of RDIR/<stem>.ripple_speed.csv as a second measurement (rpm_ekf_ripple;
//       else NaN).
//
// Both restart every estimator at the first row, at the split (the log's split_row
// metadata, else F of the rows; 0: no split), and after a gap in seq, as the board
// observer restarts its lags.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench_log.h"
#include "observers.h"

namespace {

using hpddo_compare::Ekf;
using hpddo_compare::EkfParams;
using hpddo_compare::kRpmPerRadS;
using hpddo_compare::Mlp;
using hpddo_compare::Motor;
using hpddo_compare::Smo;
using hpddo_compare::SmoParams;

constexpr double kMinRpm = 10.0;  ///< torque balance on rows above 10 RPM (as the Ke fit, identify.py)
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Log {
  hpddo_host::BenchLog data;
  std::vector<char> start;  ///< 1 where the estimators restart
  std::vector<double> dt;   ///< sample period of each row, s
};

double first_dt(const hpddo_host::BenchLog& log) {
  auto it = log.meta.find("sample_rate_hz");
  if (it != log.meta.end()) {
    const double r = std::strtod(it->second.c_str(), nullptr);
    if (r > 0) return 1.0 / r;
  }
  if (log.size() < 2) return 1.0;
  std::vector<double> d(log.size() - 1);
  for (size_t k = 1; k < log.size(); ++k) d[k - 1] = log.t_s[k] - log.t_s[k - 1];
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

Log load(const std::string& path, double fraction) {
  Log L{hpddo_host::read_bench_log(path), {}, {}};
  const auto& d = L.data;
  const size_t n = d.size(), split = hpddo_host::split_row(d, fraction);
  L.start.assign(n, 0);
  L.dt.assign(n, first_dt(d));
  for (size_t k = 0; k < n; ++k) {
    if (k > 0) L.dt[k] = d.t_s[k] - d.t_s[k - 1];
    L.start[k] = k == 0 || k == split || d.seq[k] != d.seq[k - 1] + 1 || !(L.dt[k] > 0.0);
  }
  return L;
}

/// Speed estimates of every row, rpm, by an estimator with restart(v, i) and step(v, i, dt);
/// after(est, k, w) may update the row's estimate w (rad/s) with a further measurement.
template <class Est, class After>
std::vector<double> replay(const Log& L, Est est, After after) {
  const auto& d = L.data;
  std::vector<double> out(d.size());
  for (size_t k = 0; k < d.size(); ++k) {
    if (L.start[k]) est.restart(d.v_V[k], d.i_A[k]);
    out[k] = after(est, k, est.step(d.v_V[k], d.i_A[k], L.start[k] ? first_dt(d) : L.dt[k])) * kRpmPerRadS;
  }
  return out;
}

template <class Est>
std::vector<double> replay(const Log& L, Est est) {
  return replay(L, est, [](Est&, size_t, double w) { return w; });
}

/// The ripple count of each row of one log (hpddo.studies.compare writes it): the header
/// "rpm,sd_rpm", then one line per row of the log; both fields empty where the count is not
/// confident. sd_rpm: the count's standard uncertainty.
struct RippleSpeeds {
  std::vector<double> rpm, sd_rpm;
};

RippleSpeeds read_ripple_speeds(const std::string& path, size_t rows) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot read the ripple speeds");
  std::string line;
  if (!std::getline(f, line) || line != "rpm,sd_rpm")
    throw std::runtime_error(path + ":1: the header must be rpm,sd_rpm");
  RippleSpeeds r;
  for (size_t n = 2; std::getline(f, line); ++n) {
    const size_t comma = line.find(',');
    if (comma == std::string::npos) throw std::runtime_error(path + ":" + std::to_string(n) + ": two fields expected");
    const std::string a = line.substr(0, comma), b = line.substr(comma + 1);
    if (a.empty() != b.empty()) throw std::runtime_error(path + ":" + std::to_string(n) + ": rpm and sd_rpm go together");
    double rpm = NAN, sd = NAN;
    if (!a.empty()) {
      char *ea = nullptr, *eb = nullptr;
      rpm = std::strtod(a.c_str(), &ea);
      sd = std::strtod(b.c_str(), &eb);
      if (*ea || *eb || !std::isfinite(rpm) || !(sd > 0.0) || !std::isfinite(sd))
        throw std::runtime_error(path + ":" + std::to_string(n) + ": rpm finite and sd_rpm > 0 expected");
    }
    r.rpm.push_back(rpm);
    r.sd_rpm.push_back(sd);
  }
  if (r.rpm.size() != rows)
    throw std::runtime_error(path + ": " + std::to_string(r.rpm.size()) + " rows for the log's " +
                             std::to_string(rows));
  return r;
}

/// RDIR/<stem>.ripple_speed.csv for the log at path.
std::string ripple_file(const std::string& dir, const std::string& path) {
  return dir + "/" + hpddo_host::file_stem(path) + ".ripple_speed.csv";
}

/// The EKF with the ripple count as a second measurement of the speed where there is one.
std::vector<double> replay_ekf_ripple(const Log& L, Ekf ekf, const RippleSpeeds& rip) {
  return replay(L, ekf, [&](Ekf& e, size_t k, double w) {
    if (!std::isfinite(rip.rpm[k])) return w;
    const double sd_rad_s = rip.sd_rpm[k] / kRpmPerRadS;
    return e.update_speed(rip.rpm[k] / kRpmPerRadS, sd_rad_s * sd_rad_s);
  });
}

/// The tuning score: the mean over logs of each log's RMSE on its labelled rows (the
/// "average" of the tables, which weighs every condition alike); infinite when an
/// estimate is not finite. estimates(l): the estimates of every row of logs[l], rpm.
double score_of(const std::vector<Log>& logs, const std::function<std::vector<double>(size_t)>& estimates) {
  double sum = 0.0;
  for (size_t l = 0; l < logs.size(); ++l) {
    const Log& L = logs[l];
    const auto est = estimates(l);
    double se = 0.0;
    size_t n = 0;
    for (size_t k = 0; k < est.size(); ++k) {
      if (!std::isfinite(L.data.rpm_ref[k])) continue;
      if (!std::isfinite(est[k])) return kInf;
      const double e = est[k] - L.data.rpm_ref[k];
      se += e * e;
      ++n;
    }
    sum += n ? std::sqrt(se / static_cast<double>(n)) : 0.0;
  }
  return sum / static_cast<double>(logs.size());
}

/// score_of an estimator made by make() and replayed on each log.
template <class Make>
double score(const std::vector<Log>& logs, Make make) {
  return score_of(logs, [&](size_t l) { return replay(logs[l], make()); });
}

/// A log-spaced axis of the grid: 10^lo .. 10^hi in n points.
struct Axis {
  const char* name;
  double lo, hi;
  int n;
};

/// Grid search over log10 of the parameters, then `refinements` times a 5-point grid per
/// axis around the best point with half the previous spacing each time. Returns the
/// best parameters (not log) and its score; counts the evaluations.
std::pair<std::vector<double>, double> grid_tune(const std::vector<Axis>& axes, int refinements,
                                                 const std::function<double(const std::vector<double>&)>& f,
                                                 long& evaluations) {
  const size_t d = axes.size();
  std::vector<std::vector<double>> grid(d);
  std::vector<double> step(d);
  for (size_t a = 0; a < d; ++a) {
    step[a] = axes[a].n > 1 ? (axes[a].hi - axes[a].lo) / (axes[a].n - 1) : 0.0;
    for (int k = 0; k < axes[a].n; ++k) grid[a].push_back(axes[a].lo + k * step[a]);
  }
  std::vector<double> best_log(d);
  double best = kInf;
  for (int round = 0; round <= refinements; ++round) {
    std::vector<size_t> idx(d, 0);
    for (;;) {
      std::vector<double> p(d);
      for (size_t a = 0; a < d; ++a) p[a] = std::pow(10.0, grid[a][idx[a]]);
      const double s = f(p);
      ++evaluations;
      if (s < best) {
        best = s;
        for (size_t a = 0; a < d; ++a) best_log[a] = grid[a][idx[a]];
      }
      size_t a = 0;
      while (a < d && ++idx[a] == grid[a].size()) idx[a++] = 0;
      if (a == d) break;
    }
    for (size_t a = 0; a < d; ++a) {
      step[a] /= 2.0;
      grid[a].clear();
      for (int k = -2; k <= 2; ++k) grid[a].push_back(best_log[a] + k * step[a]);
    }
  }
  std::vector<double> out(d);
  for (size_t a = 0; a < d; ++a) out[a] = std::pow(10.0, best_log[a]);
  return {out, best};
}

/// Steady-state torque balance Ke i = B w + Tc over the rows above kMinRpm (least
/// squares; a negative coefficient is set to 0 and the other refitted: friction never drives).
void identify_friction(const std::vector<Log>& logs, Motor& m) {
  double sww = 0, sw = 0, n = 0, swy = 0, sy = 0;
  for (const auto& L : logs)
    for (size_t k = 0; k < L.data.size(); ++k) {
      const double rpm = L.data.rpm_ref[k];
      if (!(std::isfinite(rpm) && rpm > kMinRpm)) continue;
      const double w = rpm / kRpmPerRadS, y = m.ke_vs_per_rad * L.data.i_A[k];
      sww += w * w; sw += w; n += 1; swy += w * y; sy += y;
    }
  if (n < 2) throw std::runtime_error("fewer than 2 training rows above 10 RPM: no friction to identify");
  const double det = sww * n - sw * sw;
  double b = det != 0 ? (swy * n - sw * sy) / det : 0.0, tc = det != 0 ? (sww * sy - sw * swy) / det : sy / n;
  if (b < 0) { b = 0; tc = sy / n; }
  if (tc < 0) { tc = 0; b = sww > 0 ? swy / sww : 0.0; }
  m.b_nms_per_rad = b;
  m.tc_nm = tc;
}

double m2_score(const std::vector<Log>& logs, const Motor& m) {
  struct M2 {
    Motor m;
    void restart(double, double) {}
    double step(double v, double i, double) { return hpddo_compare::m2_rad_s(m, v, i); }
  };
  return score(logs, [&] { return M2{m}; });
}

/// The axis with about half its points over the same range (--coarse).
std::vector<Axis> coarser(std::vector<Axis> axes) {
  for (auto& a : axes) a.n = (a.n + 1) / 2;
  return axes;
}

int tune(const Motor& given, const std::vector<std::string>& paths, bool coarse, const std::string& ripple_dir) {
  std::vector<Log> logs;
  for (const auto& p : paths) logs.push_back(load(p, 0.0));
  Motor m = given;
  identify_friction(logs, m);
  long n_ekf = 0, n_smo = 0;
  // J: 1e-7..1e-1 kg m^2 (a 25 mm gear motor's rotor is ~1e-6 at the motor shaft, x ratio^2
  // at the output; up to a J that slows the model to seconds). Noise variances per sample.
  std::vector<Axis> ekf_axes = {{"j_kgm2", -7, -1, 7}, {"q_w", -4, 4, 9}, {"q_t", -10, -2, 9},
                                      {"r_A2", -8, -2, 7}};
  const int refinements = coarse ? 1 : 2;
  if (coarse) ekf_axes = coarser(ekf_axes);
  auto ekf = grid_tune(ekf_axes, refinements, [&](const std::vector<double>& p) {
    const EkfParams e{p[0], p[1], p[2], p[3]};
    return score(logs, [&] { return Ekf(m, e); });
  }, n_ekf);
  // With the ripple counts of the training rows (--ripple): the EKF that takes the count as a
  // second measurement tuned over the same grid, since the noises that fit the current alone
  // (a current trusted to 1e-8 A^2 stands for M2's bias, not for noise) are not those that
  // fit both.
  std::pair<std::vector<double>, double> ekf_ripple{{NAN, NAN, NAN, NAN}, NAN};
  long n_ekf_ripple = 0;
  if (!ripple_dir.empty()) {
    std::vector<RippleSpeeds> rip;
    for (size_t l = 0; l < logs.size(); ++l) rip.push_back(read_ripple_speeds(ripple_file(ripple_dir, paths[l]), logs[l].data.size()));
    ekf_ripple = grid_tune(ekf_axes, refinements, [&](const std::vector<double>& p) {
      const EkfParams e{p[0], p[1], p[2], p[3]};
      return score_of(logs, [&](size_t l) { return replay_ekf_ripple(logs[l], Ekf(m, e), rip[l]); });
    }, n_ekf_ripple);
  }
  // k: 1e-4..10 V per sample; phi: 1e-5..1 A; tau: 0.01..30 s.
  std::vector<Axis> smo_axes = {{"k_V", -4, 1, 11}, {"phi_A", -5, 0, 11}, {"tau_s", -2, 1.5, 8}};
  if (coarse) smo_axes = coarser(smo_axes);
  auto smo = grid_tune(smo_axes, refinements, [&](const std::vector<double>& p) {
    const SmoParams s{p[0], p[1], p[2]};
    return score(logs, [&] { return Smo(m, s); });
  }, n_smo);
  size_t rows = 0;
  for (const auto& L : logs) rows += L.data.size();
  std::printf("{\"motor\": {\"ke_vs_per_rad\": %.17g, \"ra_ohm\": %.17g, \"b_nms_per_rad\": %.17g, \"tc_nm\": %.17g},\n"
              " \"ekf\": {\"j_kgm2\": %.17g, \"q_w\": %.17g, \"q_t\": %.17g, \"r_A2\": %.17g},\n"
              " \"smo\": {\"k_V\": %.17g, \"phi_A\": %.17g, \"tau_s\": %.17g},\n"
              " \"train_rmse_rpm\": {\"ekf\": %.17g, \"smo\": %.17g, \"m2\": %.17g},\n"
              " \"evaluations\": {\"ekf\": %ld, \"smo\": %ld}, \"rows\": %zu",
              m.ke_vs_per_rad, m.ra_ohm, m.b_nms_per_rad, m.tc_nm, ekf.first[0], ekf.first[1], ekf.first[2],
              ekf.first[3], smo.first[0], smo.first[1], smo.first[2], ekf.second, smo.second, m2_score(logs, m),
              n_ekf, n_smo, rows);
  if (!ripple_dir.empty())
    std::printf(",\n \"ekf_ripple\": {\"j_kgm2\": %.17g, \"q_w\": %.17g, \"q_t\": %.17g, \"r_A2\": %.17g, "
                "\"train_rmse_rpm\": %.17g, \"evaluations\": %ld}",
                ekf_ripple.first[0], ekf_ripple.first[1], ekf_ripple.first[2], ekf_ripple.first[3], ekf_ripple.second,
                n_ekf_ripple);
  std::printf("}\n");
  return 0;
}

std::vector<double> numbers(const std::string& text, size_t count, const std::string& what) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::stod(item));
  if (out.size() != count) throw std::runtime_error(what + " needs " + std::to_string(count) + " numbers");
  return out;
}

/// The pure network's file (hpddo.studies.compare writes it): "hpddo-mlp 1", the layer sizes
/// (inputs first, output 1 last), the scaler's mean and scale, then per layer its
/// weights [out x in] row by row and its biases.
Mlp read_mlp(const std::string& path) {
  std::ifstream f(path);
  std::string magic;
  int version = 0, layers = 0;
  if (!(f >> magic >> version >> layers) || magic != "hpddo-mlp" || version != 1 || layers < 2)
    throw std::runtime_error(path + ": not a network file of hpddo compare");
  std::vector<int> sizes(static_cast<size_t>(layers));
  for (auto& s : sizes) f >> s;
  Mlp m;
  m.mean.resize(sizes[0]);
  m.scale.resize(sizes[0]);
  for (int k = 0; k < sizes[0]; ++k) f >> m.mean(k);
  for (int k = 0; k < sizes[0]; ++k) f >> m.scale(k);
  for (size_t l = 0; l + 1 < sizes.size(); ++l) {
    Eigen::MatrixXf w(sizes[l + 1], sizes[l]);
    Eigen::VectorXf b(sizes[l + 1]);
    for (int r = 0; r < w.rows(); ++r)
      for (int c = 0; c < w.cols(); ++c) f >> w(r, c);
    for (int r = 0; r < b.size(); ++r) f >> b(r);
    m.w.push_back(w);
    m.b.push_back(b);
  }
  if (!f) throw std::runtime_error(path + ": network file ends early");
  return m;
}

/// The pure network's speed for every row: inputs (V, I, I(t-1), V(t-1)), the lags
/// restarting (the row's own values) where the estimators restart.
std::vector<double> replay_mlp(const Log& L, const Mlp& net) {
  const auto& d = L.data;
  std::vector<double> out(d.size());
  Eigen::VectorXf x(4);
  for (size_t k = 0; k < d.size(); ++k) {
    const size_t p = L.start[k] ? k : k - 1;
    x << static_cast<float>(d.v_V[k]), static_cast<float>(d.i_A[k]), static_cast<float>(d.i_A[p]),
        static_cast<float>(d.v_V[p]);
    out[k] = net.predict(x);
  }
  return out;
}

int run(const Motor& m, const EkfParams& e, const SmoParams& s, const std::string& mlp_path,
        const std::string& ripple_dir, const EkfParams& e_ripple, double fraction, const std::string& out_dir,
        const std::vector<std::string>& paths) {
  Mlp net;
  const bool has_mlp = !mlp_path.empty();
  if (has_mlp) {
    net = read_mlp(mlp_path);
    if (net.inputs() != 4) throw std::runtime_error(mlp_path + ": the pure network takes 4 inputs");
  }
  for (const auto& p : paths) {
    const Log L = load(p, fraction);
    const auto ekf = replay(L, Ekf(m, e));
    const auto smo = replay(L, Smo(m, s));
    const auto nn = has_mlp ? replay_mlp(L, net) : std::vector<double>(L.data.size(), NAN);
    const size_t split = hpddo_host::split_row(L.data, fraction);
    const std::string stem = hpddo_host::file_stem(p);
    const auto ekf_ripple =
        ripple_dir.empty()
            ? std::vector<double>(L.data.size(), NAN)
            : replay_ekf_ripple(L, Ekf(m, e_ripple), read_ripple_speeds(ripple_file(ripple_dir, p), L.data.size()));
    const std::string path = out_dir + "/" + stem + ".observers.csv";
    std::ofstream f(path + ".tmp");
    f << "t_s,rpm_ref,rpm_ekf,rpm_smo,rpm_nn,rpm_ekf_ripple,part\n";
    char buf[256];
    for (size_t k = 0; k < L.data.size(); ++k) {
      char ref[32] = "";
      if (std::isfinite(L.data.rpm_ref[k])) std::snprintf(ref, sizeof ref, "%.10g", L.data.rpm_ref[k]);
      std::snprintf(buf, sizeof buf, "%.10g,%s,%.9g,%.9g,%.9g,%.9g,%s\n", L.data.t_s[k], ref, ekf[k], smo[k], nn[k],
                    ekf_ripple[k], k < split ? "train" : "test");
      f << buf;
    }
    f.close();
    if (!f || std::rename((path + ".tmp").c_str(), path.c_str()) != 0)
      throw std::runtime_error("cannot write " + path);
  }
  return 0;
}

int usage() {
  std::fprintf(stderr,
               "usage: compare_observers tune --ke KE --ra RA [--coarse] [--ripple RDIR] LOG...\n"
               "       compare_observers run --motor KE,RA,B,TC --ekf J,QW,QT,R --smo K,PHI,TAU [--mlp FILE] "
               "[--ripple RDIR --ekf-ripple J,QW,QT,R] [--split F] --out-dir DIR LOG...\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const std::string mode = argv[1];
  Motor m;
  EkfParams e, e_ripple;
  SmoParams s;
  std::string mlp, ripple_dir, out_dir;
  double fraction = 0.0;
  bool have_motor = false, have_ekf = false, have_smo = false, have_ekf_ripple = false, coarse = false;
  std::vector<std::string> paths;
  try {
    for (int a = 2; a < argc; ++a) {
      const std::string arg = argv[a];
      auto next = [&]() -> std::string {
        if (a + 1 >= argc) throw std::runtime_error("option " + arg + " needs a value");
        return argv[++a];
      };
      if (arg == "--ke") m.ke_vs_per_rad = std::stod(next());
      else if (arg == "--ra") m.ra_ohm = std::stod(next());
      else if (arg == "--motor") {
        const auto v = numbers(next(), 4, arg);
        m = Motor{v[0], v[1], v[2], v[3]};
        have_motor = true;
      } else if (arg == "--ekf") {
        const auto v = numbers(next(), 4, arg);
        e = EkfParams{v[0], v[1], v[2], v[3]};
        have_ekf = true;
      } else if (arg == "--ekf-ripple") {
        const auto v = numbers(next(), 4, arg);
        e_ripple = EkfParams{v[0], v[1], v[2], v[3]};
        have_ekf_ripple = true;
      } else if (arg == "--smo") {
        const auto v = numbers(next(), 3, arg);
        s = SmoParams{v[0], v[1], v[2]};
        have_smo = true;
      } else if (arg == "--mlp") mlp = next();
      else if (arg == "--ripple") ripple_dir = next();
      else if (arg == "--coarse") coarse = true;
      else if (arg == "--split") fraction = std::stod(next());
      else if (arg == "--out-dir") out_dir = next();
      else if (!arg.empty() && arg[0] == '-') return usage();
      else paths.push_back(arg);
    }
    if (paths.empty()) return usage();
    if (mode == "tune") {
      if (!(m.ke_vs_per_rad > 0 && m.ra_ohm > 0)) throw std::runtime_error("tune needs --ke > 0 and --ra > 0");
      return tune(m, paths, coarse, ripple_dir);
    }
    if (mode == "run") {
      if (!(have_motor && have_ekf && have_smo) || out_dir.empty()) return usage();
      if (ripple_dir.empty() != !have_ekf_ripple) return usage();  // --ripple and --ekf-ripple go together
      return run(m, e, s, mlp, ripple_dir, e_ripple, fraction, out_dir, paths);
    }
    return usage();
  } catch (const hpddo_host::LogError& err) {
    std::fprintf(stderr, "compare_observers: %s\n", err.what());
    return 1;
  } catch (const std::exception& err) {
    std::fprintf(stderr, "compare_observers: %s\n", err.what());
    return 1;
  }
}
