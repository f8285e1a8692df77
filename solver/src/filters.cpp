#include "mimic/solver/filters.h"

#include <algorithm>
#include <cmath>

#include "rotation_vector.h"
#include "sample_check.h"

namespace mimic::solver {

namespace {

constexpr float kTwoPi = 6.28318530718f;

using detail::exp_rotation;

bool finite(const devices::SensorSample& s) { return detail::finite_sample(s); }

}  // namespace

float one_euro_alpha(float cutoff_hz, float dt_s) {
  // 1/(1 + τ/dt) with τ = 1/(2π·fc), in one division.
  const float x = kTwoPi * std::max(cutoff_hz, 1e-4f) * std::max(dt_s, 1e-6f);
  return x / (x + 1.0f);
}

glm::vec3 OneEuroVec3::filter(const glm::vec3& x, float dt_s) {
  if (!primed_ || !(dt_s > 0)) {
    if (!primed_) x_ = x, dx_ = glm::vec3(0.0f);
    raw_ = x;
    primed_ = true;
    return x_;
  }
  // The speed from raw samples (not from the lagging output), so it is the signal's true speed:
  // it sets the cutoff and extrapolates the output.
  const glm::vec3 raw_dx = (x - raw_) / dt_s;
  raw_ = x;
  dx_ += one_euro_alpha(p_.derivative_cutoff_hz, dt_s) * (raw_dx - dx_);
  const float cutoff = p_.min_cutoff_hz + p_.beta * glm::length(dx_);
  lag_s_ = 1.0f / (kTwoPi * std::max(cutoff, 1e-3f));
  x_ += one_euro_alpha(cutoff, dt_s) * (x - x_);
  return x_;
}

glm::quat OneEuroQuat::filter(const glm::quat& q_in, float dt_s) {
  glm::quat q = glm::normalize(q_in);
  if (!primed_ || !(dt_s > 0)) {
    if (!primed_) q_ = q, w_ = glm::vec3(0.0f);
    raw_ = q;
    primed_ = true;
    return q_;
  }
  if (glm::dot(q, q_) < 0) q = -q;  // the nearer of ±q
  // A sample apart is a small turn: 2·(x, y, z) of the relative quaternion is its rotation vector
  // to 10⁻⁴ at 0.07 rad (8 rad/s at 120 Hz), 4 % short at a whole radian, without an arctangent.
  const glm::quat d = q * glm::conjugate(raw_);
  const glm::vec3 raw_w = (d.w < 0 ? -2.0f : 2.0f) / dt_s * glm::vec3(d.x, d.y, d.z);
  raw_ = q;
  w_ += one_euro_alpha(p_.derivative_cutoff_hz, dt_s) * (raw_w - w_);
  const float cutoff = p_.min_cutoff_hz + p_.beta * glm::length(w_);
  lag_s_ = 1.0f / (kTwoPi * std::max(cutoff, 1e-3f));
  // The filtered orientation trails the sample by a small turn (its lag: 0.2 rad at 8 rad/s), where
  // the normalised blend is the spherical one to 10⁻⁴ rad, without an arccosine and two sines.
  const float a = one_euro_alpha(cutoff, dt_s);
  q_ = glm::normalize((1.0f - a) * q_ + a * q);
  return q_;
}

std::array<float, kMaxSmootherTaps> fixed_lag_taps(SmootherParams p) {
  std::array<float, kMaxSmootherTaps> taps{};
  const int n = std::clamp(p.window, 1, kMaxSmootherTaps);
  const double lag = std::clamp(static_cast<double>(p.lag_samples), 0.0, n - 1.0);
  if (n == 1) {
    taps[0] = 1.0f;
    return taps;
  }
  // Lagrange system [2A Cᵀ; C 0]·[h; μ] = [0; 1; lag], A the autocorrelation of [1, −2, 1]
  // (6 on the diagonal, −4 and 1 beside it), C the rows Σh and Σk·h. Gauss-Jordan with partial
  // pivoting on a fixed array: at most 10 unknowns.
  constexpr int kMax = kMaxSmootherTaps + 2;
  double m[kMax][kMax + 1] = {};
  const int size = n + 2;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const int d = std::abs(i - j);
      m[i][j] = 2.0 * ((d == 0   ? 6.0
                        : d == 1 ? -4.0
                        : d == 2 ? 1.0
                                 : 0.0) +
                       static_cast<double>(p.curvature_weight) * i * i * j * j);
    }
    m[i][n] = m[n][i] = 1.0;
    m[i][n + 1] = m[n + 1][i] = static_cast<double>(i);
  }
  m[n][size] = 1.0;
  m[n + 1][size] = lag;
  for (int c = 0; c < size; ++c) {
    int pivot = c;
    for (int r = c + 1; r < size; ++r)
      if (std::abs(m[r][c]) > std::abs(m[pivot][c])) pivot = r;
    for (int k = 0; k <= size; ++k) std::swap(m[c][k], m[pivot][k]);
    for (int r = 0; r < size; ++r) {
      if (r == c) continue;
      const double f = m[r][c] / m[c][c];
      for (int k = c; k <= size; ++k) m[r][k] -= f * m[c][k];
    }
  }
  for (int i = 0; i < n; ++i) taps[static_cast<size_t>(i)] = static_cast<float>(m[i][size] / m[i][i]);
  return taps;
}

