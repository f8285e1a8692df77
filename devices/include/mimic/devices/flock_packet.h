// Ascension Flock of Birds wire codec: pure functions from bytes to measurements and back, and
// the host command bytes. No I/O; the driver (flock.h) and the virtual Flock (sim/) share it.
// Protocol reference: docs/devices-flock.md and device-protocols.md §1.
//
// Frames. The Flock reports in its transmitter frame: right-handed, +X forward, +Y right,
// +Z down, inches and degrees. Mimic's reference frame for a Flock is the same transmitter
// with Mimic's axis names (+Y up, +Z forward, +X left), so a transmitter mounted level and facing
// the performer's forward gives world-aligned samples:
//   mimic = C · flock,  C columns: flock +X -> mimic +Z, flock +Y -> mimic −X, flock +Z -> mimic −Y.
// C is a proper rotation (det +1), so no handedness flip happens; sensor orientations are
// conjugated by C (R_mimic = C · R_flock · Cᵀ) so an unrotated sensor is the identity in both.
//
// Orientation on the wire. The angles are azimuth A (about Z), elevation E (about Y) and roll R
// (about X): transmitter_from_sensor = Rz(A) · Ry(E) · Rx(R). The MATRIX record is its
// transpose, M = sensor_from_transmitter (M11 = cosE·cosA, M12 = cosE·sinA, M13 = −sinE ...),
// and the QUATERNION record is the quaternion of that same M (q0 scalar first, q0 ≥ 0 when the
// simulator sends it). The driver conjugates it back to transmitter_from_sensor.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/devices/sample.h"

namespace mimic::devices::flock {

// ---------------------------------------------------------------------------------------------
// Record formats and layouts

// Values are the output-format codes of the status word (bits 4–1); code 6 is factory test.
enum class Format : uint8_t {
  position = 1,
  angles = 2,
  matrix = 3,
  position_angles = 4,
  position_matrix = 5,
  quaternion = 7,
  position_quaternion = 8,
};

inline constexpr std::array<Format, 7> kAllFormats = {
    Format::position,           Format::angles,          Format::matrix,
    Format::position_angles,    Format::position_matrix, Format::quaternion,
    Format::position_quaternion};

// Number of 16-bit words a record of this format carries (3, 3, 9, 6, 12, 4, 7).
int word_count(Format f);
bool has_position(Format f);
// The command byte that selects the format: 'V' − 1 + code ('V'…'Z', '\', ']').
uint8_t format_command(Format f);
// Inverse of format_command and of the status-word code; nullopt for anything else.
std::optional<Format> format_from_command(uint8_t command);
std::optional<Format> format_from_code(int code);
// "position", "angles", "matrix", "position_angles", "position_matrix", "quaternion",
// "position_quaternion"; parse also accepts the short forms "pos", "quat", "pos_quat", ...
const char* format_name(Format f);
std::optional<Format> parse_format(std::string_view name);

// What a record looks like on the wire: the words, then the optional button byte (BUTTON MODE 1),
// then the optional group address byte (GROUP MODE on).
struct RecordLayout {
  Format format = Format::position_quaternion;
  bool button = false;
  bool group = false;

