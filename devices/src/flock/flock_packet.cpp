#include "mimic/devices/flock_packet.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <glm/gtc/matrix_access.hpp>

namespace mimic::devices::flock {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMetresPerInch = 0.0254;

// Scaled value -> word as it survives the wire: nearest multiple of 4, saturated to the range
// a 14-bit word can hold.
int16_t to_word(double scaled) {
  const double q = std::round(scaled / 4.0) * 4.0;
  return static_cast<int16_t>(std::clamp(q, -32768.0, 32764.0));
}

double position_factor(PositionRange r) { return full_scale_in(r) / 32768.0; }

glm::dquat positive_w(glm::dquat q) { return q.w < 0 ? -q : q; }

}  // namespace

int word_count(Format f) {
  switch (f) {
    case Format::position: return 3;
    case Format::angles: return 3;
    case Format::matrix: return 9;
    case Format::position_angles: return 6;
    case Format::position_matrix: return 12;
    case Format::quaternion: return 4;
    case Format::position_quaternion: return 7;
  }
  return 0;
}

bool has_position(Format f) {
  return f == Format::position || f == Format::position_angles || f == Format::position_matrix ||
         f == Format::position_quaternion;
}

uint8_t format_command(Format f) { return static_cast<uint8_t>('V' - 1 + static_cast<int>(f)); }

std::optional<Format> format_from_code(int code) {
  for (Format f : kAllFormats)
    if (static_cast<int>(f) == code) return f;
  return std::nullopt;
}

std::optional<Format> format_from_command(uint8_t command) {
  return format_from_code(static_cast<int>(command) - ('V' - 1));
}

const char* format_name(Format f) {
  switch (f) {
    case Format::position: return "position";
    case Format::angles: return "angles";
    case Format::matrix: return "matrix";
    case Format::position_angles: return "position_angles";
    case Format::position_matrix: return "position_matrix";
    case Format::quaternion: return "quaternion";
    case Format::position_quaternion: return "position_quaternion";
  }
  return "?";
}