FixedLagSmoother::Channel FixedLagSmoother::channel(const SmootherParams& p) {
  Channel c;
  c.window = std::clamp(p.window, 1, kMaxSmootherTaps);
  c.taps = fixed_lag_taps(p);
  c.bend = std::max(0.0f, p.bend);
  if (c.bend > 0) c.sharp = fixed_lag_taps({p.window, p.lag_samples, p.sharp_curvature_weight});
  return c;
}

FixedLagSmoother::FixedLagSmoother(SmootherParams position, SmootherParams rotation)
    : pos_ch_(channel(position)), rot_ch_(channel(rotation)) {}

template <class Offset>
glm::vec3 FixedLagSmoother::offset(const Channel& c, Offset&& offset_of) const {
  glm::vec3 smooth(0.0f), sharp(0.0f);
  for (int k = 1; k < c.window; ++k) {
    const glm::vec3 d = offset_of(static_cast<size_t>((newest_ - k + kMaxSmootherTaps) % kMaxSmootherTaps));
    smooth += c.taps[static_cast<size_t>(k)] * d;
    sharp += c.sharp[static_cast<size_t>(k)] * d;
  }
  if (!(c.bend > 0)) return smooth;
  // A soft switch: the smooth taps' curvature bias grows with the bend, the noise they take out
  // does not, so a large disagreement is the motion's.
  const glm::vec3 diff = smooth - sharp;
  const float b2 = c.bend * c.bend;
  return sharp + diff * (b2 / (b2 + glm::dot(diff, diff)));
}

void FixedLagSmoother::filter(glm::vec3& position, glm::quat& orientation) {
  if (pos_ch_.window == 1 && rot_ch_.window == 1) return;
  const glm::quat q = glm::normalize(orientation);
  if (count_ == 0) {
    pos_.fill(position);
    rot_.fill(q);
    count_ = 1;
  }
  newest_ = (newest_ + 1) % kMaxSmootherTaps;
  pos_[static_cast<size_t>(newest_)] = position;
  rot_[static_cast<size_t>(newest_)] = q;
  // Offsets from the newest sample: Σh = 1, so its own weight is implied. Orientations as
  // rotation vectors from the newest, taken as 2·(x, y, z) of the relative quaternion: a window
  // apart is a small angle (0.5 rad at 8.6 rad/s, where that is 1 % short), and it spares an atan2
  // per tap.
  const glm::vec3 p = position;
  position += offset(pos_ch_, [&](size_t i) { return pos_[i] - p; });
  const glm::quat from_newest = glm::conjugate(q);
  const glm::vec3 dr = offset(rot_ch_, [&](size_t i) {
    const glm::quat d = rot_[i] * from_newest;
    return (d.w < 0 ? -2.0f : 2.0f) * glm::vec3(d.x, d.y, d.z);
  });
  // The correction is a small turn (noise and the lag of a bend): (1, dr/2) normalised turns by
  // 2·atan(|dr|/2), 1e-5 rad short at 0.05 rad, without a sine and cosine.
  orientation = glm::normalize(glm::quat(1.0f, 0.5f * dr.x, 0.5f * dr.y, 0.5f * dr.z) * q);
}