  size_t size() const { return static_cast<size_t>(word_count(format)) * 2 + (button ? 1 : 0) + (group ? 1 : 0); }
  bool operator==(const RecordLayout&) const = default;
};

inline constexpr size_t kMaxRecordSize = 12 * 2 + 2;  // POS/MATRIX + button + group

// ---------------------------------------------------------------------------------------------
// Words

// A 16-bit value goes out as two bytes, LS first: (v >> 2) & 7Fh (plus 80h when it opens a
// record), then (v >> 9) & 7Fh. Bits 1–0 of v are lost (14-bit resolution).
inline void encode_word(int16_t v, uint8_t* out, bool first_of_record) {
  const auto u = static_cast<uint16_t>(v);
  out[0] = static_cast<uint8_t>(((u >> 2) & 0x7F) | (first_of_record ? 0x80 : 0x00));
  out[1] = static_cast<uint8_t>((u >> 9) & 0x7F);
}
inline int16_t decode_word(uint8_t b0, uint8_t b1) {
  return static_cast<int16_t>(static_cast<uint16_t>(((b1 & 0x7F) << 9) | ((b0 & 0x7F) << 2)));
}
// The value a word has after a trip over the wire (low two bits cleared).
inline int16_t quantize_word(int16_t v) { return static_cast<int16_t>(static_cast<uint16_t>(v) & 0xFFFC); }

// Parameter data (CHANGE/EXAMINE) is plain binary, LSB first, no phasing bits.
inline void put_le16(int16_t v, uint8_t* out) {
  const auto u = static_cast<uint16_t>(v);
  out[0] = static_cast<uint8_t>(u & 0xFF);
  out[1] = static_cast<uint8_t>(u >> 8);
}
inline int16_t get_le16(const uint8_t* in) { return static_cast<int16_t>(static_cast<uint16_t>(in[0] | (in[1] << 8))); }

// ---------------------------------------------------------------------------------------------
// Raw records (device units) and measurements (physical units, Flock frame)

struct RawRecord {
  RecordLayout layout;
  std::array<int16_t, 12> words{};  // word_count(layout.format) used, in wire order
  uint8_t button = 0;               // valid when layout.button
  uint8_t address = 0;              // valid when layout.group
};

// Writes the record (layout.size() bytes) into `out`; returns the byte count. out.size() must
// be at least layout.size().
size_t encode_record(const RawRecord& record, std::span<uint8_t> out);
// Decodes exactly layout.size() bytes. Fails (nullopt) when the phasing is wrong: the first byte
// lacks bit 7 or any later byte has it.
std::optional<RawRecord> decode_record(std::span<const uint8_t> bytes, const RecordLayout& layout);

// Position full scale in inches: 36 (standard transmitter), 72 (parameter 3 = 1), 144 (ERT).
enum class PositionRange : uint8_t { in36 = 36, in72 = 72, in144 = 144 };
inline double full_scale_in(PositionRange r) { return static_cast<double>(static_cast<int>(r)); }

// A measurement in the Flock's own frame and units. Which fields are meaningful depends on the
// format; `from_raw` fills every orientation field it can derive, `to_raw` reads the ones the
// format carries.
struct Measurement {
  glm::dvec3 position_in{0.0};        // +X forward, +Y right, +Z down
  glm::dvec3 angles_deg{0.0};         // azimuth (Z), elevation (Y), roll (X)
  glm::dmat3 matrix{1.0};             // M = sensor_from_transmitter; glm is column-major: matrix[col][row]
  glm::dquat quaternion{1, 0, 0, 0};  // the quaternion of M (w = q0)
  uint8_t button = 0;
  uint8_t address = 0;
};

Measurement from_raw(const RawRecord& record, PositionRange range);
RawRecord to_raw(const Measurement& m, const RecordLayout& layout, PositionRange range);

// Orientation helpers (radians inside, degrees in Measurement).
glm::dmat3 transmitter_from_sensor_from_angles(const glm::dvec3& angles_deg);
glm::dvec3 angles_from_transmitter_from_sensor(const glm::dmat3& r);  // degrees; E in [−90, 90]

// Fills every field of a Measurement from a pose in the Flock frame (inches,
// transmitter_from_sensor); used by the simulator and the tests.
Measurement measurement_from_pose(const glm::dvec3& position_in, const glm::dmat3& transmitter_from_sensor);

// Flock frame <-> Mimic frame (see the header comment).
glm::dmat3 mimic_from_flock();
// A SensorSample (metres, reference_from_sensor, Mimic axes) from a decoded record. Orientation
// comes from the quaternion, matrix or angles, whichever the format carries; formats without
// orientation leave it identity, formats without position leave it zero. `sensor` is the group
// address when the layout has one, else `default_sensor`; the button byte sets kSampleButton.
SensorSample to_sample(const Measurement& m, const RecordLayout& layout, uint16_t default_sensor = 1);
// The inverse: a Measurement in the Flock frame for a sample in Mimic's frame.
Measurement measurement_from_sample(const SensorSample& s);

// ---------------------------------------------------------------------------------------------
// Incremental stream decoder

// Splits a byte stream into records of a fixed layout. Synchronises on the phasing bit: bytes
// before a phased byte are garbage, and a phased byte inside a record tears it (the partial
// record is dropped and a new one starts at that byte), so the good record that follows a
// fault is never lost. In group mode a record whose address byte is not in `valid_addresses`
// is dropped too. Each dropped run of bytes counts one resync.
class StreamDecoder {
 public:
  StreamDecoder() = default;
  explicit StreamDecoder(const RecordLayout& layout) : layout_(layout) {}