std::optional<Format> parse_format(std::string_view name) {
  struct Alias {
    const char* name;
    Format f;
  };
  static constexpr Alias kAliases[] = {
      {"position", Format::position},
      {"pos", Format::position},
      {"angles", Format::angles},
      {"ang", Format::angles},
      {"matrix", Format::matrix},
      {"mat", Format::matrix},
      {"position_angles", Format::position_angles},
      {"pos_angles", Format::position_angles},
      {"position_matrix", Format::position_matrix},
      {"pos_matrix", Format::position_matrix},
      {"quaternion", Format::quaternion},
      {"quat", Format::quaternion},
      {"position_quaternion", Format::position_quaternion},
      {"pos_quat", Format::position_quaternion},
  };
  for (const auto& a : kAliases)
    if (name == a.name) return a.f;
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------

size_t encode_record(const RawRecord& record, std::span<uint8_t> out) {
  const RecordLayout& l = record.layout;
  const int n = word_count(l.format);
  size_t pos = 0;
  for (int i = 0; i < n; ++i, pos += 2) encode_word(record.words[i], &out[pos], i == 0);
  if (l.button) out[pos++] = static_cast<uint8_t>(record.button & 0x7F);
  if (l.group) out[pos++] = static_cast<uint8_t>(record.address & 0x7F);
  return pos;
}

std::optional<RawRecord> decode_record(std::span<const uint8_t> bytes, const RecordLayout& layout) {
  if (bytes.size() != layout.size() || bytes.empty() || !(bytes[0] & 0x80)) return std::nullopt;
  for (size_t i = 1; i < bytes.size(); ++i)
    if (bytes[i] & 0x80) return std::nullopt;
  RawRecord r;
  r.layout = layout;
  const int n = word_count(layout.format);
  size_t pos = 0;
  for (int i = 0; i < n; ++i, pos += 2) r.words[i] = decode_word(bytes[pos], bytes[pos + 1]);
  if (layout.button) r.button = bytes[pos++];
  if (layout.group) r.address = bytes[pos++];
  return r;
}

// ---------------------------------------------------------------------------------------------

glm::dmat3 transmitter_from_sensor_from_angles(const glm::dvec3& angles_deg) {
  const glm::dvec3 a = angles_deg * (kPi / 180.0);
  const double ca = std::cos(a.x), sa = std::sin(a.x);
  const double ce = std::cos(a.y), se = std::sin(a.y);
  const double cr = std::cos(a.z), sr = std::sin(a.z);
  // Rz(A)·Ry(E)·Rx(R); glm constructor takes columns.
  return glm::dmat3(glm::dvec3(ca * ce, sa * ce, -se),
                    glm::dvec3(ca * se * sr - sa * cr, sa * se * sr + ca * cr, ce * sr),
                    glm::dvec3(ca * se * cr + sa * sr, sa * se * cr - ca * sr, ce * cr));
}

glm::dvec3 angles_from_transmitter_from_sensor(const glm::dmat3& r) {
  const double el = std::asin(std::clamp(-r[0][2], -1.0, 1.0));
  double az, roll;
  if (std::abs(r[0][2]) > 0.999999) {
    // Gimbal lock: azimuth and roll share one axis; put it all in azimuth.
    roll = 0;
    az = std::atan2(-r[1][0], r[1][1]);
  } else {
    az = std::atan2(r[0][1], r[0][0]);
    roll = std::atan2(r[1][2], r[2][2]);
  }
  return glm::dvec3(az, el, roll) * (180.0 / kPi);
}

Measurement measurement_from_pose(const glm::dvec3& position_in, const glm::dmat3& transmitter_from_sensor) {
  Measurement m;
  m.position_in = position_in;
  m.angles_deg = angles_from_transmitter_from_sensor(transmitter_from_sensor);
  m.matrix = glm::transpose(transmitter_from_sensor);
  m.quaternion = positive_w(glm::normalize(glm::quat_cast(m.matrix)));
  return m;
}

Measurement from_raw(const RawRecord& record, PositionRange range) {
  Measurement m;
  m.button = record.button;
  m.address = record.address;
  const Format f = record.layout.format;
  const auto& w = record.words;
  int o = 0;
  if (has_position(f)) {
    const double k = position_factor(range);
    m.position_in = glm::dvec3(w[0], w[1], w[2]) * k;
    o = 3;
  }
  switch (f) {
    case Format::angles:
    case Format::position_angles: {
      m.angles_deg = glm::dvec3(w[o], w[o + 1], w[o + 2]) * (180.0 / 32768.0);
      m.matrix = glm::transpose(transmitter_from_sensor_from_angles(m.angles_deg));
      m.quaternion = positive_w(glm::normalize(glm::quat_cast(m.matrix)));
      break;
    }
    case Format::matrix:
    case Format::position_matrix: {
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) m.matrix[c][r] = w[o + c * 3 + r] / 32768.0;
      m.quaternion = positive_w(glm::normalize(glm::quat_cast(m.matrix)));
      m.angles_deg = angles_from_transmitter_from_sensor(glm::transpose(m.matrix));
      break;
    }
    case Format::quaternion:
    case Format::position_quaternion: {
      glm::dquat q(w[o] / 32768.0, w[o + 1] / 32768.0, w[o + 2] / 32768.0, w[o + 3] / 32768.0);
      const double len = glm::length(q);
      m.quaternion = len > 1e-9 ? q / len : glm::dquat(1, 0, 0, 0);
      m.matrix = glm::mat3_cast(m.quaternion);
      m.angles_deg = angles_from_transmitter_from_sensor(glm::transpose(m.matrix));
      break;
    }
    case Format::position: break;
  }
  return m;
}