SensorFilterBank::SensorFilterBank(int max_sensor_id, SensorFilterConfig config)
    : config_(config), state_(static_cast<size_t>(std::max(0, max_sensor_id) + 1)) {
  reset();
}

void SensorFilterBank::reset() {
  const FixedLagSmoother smoother(config_.position_smoother, config_.rotation_smoother);  // taps once
  for (auto& s : state_) s = State{OneEuroVec3(config_.position), OneEuroQuat(config_.rotation), smoother};
  outliers_ = 0;
}

void SensorFilterBank::process(std::span<devices::SensorSample> samples) {
  for (auto& smp : samples) {
    if (smp.sensor >= state_.size()) continue;
    State& st = state_[smp.sensor];
    const double t = smp.device_time_s > st.last_t || !st.seen ? smp.device_time_s : smp.host_time_s;
    const float dt = st.seen ? static_cast<float>(t - st.last_t) : 0.0f;
    const bool usable = (smp.flags & devices::kSampleValid) && finite(smp);

    // Where the sensor should be now, from the filtered state: taken only for a sample replaced
    // (a dropout or an outlier), so that a good one does not pay for its rotation.
    auto predict = [&] {
      smp.position_m = st.pos.value() + st.pos.velocity() * std::max(dt, 0.0f);
      smp.orientation = glm::normalize(exp_rotation(st.rot.angular_velocity() * std::max(dt, 0.0f)) * st.rot.value());
    };

    if (!usable) {
      if (st.seen && t - st.last_good_t <= config_.hold_s) {
        predict();
        smp.flags = devices::kSampleValid | devices::kSampleStale | (smp.flags & devices::kSampleButton);
        smooth(st, smp);
      } else {
        st.smooth.reset();
      }
      continue;
    }
    const glm::quat unit = glm::normalize(smp.orientation);
    if (st.seen && dt > 0) {
      // Against the last accepted raw sample: a jump, not the filter's lag, makes an outlier.
      const float since = static_cast<float>(t - st.last_good_t);
      const float allowed = config_.max_speed_m_s * since + config_.jump_allowance_m;
      const float jump = glm::length(smp.position_m - st.last_raw_pos);
      const glm::quat d = unit * glm::conjugate(st.last_raw_rot);
      const float half_sin = glm::length(glm::vec3(d.x, d.y, d.z));
      const float allowed_deg = config_.max_angular_speed_deg_s * since + 10.0f;
      // The turn is 2·asin(half_sin) ≤ π·half_sin: a sample turned well within that bound needs
      // no arcsine (the usual case).
      const bool turned = half_sin * (180.0f * 1.01f) > allowed_deg &&
                          glm::degrees(2.0f * std::asin(std::min(1.0f, half_sin))) > allowed_deg;
      const bool outlier = jump > allowed || turned;
      if (outlier && ++st.outlier_streak < config_.accept_after) {
        ++outliers_;
        predict();
        smp.flags |= devices::kSampleOutlier | devices::kSampleStale;
        smooth(st, smp);
        st.last_t = t;
        continue;
      }
      if (outlier) {  // persistent: the sensor really is there now
        st.pos.reset();
        st.rot.reset();
        st.smooth.reset();
      }
    }
    st.outlier_streak = 0;
    st.last_raw_pos = smp.position_m;
    st.last_raw_rot = unit;
    const glm::vec3 p = st.pos.filter(smp.position_m, dt);
    const glm::quat q = st.rot.filter(unit, dt);
    if (config_.enabled) {
      // Each filter lags by its time constant 1/(2π·fc); extrapolating by it (plus the asked-for
      // horizon) puts the output back on time.
      const float lead_p = config_.predict_s + (config_.compensate_lag ? st.pos.lag_s() : 0.0f);
      const float lead_r = config_.predict_s + (config_.compensate_lag ? st.rot.lag_s() : 0.0f);
      smp.position_m = p + st.pos.velocity() * lead_p;
      smp.orientation = glm::normalize(exp_rotation(st.rot.angular_velocity() * lead_r) * q);
      smooth(st, smp);
    }
    st.seen = true;
    st.last_t = t;
    st.last_good_t = t;
  }
}

void SensorFilterBank::smooth(State& st, devices::SensorSample& smp) const {
  if (config_.enabled) st.smooth.filter(smp.position_m, smp.orientation);
}

}  // namespace mimic::solver