  void set_layout(const RecordLayout& layout) {
    layout_ = layout;
    reset();
  }
  const RecordLayout& layout() const { return layout_; }
  // Bit i set = address i accepted in the group byte; all accepted by default.
  void set_valid_addresses(uint32_t mask) { valid_addresses_ = mask; }
  void reset() {
    fill_ = 0;
    in_garbage_ = false;
  }

  // Feeds bytes; calls on_record(const RawRecord&, size_t end) for each complete record, where
  // `end` is the offset in `bytes` just past its last byte. Never allocates.
  template <class F>
  void feed(std::span<const uint8_t> bytes, F&& on_record) {
    const size_t size = layout_.size();
    for (size_t i = 0; i < bytes.size(); ++i) {
      const uint8_t b = bytes[i];
      if (b & 0x80) {
        if (fill_ > 0) drop_partial();  // torn record: a new one starts here
        in_garbage_ = false;
        buf_[0] = b;
        fill_ = 1;
      } else if (fill_ == 0) {
        if (!in_garbage_) {  // one resync per run of unphased bytes
          in_garbage_ = true;
          ++resyncs_;
        }
        ++discarded_bytes_;
        continue;
      } else {
        buf_[fill_++] = b;
      }
      if (fill_ == size) {
        fill_ = 0;
        auto rec = decode_record(std::span<const uint8_t>(buf_.data(), size), layout_);
        if (rec && (!layout_.group || address_ok(rec->address))) {
          ++records_;
          on_record(*rec, i + 1);
        } else {
          ++resyncs_;
          discarded_bytes_ += size;
        }
      }
    }
  }

  uint64_t records() const { return records_; }
  uint64_t resyncs() const { return resyncs_; }
  uint64_t discarded_bytes() const { return discarded_bytes_; }
  size_t pending_bytes() const { return fill_; }

 private:
  bool address_ok(uint8_t a) const { return a < 32 && ((valid_addresses_ >> a) & 1u); }
  void drop_partial() {
    ++resyncs_;
    discarded_bytes_ += fill_;
    fill_ = 0;
  }

