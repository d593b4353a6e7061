// The classical competitors of the hybrid observer (hpddo compare, docs/compare.md):
// an extended Kalman filter on the mechanical model and a sliding-mode observer in the
// quasi-steady current formulation, plus a float32 dense ReLU network for the pure
// data-driven baseline. Host only (double precision for the observers, as a desk
// implementation would be; float32 for the network, as on the boards). Every input is
// a sample's mean terminal voltage v_V and armature current i_A over its period dt_s.
#ifndef HPDDO_HOST_COMPARE_OBSERVERS_H
#define HPDDO_HOST_COMPARE_OBSERVERS_H

#include <Eigen/Dense>

#include <cmath>
#include <string>
#include <vector>

namespace hpddo_compare {

constexpr double kRpmPerRadS = 60.0 / (2.0 * M_PI);
/// Coulomb friction as Tc tanh(w / kCoulombSmoothRadS): the sign function smoothed over
/// 1 rad/s, so that the EKF's Jacobian exists at standstill.
constexpr double kCoulombSmoothRadS = 1.0;

/// The identified motor: the physics model M2's Ke and Ra, and the friction of the
/// steady-state torque balance Ke i = B w + Tc sgn(w) (Kt = Ke in SI units).
struct Motor {
  double ke_vs_per_rad = 0.0;
  double ra_ohm = 0.0;
  double b_nms_per_rad = 0.0;  ///< viscous friction, N m s/rad
  double tc_nm = 0.0;          ///< Coulomb friction, N m
};

/// M2 speed from one sample, rad/s: (V - I Ra) / Ke.
inline double m2_rad_s(const Motor& m, double v_V, double i_A) { return (v_V - i_A * m.ra_ohm) / m.ke_vs_per_rad; }

struct EkfParams {
  double j_kgm2 = 1e-4;      ///< rotor inertia seen at the output shaft
  double q_w = 1.0;          ///< process noise of w, (rad/s)^2 per sample
  double q_t = 1e-4;         ///< random walk of T_L, (N m)^2 per sample
  double r_A2 = 1e-4;        ///< measurement noise of i, A^2
};

/// EKF with state x = [w (rad/s), T_L (N m)]:
///   J dw/dt = Kt (V - Ke w)/Ra - B w - Tc tanh(w/ws) - T_L,  dT_L/dt = noise,
/// the linear part discretised exactly over each period (stable at any dt, as the
/// mechanical time constant J Ra / (Ke Kt) is far below the 500 ms of a 2 Hz log), the
/// Coulomb term and T_L held over the period (the shaft stopped where Coulomb friction would
/// carry it through zero); measurement i = (V - Ke w)/Ra.
class Ekf {
 public:
  Ekf(const Motor& m, const EkfParams& p) : m_(m), p_(p) {}

  /// Starts from the sample's M2 speed and the steady-state load torque it implies.
  void restart(double v_V, double i_A) {
    const double w = m2_rad_s(m_, v_V, i_A);
    x_ << w, m_.ke_vs_per_rad * i_A - m_.b_nms_per_rad * w - coulomb(w);
    P_ << kInitW, 0.0, 0.0, kInitT;
  }

  /// One sample; returns the speed estimate, rad/s.
  double step(double v_V, double i_A, double dt_s) {
    const double ke = m_.ke_vs_per_rad, ra = m_.ra_ohm, j = p_.j_kgm2;
    const double a = (ke * ke / ra + m_.b_nms_per_rad) / j;  // 1/s
    const double phi = std::exp(-a * dt_s);
    const double g = (1.0 - phi) / (a * j);  // rad/s per N m of constant torque over the period
    const double w = x_(0), tl = x_(1);
    const double th = std::tanh(w / kCoulombSmoothRadS);
    const double drive = ke * v_V / ra - tl;  // N m: the torque at standstill, before friction
    const double u = drive - m_.tc_nm * th;
    x_(0) = phi * w + g * u;
    // Coulomb friction stops the shaft, it cannot turn it back: held over a period longer than the
    // time to stop, -Tc sgn(w) would carry the speed through zero (a limit cycle of +-g Tc at
    // standstill). Where the speed would change sign and the drive cannot overcome Tc, the shaft
    // stands at the period's end.
    if (x_(0) * w < 0.0 && std::fabs(drive) <= m_.tc_nm) x_(0) = 0.0;
    Eigen::Matrix2d F;
    F << phi - g * m_.tc_nm * (1.0 - th * th) / kCoulombSmoothRadS, -g, 0.0, 1.0;
    P_ = F * P_ * F.transpose();
    P_(0, 0) += p_.q_w;
    P_(1, 1) += p_.q_t;
    const Eigen::RowVector2d H(-ke / ra, 0.0);
    const double y = i_A - (v_V - ke * x_(0)) / ra;
    const double s = (H * P_ * H.transpose())(0, 0) + p_.r_A2;
    const Eigen::Vector2d K = P_ * H.transpose() / s;
    x_ += K * y;
    const Eigen::Matrix2d IKH = Eigen::Matrix2d::Identity() - K * H;
    P_ = IKH * P_ * IKH.transpose() + K * p_.r_A2 * K.transpose();  // Joseph form
    return x_(0);
  }