RawRecord to_raw(const Measurement& m, const RecordLayout& layout, PositionRange range) {
  RawRecord r;
  r.layout = layout;
  r.button = static_cast<uint8_t>(m.button & 0x7F);
  r.address = static_cast<uint8_t>(m.address & 0x7F);
  const Format f = layout.format;
  auto& w = r.words;
  int o = 0;
  if (has_position(f)) {
    const double k = 1.0 / position_factor(range);
    for (int i = 0; i < 3; ++i) w[i] = to_word(m.position_in[i] * k);
    o = 3;
  }
  switch (f) {
    case Format::angles:
    case Format::position_angles:
      for (int i = 0; i < 3; ++i) w[o + i] = to_word(m.angles_deg[i] * (32768.0 / 180.0));
      break;
    case Format::matrix:
    case Format::position_matrix:
      for (int c = 0; c < 3; ++c)
        for (int rr = 0; rr < 3; ++rr) w[o + c * 3 + rr] = to_word(m.matrix[c][rr] * 32768.0);
      break;
    case Format::quaternion:
    case Format::position_quaternion:
      w[o] = to_word(m.quaternion.w * 32768.0);
      w[o + 1] = to_word(m.quaternion.x * 32768.0);
      w[o + 2] = to_word(m.quaternion.y * 32768.0);
      w[o + 3] = to_word(m.quaternion.z * 32768.0);
      break;
    case Format::position: break;
  }
  return r;
}

glm::dmat3 mimic_from_flock() {
  // Columns: images of flock +X (forward), +Y (right), +Z (down).
  return glm::dmat3(glm::dvec3(0, 0, 1), glm::dvec3(-1, 0, 0), glm::dvec3(0, -1, 0));
}

SensorSample to_sample(const Measurement& m, const RecordLayout& layout, uint16_t default_sensor) {
  static const glm::dmat3 kC = mimic_from_flock();
  static const glm::dquat kQc = glm::quat_cast(kC);
  SensorSample s;
  s.sensor = layout.group ? m.address : default_sensor;
  if (has_position(layout.format)) s.position_m = glm::vec3(kC * m.position_in * kMetresPerInch);
  if (layout.format != Format::position) {
    // The wire quaternion is sensor_from_transmitter; conjugate to transmitter_from_sensor, then
    // change axes.
    const glm::dquat q = kQc * glm::conjugate(m.quaternion) * glm::conjugate(kQc);
    s.orientation = glm::quat(glm::normalize(positive_w(q)));
  }
  if (layout.button) {
    s.buttons = m.button;
    s.flags |= kSampleButton;
  }
  return s;
}

Measurement measurement_from_sample(const SensorSample& s) {
  static const glm::dmat3 kC = mimic_from_flock();
  const glm::dvec3 p_in = glm::transpose(kC) * glm::dvec3(s.position_m) / kMetresPerInch;
  const glm::dmat3 r_mimic = glm::mat3_cast(glm::normalize(glm::dquat(s.orientation)));
  const glm::dmat3 r_flock = glm::transpose(kC) * r_mimic * kC;
  Measurement m = measurement_from_pose(p_in, r_flock);
  m.address = static_cast<uint8_t>(s.sensor);
  m.button = static_cast<uint8_t>(s.buttons & 0x7F);
  return m;
}

// ---------------------------------------------------------------------------------------------

int change_size(uint8_t parameter) {
  switch (parameter) {
    case 3:
    case 4:
    case 6:
    case 7:
    case 22:
    case 32: return 2;
    case 5:
    case 12:
    case 13: return 14;
    case 8:
    case 9:
    case 11:
    case 14:
    case 17:
    case 18:
    case 20:
    case 35:
    case 50: return 1;
    case 23:
    case 24: return 6;
    case 33: return 5;
    default: return 0;
  }
}

int examine_size(uint8_t parameter) {
  switch (parameter) {
    case 0:
    case 1:
    case 2:
    case 3:
    case 4:
    case 6:
    case 7:
    case 16:
    case 22:
    case 25:
    case 26:
    case 27:
    case 32: return 2;
    case 5:
    case 12:
    case 13:
    case 36: return 14;
    case 8:
    case 9:
    case 10:
    case 11:
    case 14:
    case 17:
    case 18:
    case 19:
    case 20:
    case 21:
    case 35: return 1;
    case 15: return 10;
    case 23:
    case 24: return 6;
    case 33:
    case 50: return 5;
    default: return 0;
  }
}