  RecordLayout layout_{};
  uint32_t valid_addresses_ = 0xFFFFFFFFu;
  std::array<uint8_t, kMaxRecordSize> buf_{};
  size_t fill_ = 0;
  bool in_garbage_ = false;
  uint64_t records_ = 0, resyncs_ = 0, discarded_bytes_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Commands (host -> bird)

namespace cmd {
inline constexpr uint8_t kStream = '@';
inline constexpr uint8_t kPoint = 'B';
inline constexpr uint8_t kStreamStop = '?';
inline constexpr uint8_t kRun = 'F';
inline constexpr uint8_t kSleep = 'G';
inline constexpr uint8_t kExamine = 'O';
inline constexpr uint8_t kChange = 'P';
inline constexpr uint8_t kHemisphere = 'L';
inline constexpr uint8_t kReferenceFrame1 = 'H';
inline constexpr uint8_t kAngleAlign1 = 'J';
inline constexpr uint8_t kReferenceFrame2 = 'r';
inline constexpr uint8_t kAngleAlign2 = 'q';
inline constexpr uint8_t kButtonMode = 'M';
inline constexpr uint8_t kButtonRead = 'N';
inline constexpr uint8_t kSync = 'A';
inline constexpr uint8_t kFbbReset = '/';
inline constexpr uint8_t kNextTransmitter = '0';
inline constexpr uint8_t kXon = 0x11;
inline constexpr uint8_t kXoff = 0x13;
}  // namespace cmd

// CHANGE/EXAMINE parameter numbers used by Mimic (device-protocols.md §1.6).
namespace param {
inline constexpr uint8_t kStatus = 0;
inline constexpr uint8_t kSoftwareRevision = 1;
inline constexpr uint8_t kCrystalSpeed = 2;
inline constexpr uint8_t kPositionScaling = 3;
inline constexpr uint8_t kFilter = 4;
inline constexpr uint8_t kMeasurementRateCount = 6;
inline constexpr uint8_t kMeasurementRate = 7;
inline constexpr uint8_t kErrorCode = 10;
inline constexpr uint8_t kSystemModel = 15;
inline constexpr uint8_t kExpandedErrorCode = 16;
inline constexpr uint8_t kAddressingMode = 19;
inline constexpr uint8_t kFbbAddress = 21;
inline constexpr uint8_t kHemisphere = 22;
inline constexpr uint8_t kGroupMode = 35;
inline constexpr uint8_t kFlockStatus = 36;
inline constexpr uint8_t kAutoConfig = 50;
}  // namespace param

// Data bytes CHANGE VALUE takes after the parameter number; 0 for read-only or unknown ones.
int change_size(uint8_t parameter);
// Bytes EXAMINE VALUE returns (normal addressing); 0 for unknown parameters.
int examine_size(uint8_t parameter);

enum class Hemisphere : uint8_t { forward, aft, upper, lower, left, right };
std::array<uint8_t, 2> hemisphere_bytes(Hemisphere h);  // 'L' / parameter 22 axis, sign
std::optional<Hemisphere> hemisphere_from_bytes(uint8_t axis, uint8_t sign);
const char* hemisphere_name(Hemisphere h);
std::optional<Hemisphere> parse_hemisphere(std::string_view name);
// True when a position (Flock frame) lies in the hemisphere (boundary included).
bool in_hemisphere(Hemisphere h, const glm::dvec3& position);

// Report rate: every 1st, 2nd, 8th or 32nd measurement ('Q', 'R', 'S', 'T'); nullopt otherwise.
std::optional<uint8_t> report_rate_command(int every_nth);
int report_rate_divisor(uint8_t command);  // 0 for a byte that is not Q/R/S/T

// RS232 TO FBB prefix for the next single command (normal/expanded addressing: one byte).
uint8_t fbb_prefix(int address);  // F0h|addr for 0–15, E0h|(addr−16) for 16–30
// The address a prefix byte names, or −1 when `byte` is not a one-byte prefix.
int fbb_prefix_address(uint8_t byte);

// Command encoders append to `out`. `address` < 0 sends to the master (no prefix).
void append_command(std::vector<uint8_t>& out, uint8_t command, int address = -1);
void append_examine(std::vector<uint8_t>& out, uint8_t parameter, int address = -1);
void append_change(std::vector<uint8_t>& out, uint8_t parameter, std::span<const uint8_t> data, int address = -1);
void append_change_word(std::vector<uint8_t>& out, uint8_t parameter, int16_t value, int address = -1);
void append_change_byte(std::vector<uint8_t>& out, uint8_t parameter, uint8_t value, int address = -1);
void append_format(std::vector<uint8_t>& out, Format f, int address = -1);
void append_hemisphere(std::vector<uint8_t>& out, Hemisphere h, int address = -1);
void append_group_mode(std::vector<uint8_t>& out, bool on);     // P 35 on, to the master
void append_auto_config(std::vector<uint8_t>& out, int units);  // P 50 N, to the master
void append_button_mode(std::vector<uint8_t>& out, bool on, int address = -1);

// ---------------------------------------------------------------------------------------------
// Status, rates, EXAMINE replies

struct BirdStatus {
  bool master = false, initialized = false, error_pending = false, running = false;
  bool expanded_addressing = false, sleeping = false, streaming = false;
  std::optional<Format> format;
};
uint16_t encode_status(const BirdStatus& s);
BirdStatus decode_status(uint16_t word);

// Flock system status byte (parameter 36).
inline constexpr uint8_t kUnitAccessible = 0x80, kUnitRunning = 0x40, kUnitSensor = 0x20, kUnitErc = 0x10,
                         kUnitTransmitter = 0x01;

// Measurement rate from the transmitter time count C (parameter 6) and the crystal in MHz:
// rate_Hz = 1000 / (4·C·(8/f)/1000 + 0.3), and back.
double measurement_rate_hz(int count, double crystal_mhz);
int measurement_rate_count(double rate_hz, double crystal_mhz);

// Software revision word (parameter 1): LS byte integer part, MS byte fraction (3.67 → 03 43).
std::string software_revision_text(uint16_t word);

// Error code names (parameter 10); "unknown error" for codes it does not know.
const char* error_name(int code);

}  // namespace mimic::devices::flock
