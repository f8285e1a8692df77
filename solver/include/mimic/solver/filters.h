// Input filtering for tracker samples: One Euro filters (Casiez, Roussel & Vogel, CHI 2012) on
// position and orientation, a short-horizon predictor that pays back the filter's (and the
// tracker's) latency, and rejection of jumps no body can make.
//
// One Euro: an exponential smoother whose cutoff rises with speed, fc = min_cutoff + beta·|ẋ|, so
// a still sensor is smoothed hard (no jitter) and a fast one barely (little lag). Its lag at a
// cutoff fc is about 1/(2π·fc) seconds; SensorFilterBank extrapolates each filtered pose along
// its filtered velocity by that lag (compensate_lag) plus `predict_s` (e.g. the tracker's
// latency, to see the body "now"; 0 by default). Orientations are filtered on the unit sphere (slerp),
// their speed being the angular speed.
//
// Outliers: a sample farther from the last accepted one than max_speed · elapsed time (+ a noise
// allowance), or turned faster than max_angular_speed, is replaced by the prediction and flagged
// kSampleOutlier | kSampleStale (kept valid, so the solver holds the segment). After
// `accept_after` consecutive outliers the new place is believed (the tracker was re-seated) and
// the filter restarts there. Invalid samples (dropouts) are likewise bridged by the prediction
// for at most `hold_s`, then passed on invalid.
//
// Fixed-lag smoothing: after the One Euro stage each sensor's pose passes a short FIR
// (FixedLagSmoother) whose taps reproduce a straight-line motion `lag_samples` late and, of all
// such taps over `window` samples, pass the least white noise into the second difference — the
// sample-to-sample shake a viewer sees. A One Euro filter cannot do that while the body moves:
// its cutoff rises with speed, so the noise passes almost untouched. The defaults keep straight
// lines on time (lag 0) over 8 samples, cutting the noise's second difference about 6×; a
// second, sharper tap set takes over where the motion bends (SmootherParams::bend), so a
// swinging foot is not cut short. A one-sample lag would shake less still but costs a walking
// hand or foot about a centimetre of accuracy (docs/solver.md, Jitter).
//
// Time is the sample's device_time_s when it advances, else host_time_s. Nothing allocates after
// construction; process() never throws.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/devices/sample.h"

namespace mimic::solver {

struct OneEuroParams {
  float min_cutoff_hz = 1.0f;  // cutoff of a still signal
  float beta = 0.5f;           // cutoff increase per unit of speed (per m/s or per rad/s)
  float derivative_cutoff_hz = 1.0f;
};

// Smoothing factor of a first-order low-pass at cutoff fc sampled every dt.
float one_euro_alpha(float cutoff_hz, float dt_s);

class OneEuroVec3 {
 public:
  explicit OneEuroVec3(OneEuroParams p = {}) : p_(p) {}
  glm::vec3 filter(const glm::vec3& x, float dt_s);
  void reset() { primed_ = false; }
  const glm::vec3& value() const { return x_; }
  const glm::vec3& velocity() const { return dx_; }  // filtered, units per second
  float lag_s() const { return lag_s_; }             // time constant at the current cutoff
  bool primed() const { return primed_; }

 private:
  OneEuroParams p_;
  float lag_s_ = 0;
  glm::vec3 x_{0.0f}, dx_{0.0f}, raw_{0.0f};
  bool primed_ = false;
};

class OneEuroQuat {
 public:
  explicit OneEuroQuat(OneEuroParams p = {}) : p_(p) {}
  glm::quat filter(const glm::quat& q, float dt_s);
  void reset() { primed_ = false; }
  const glm::quat& value() const { return q_; }
  const glm::vec3& angular_velocity() const { return w_; }  // world frame, rad/s
  float lag_s() const { return lag_s_; }
  bool primed() const { return primed_; }