std::array<uint8_t, 2> hemisphere_bytes(Hemisphere h) {
  switch (h) {
    case Hemisphere::forward: return {0x00, 0x00};
    case Hemisphere::aft: return {0x00, 0x01};
    case Hemisphere::upper: return {0x0C, 0x01};
    case Hemisphere::lower: return {0x0C, 0x00};
    case Hemisphere::left: return {0x06, 0x01};
    case Hemisphere::right: return {0x06, 0x00};
  }
  return {0, 0};
}

std::optional<Hemisphere> hemisphere_from_bytes(uint8_t axis, uint8_t sign) {
  for (Hemisphere h : {Hemisphere::forward, Hemisphere::aft, Hemisphere::upper, Hemisphere::lower, Hemisphere::left,
                       Hemisphere::right}) {
    const auto b = hemisphere_bytes(h);
    if (b[0] == axis && b[1] == sign) return h;
  }
  return std::nullopt;
}

const char* hemisphere_name(Hemisphere h) {
  switch (h) {
    case Hemisphere::forward: return "forward";
    case Hemisphere::aft: return "aft";
    case Hemisphere::upper: return "upper";
    case Hemisphere::lower: return "lower";
    case Hemisphere::left: return "left";
    case Hemisphere::right: return "right";
  }
  return "?";
}

std::optional<Hemisphere> parse_hemisphere(std::string_view name) {
  for (Hemisphere h : {Hemisphere::forward, Hemisphere::aft, Hemisphere::upper, Hemisphere::lower, Hemisphere::left,
                       Hemisphere::right})
    if (name == hemisphere_name(h)) return h;
  return std::nullopt;
}

bool in_hemisphere(Hemisphere h, const glm::dvec3& p) {
  switch (h) {
    case Hemisphere::forward: return p.x >= 0;
    case Hemisphere::aft: return p.x <= 0;
    case Hemisphere::upper: return p.z <= 0;
    case Hemisphere::lower: return p.z >= 0;
    case Hemisphere::left: return p.y <= 0;
    case Hemisphere::right: return p.y >= 0;
  }
  return true;
}

std::optional<uint8_t> report_rate_command(int every_nth) {
  switch (every_nth) {
    case 1: return uint8_t{'Q'};
    case 2: return uint8_t{'R'};
    case 8: return uint8_t{'S'};
    case 32: return uint8_t{'T'};
    default: return std::nullopt;
  }
}

int report_rate_divisor(uint8_t command) {
  switch (command) {
    case 'Q': return 1;
    case 'R': return 2;
    case 'S': return 8;
    case 'T': return 32;
    default: return 0;
  }
}

uint8_t fbb_prefix(int address) {
  if (address < 16) return static_cast<uint8_t>(0xF0 | (address & 0x0F));
  return static_cast<uint8_t>(0xE0 | ((address - 16) & 0x0F));
}

int fbb_prefix_address(uint8_t byte) {
  if ((byte & 0xF0) == 0xF0) return byte & 0x0F;
  if ((byte & 0xF0) == 0xE0) return 16 + (byte & 0x0F);
  return -1;
}

void append_command(std::vector<uint8_t>& out, uint8_t command, int address) {
  if (address >= 0) out.push_back(fbb_prefix(address));
  out.push_back(command);
}

void append_examine(std::vector<uint8_t>& out, uint8_t parameter, int address) {
  append_command(out, cmd::kExamine, address);
  out.push_back(parameter);
}

void append_change(std::vector<uint8_t>& out, uint8_t parameter, std::span<const uint8_t> data, int address) {
  append_command(out, cmd::kChange, address);
  out.push_back(parameter);
  out.insert(out.end(), data.begin(), data.end());
}

void append_change_word(std::vector<uint8_t>& out, uint8_t parameter, int16_t value, int address) {
  uint8_t b[2];
  put_le16(value, b);
  append_change(out, parameter, b, address);
}

