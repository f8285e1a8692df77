// Device-independent types: timestamped 6-DOF sensor samples, 6-DOF input frames (Spaceball,
// SpaceMouse), and device status. Positions in metres, orientations as unit quaternions giving
// the device's reference frame from the sensor frame (reference_from_sensor).
#pragma once

#include <cstdint>
#include <string>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace mimic::devices {

enum SampleFlags : uint32_t {
  kSampleValid = 1u << 0,
  kSampleStale = 1u << 1,    // no fresh data: the last good value is repeated
  kSampleButton = 1u << 2,   // `buttons` holds a button state
  kSampleOutlier = 1u << 3,  // rejected downstream as physically impossible
};

struct SensorSample {
  uint16_t sensor = 0;                // sensor id: its index in a layout (a Flock's bird in address order)
  double device_time_s = 0;           // device clock, when known; otherwise derived from rate
  double host_time_s = 0;             // host monotonic clock at the record's last byte
  glm::vec3 position_m{0.0f};         // reference_from_sensor translation
  glm::quat orientation{1, 0, 0, 0};  // reference_from_sensor rotation
  uint32_t buttons = 0;
  uint32_t flags = kSampleValid;
};

// Spaceball / SpaceMouse: translation and rotation deflections, scaled to [-1, 1] per axis.
struct InputFrame {
  double host_time_s = 0;
  glm::vec3 translation{0.0f};
  glm::vec3 rotation{0.0f};
  uint32_t buttons = 0;  // bit i = button i+1
};

enum class DeviceState : uint8_t { disconnected, connecting, streaming, stale, error };

struct DeviceStatus {
  DeviceState state = DeviceState::disconnected;
  std::string description;  // human-readable, e.g. "flock:/dev/ttyUSB0 4 birds, 115200 baud"
  std::string last_error;
  uint64_t records = 0;
  uint64_t resyncs = 0;  // phase errors / garbage skipped
  uint64_t reconnects = 0;
};

}  // namespace mimic::devices