  /// A second measurement of the speed itself (the count of the commutation ripple,
  /// hpddo.ripple), w_rad_s with variance var_rad2_s2, after step(): the same Joseph
  /// update with H = [1 0]. Returns the speed estimate, rad/s.
  double update_speed(double w_rad_s, double var_rad2_s2) {
    const Eigen::RowVector2d H(1.0, 0.0);
    const double s = P_(0, 0) + var_rad2_s2;
    const Eigen::Vector2d K = P_ * H.transpose() / s;
    x_ += K * (w_rad_s - x_(0));
    const Eigen::Matrix2d IKH = Eigen::Matrix2d::Identity() - K * H;
    P_ = IKH * P_ * IKH.transpose() + K * var_rad2_s2 * K.transpose();
    return x_(0);
  }

  double load_torque_nm() const { return x_(1); }

 private:
  static constexpr double kInitW = 100.0;   ///< initial variance of w, (rad/s)^2
  static constexpr double kInitT = 1e-2;    ///< initial variance of T_L, (N m)^2
  double coulomb(double w) const { return m_.tc_nm * std::tanh(w / kCoulombSmoothRadS); }
  Motor m_;
  EkfParams p_;
  Eigen::Vector2d x_ = Eigen::Vector2d::Zero();
  Eigen::Matrix2d P_ = Eigen::Matrix2d::Identity();
};

struct SmoParams {
  double k_V = 0.1;      ///< switching gain: largest step of the injected back-EMF per sample, V
  double phi_A = 1e-2;   ///< boundary layer of the current error, A
  double tau_s = 0.0;    ///< time constant of the low-pass filter on the injected back-EMF, s
};

/// Sliding-mode observer in the quasi-steady current formulation. The armature's
/// electrical time constant L/Ra is far below a 2 Hz sample period, so the observer's
/// current is its steady state under the injected back-EMF z, i_hat = (V - z)/Ra. The
/// sliding variable is the current error s = i_hat - I; the switching signal
/// k sat(s/phi) (boundary layer phi) moves z each sample, and the estimate is z through
/// a first-order low-pass filter (time constant tau), over Ke. On the sliding surface
/// s = 0, z is the back-EMF V - I Ra: M2's, reached with a bounded slew (k per sample).
class Smo {
 public:
  Smo(const Motor& m, const SmoParams& p) : m_(m), p_(p) {}

  void restart(double v_V, double i_A) { z_ = zf_ = v_V - i_A * m_.ra_ohm; }

  double step(double v_V, double i_A, double dt_s) {
    const double s = (v_V - z_) / m_.ra_ohm - i_A;
    const double sat = std::fmax(-1.0, std::fmin(1.0, s / p_.phi_A));
    z_ += p_.k_V * sat;
    const double alpha = dt_s / (p_.tau_s + dt_s);
    zf_ += alpha * (z_ - zf_);
    return zf_ / m_.ke_vs_per_rad;
  }

 private:
  Motor m_;
  SmoParams p_;
  double z_ = 0.0, zf_ = 0.0;
};

/// A dense ReLU network with a linear scalar output, float32, on standardised inputs.
struct Mlp {
  Eigen::VectorXf mean, scale;
  std::vector<Eigen::MatrixXf> w;  ///< [out x in]
  std::vector<Eigen::VectorXf> b;

  int inputs() const { return static_cast<int>(mean.size()); }

  float predict(const Eigen::VectorXf& x) const {
    Eigen::VectorXf a = (x - mean).cwiseQuotient(scale);
    for (size_t k = 0; k < w.size(); ++k) {
      a = w[k] * a + b[k];
      if (k + 1 < w.size()) a = a.cwiseMax(0.0f);
    }
    return a(0);
  }
};

}  // namespace hpddo_compare

#endif  // HPDDO_HOST_COMPARE_OBSERVERS_H