void append_change_byte(std::vector<uint8_t>& out, uint8_t parameter, uint8_t value, int address) {
  append_change(out, parameter, std::span<const uint8_t>(&value, 1), address);
}

void append_format(std::vector<uint8_t>& out, Format f, int address) {
  append_command(out, format_command(f), address);
}

void append_hemisphere(std::vector<uint8_t>& out, Hemisphere h, int address) {
  append_command(out, cmd::kHemisphere, address);
  const auto b = hemisphere_bytes(h);
  out.insert(out.end(), b.begin(), b.end());
}

void append_group_mode(std::vector<uint8_t>& out, bool on) { append_change_byte(out, param::kGroupMode, on ? 1 : 0); }

void append_auto_config(std::vector<uint8_t>& out, int units) {
  append_change_byte(out, param::kAutoConfig, static_cast<uint8_t>(units));
}

void append_button_mode(std::vector<uint8_t>& out, bool on, int address) {
  append_command(out, cmd::kButtonMode, address);
  out.push_back(on ? 1 : 0);
}

// ---------------------------------------------------------------------------------------------

uint16_t encode_status(const BirdStatus& s) {
  uint16_t w = 0;
  if (s.master) w |= 1u << 15;
  if (s.initialized) w |= 1u << 14;
  if (s.error_pending) w |= 1u << 13;
  if (s.running) w |= 1u << 12;
  if (s.expanded_addressing) w |= 1u << 10;
  if (s.sleeping) w |= 1u << 5;
  if (s.format) w |= static_cast<uint16_t>(static_cast<int>(*s.format) << 1);
  if (s.streaming) w |= 1u;
  return w;
}

BirdStatus decode_status(uint16_t w) {
  BirdStatus s;
  s.master = w & (1u << 15);
  s.initialized = w & (1u << 14);
  s.error_pending = w & (1u << 13);
  s.running = w & (1u << 12);
  s.expanded_addressing = w & (1u << 10);
  s.sleeping = w & (1u << 5);
  s.format = format_from_code((w >> 1) & 0x0F);
  s.streaming = w & 1u;
  return s;
}

double measurement_rate_hz(int count, double crystal_mhz) {
  return 1000.0 / (4.0 * count * (8.0 / crystal_mhz) / 1000.0 + 0.3);
}

int measurement_rate_count(double rate_hz, double crystal_mhz) {
  return static_cast<int>(std::lround((crystal_mhz / 8.0) * 1000.0 * ((1000.0 / rate_hz - 0.3) / 4.0)));
}

std::string software_revision_text(uint16_t word) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%u.%02u", word & 0xFFu, (word >> 8) & 0xFFu);
  return buf;
}

const char* error_name(int code) {
  static const char* const kNames[] = {
      "no error",
      "system RAM failure",
      "non-volatile storage write failure",
      "PCB/system EEPROM configuration corrupt",
      "transmitter EEPROM configuration corrupt",
      "receiver EEPROM configuration corrupt",
      "invalid RS232 command",
      "not an FBB master",
      "no birds active",
      "bird not initialized",
      "FBB receive error (intra-bird bus)",
      "RS232 receive overrun or framing error",
      "FBB receive error (host bus)",
      "no FBB command response",
      "invalid FBB host command",
      "FBB run-time error",
      "invalid CPU speed",
      "slave no data",
      "illegal baud rate",
      "slave acknowledge error",
  };
  if (code >= 0 && code < static_cast<int>(std::size(kNames))) return kNames[code];
  switch (code) {
    case 28: return "CRT sync error";
    case 29: return "transmitter not active";
    case 30: return "ERC extended range transmitter not attached";
    case 31: return "CPU time overflow";
    case 32: return "receiver saturated";
    case 33: return "slave configuration error";
    case 34: return "ERC watchdog error";
    case 35: return "ERC over-temperature";
    default: break;
  }
  if (code >= 20 && code <= 27) return "CPU or firmware fault (call factory)";
  return "unknown error";
}

}  // namespace mimic::devices::flock