 private:
  OneEuroParams p_;
  float lag_s_ = 0;
  glm::quat q_{1, 0, 0, 0}, raw_{1, 0, 0, 0};
  glm::vec3 w_{0.0f};
  bool primed_ = false;
};

inline constexpr int kMaxSmootherTaps = 8;

struct SmootherParams {
  int window = 8;            // samples; 1 turns smoothing off
  float lag_samples = 0.0f;  // how late a straight-line motion comes out, 0 … window − 1
  // Weight of the taps' second moment (Σk²·h[k])², which sets the bias under acceleration
  // (a·dt²·Σk²h/2): 0 leaves it free, larger keeps curves on their path at more shake.
  float curvature_weight = 0.0f;
  // A second, sharper tap set on the same samples (curvature weight `sharp_curvature_weight`).
  // Where the two disagree by more than `bend` (m, or rad for orientations) the motion really
  // bends and the output follows the sharp one; below it the difference is noise and the smooth
  // one stands: out = sharp + (smooth − sharp)·bend²/(bend² + |smooth − sharp|²). 0: smooth only.
  float sharp_curvature_weight = 0.1f;
  float bend = 0.0f;
};

// FIR taps h[0 … window) (h[0] on the newest sample, zero past the window) with Σh = 1 and
// Σk·h[k] = lag_samples, minimising the white-noise gain of the second difference,
// Σ_t (h[t] − 2h[t−1] + h[t−2])², plus curvature_weight·(Σk²·h[k])². The window is clamped to
// 1 … kMaxSmootherTaps.
std::array<float, kMaxSmootherTaps> fixed_lag_taps(SmootherParams p);

// One sensor's FIR over its last samples, positions and orientations each with its own taps
// (fixed_lag_taps, and the sharp set where SmootherParams::bend > 0). Orientations are averaged
// as rotation vectors relative to the newest (a few samples are small angles apart). Fixed
// storage: never allocates.
class FixedLagSmoother {
 public:
  explicit FixedLagSmoother(SmootherParams position = {}, SmootherParams rotation = {});
  // Adds a sample and returns the smoothed pose in place. The first sample after reset() fills
  // the whole history (a still start).
  void filter(glm::vec3& position, glm::quat& orientation);
  void reset() { count_ = 0; }

 private:
  struct Channel {
    std::array<float, kMaxSmootherTaps> taps{}, sharp{};
    int window = 1;
    float bend = 0;
  };
  static Channel channel(const SmootherParams& p);
  // The smooth and sharp sums of offsets from the newest sample, blended.
  template <class Offset>
  glm::vec3 offset(const Channel& c, Offset&& offset_of) const;

  Channel pos_ch_, rot_ch_;
  std::array<glm::vec3, kMaxSmootherTaps> pos_{};
  std::array<glm::quat, kMaxSmootherTaps> rot_{};
  int newest_ = 0;  // index of the newest sample in the ring of kMaxSmootherTaps
  int count_ = 0;
};

struct SensorFilterConfig {
  OneEuroParams position{3.0f, 160.0f, 1.0f};  // beta per m/s
  OneEuroParams rotation{3.0f, 16.0f, 1.0f};   // beta per rad/s
  float predict_s = 0.0f;                      // extrapolation horizon beyond the filter lag
  bool compensate_lag = true;                  // extrapolate by each filter's own lag
  float max_speed_m_s = 12.0f;                 // faster than any limb moves
  float max_angular_speed_deg_s = 3000.0f;
  float jump_allowance_m = 0.05f;  // noise and sample-timing slack on top
  int accept_after = 12;           // consecutive outliers that move the filter
  float hold_s = 0.25f;            // bridge dropouts this long
  bool enabled = true;             // false: only outlier rejection and dropout bridging
  // After the One Euro stage (window 1: none): 8 samples, straight lines on time; positions turn
  // to the sharp taps on bends beyond 1 cm, orientations beyond 0.05 rad (chosen on the shared
  // clips, docs/solver.md: Jitter).
  SmootherParams position_smoother{8, 0.0f, 0.0003f, 0.1f, 0.01f};
  SmootherParams rotation_smoother{8, 0.0f, 0.001f, 0.1f, 0.05f};
};

class SensorFilterBank {
 public:
  // Sensor ids 0 … max_sensor_id. Allocates.
  explicit SensorFilterBank(int max_sensor_id, SensorFilterConfig config = {});

  // Filters the samples in place (ids above max_sensor_id pass untouched). Never allocates.
  void process(std::span<devices::SensorSample> samples);
  void reset();
  const SensorFilterConfig& config() const { return config_; }
  uint64_t outliers() const { return outliers_; }

 private:
  struct State {
    OneEuroVec3 pos;
    OneEuroQuat rot;
    FixedLagSmoother smooth;
    double last_t = 0;
    double last_good_t = 0;
    bool seen = false;
    int outlier_streak = 0;
    glm::vec3 last_raw_pos{0.0f};
    glm::quat last_raw_rot{1, 0, 0, 0};
  };
  void smooth(State& st, devices::SensorSample& smp) const;

  SensorFilterConfig config_;
  std::vector<State> state_;
  uint64_t outliers_ = 0;
};

}  // namespace mimic::solver
