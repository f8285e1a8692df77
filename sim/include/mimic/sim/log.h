// Recorded tracker sessions ("Mimic logs", *.mlog): a header describing the sensors and the
// source, then timestamped samples and, optionally, the raw bytes exchanged with a device, so a
// driver run can be replayed exactly. The byte layout is specified in docs/log-format.md.
//
// Every record is framed with its length and a CRC-32, so a truncated or corrupted log still
// yields every record before the damage and, resynchronising on the next well-framed record,
// every record after it; it says where the damage was and how many bytes it skipped.
// The decoder takes any bytes (it is a fuzz target) and never reads out of bounds.
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/rig/transform.h"
#include "mimic/core/result.h"
#include "mimic/devices/sample.h"

namespace mimic::sim {

inline constexpr uint32_t kLogVersion = 1;

struct LogSensor {
  uint16_t id = 0;                          // SensorSample::sensor
  std::string name;                         // e.g. "head"
  std::string segment;                      // skeleton joint it rides on; empty if unknown
  rig::RigidTransform segment_from_sensor;  // mounting offset, when known (identity otherwise)
};

struct LogHeader {
  std::vector<LogSensor> sensors;
  std::string source;                        // the source spec as given, e.g. "sim:walk?sensors=6"
  std::string device;                        // device information, e.g. "Flock of Birds, 4 birds, 115200 baud"
  std::string description;                   // free-form
  std::optional<uint64_t> seed;              // simulated sources
  double rate_hz = 0;                        // nominal sample rate per sensor; 0 if unknown
  rig::RigidTransform world_from_reference;  // tracker frame in Mimic's world, when known
  std::string calibration_json;              // a calibration in force while recording; empty if none
};

enum class RawDirection : uint8_t { from_device = 0, to_device = 1 };

struct RawChunk {
  double host_time_s = 0;
  RawDirection direction = RawDirection::from_device;
  uint64_t samples_before = 0;  // samples recorded before this chunk, for exact interleaving
  std::vector<uint8_t> bytes;
};

// One damaged stretch of a log: where, why, and how much was skipped to the next good record.
struct LogDamage {
  uint64_t byte_offset = 0;      // start of the first record that could not be read
  uint64_t record_index = 0;     // records read before it (the header is record 0)
  std::string reason;            // e.g. "CRC mismatch", "truncated record (needs 63 bytes, 20 left)"
  uint64_t bytes_skipped = 0;    // from byte_offset to where reading resumed (or the end)
  uint64_t resumed_at_byte = 0;  // the next good record, or the file size if none
  uint64_t samples_before = 0;   // samples read before the damage
  bool resumed = false;          // a good record followed
  // "damage at byte 1234 (record 17): CRC mismatch; 70 bytes skipped, reading resumed at byte 1304"
  std::string what() const;
};

struct LogContents {
  LogHeader header;
  std::vector<devices::SensorSample> samples;  // in file order
  std::vector<RawChunk> raw;
  bool complete = false;            // the end record was present (the writer closed the log)
  std::optional<LogDamage> damage;  // the first damage (or a missing end record), if any
  std::vector<LogDamage> damages;   // every damaged stretch, in file order
  uint64_t bytes_skipped = 0;       // over all damages
  uint64_t samples_lost = 0;        // end record's count minus samples read, when it survived
  uint64_t records = 0;             // records read, header included
};

// Decodes a whole log. Fails (parse_error, naming the offset) only when no valid header can be
// read: wrong magic, unsupported version, damaged or missing header record. After a good header,
// damage (bad CRC, bad length, cut-short record) is skipped by scanning for the next well-framed
// record with a good CRC; every good record before and after is kept, and each damaged stretch is
// reported in `damages` (the first also in `damage`).
Result<LogContents> decode_log(std::span<const uint8_t> bytes);
Result<LogContents> read_log(const std::string& path);

// Encoding, for writers and tests: the file prefix (magic, version, header record), one sample
// record, one raw-bytes record, the end record. Appends to `out`.
void encode_log_prefix(const LogHeader& header, std::vector<uint8_t>& out);
void encode_sample_record(const devices::SensorSample& sample, std::vector<uint8_t>& out);
void encode_raw_record(double host_time_s, RawDirection direction, std::span<const uint8_t> bytes,
                       std::vector<uint8_t>& out);
void encode_end_record(uint64_t sample_count, std::vector<uint8_t>& out);

struct LogWriterOptions {
  double flush_interval_s = 0.25;   // of sample host time; records older than this reach the file
  size_t buffer_bytes = 64 * 1024;  // flush earlier when this much is pending
  bool fsync_on_close = true;
};

// Writes a log. The header becomes visible atomically: the file is created as "<path>.part",
// the prefix written and synced, then renamed to `path`; after that records are appended and
// flushed regularly, so a crash or Ctrl-C leaves a valid log up to the last flush. append()
// does not allocate once the buffer is reserved (raw chunks larger than the buffer excepted).
class LogWriter {
 public:
  static Result<LogWriter> create(const std::string& path, const LogHeader& header,
                                  const LogWriterOptions& options = {});
  LogWriter(LogWriter&& other) noexcept;
  LogWriter& operator=(LogWriter&& other) noexcept;
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;
  ~LogWriter();  // close()s, ignoring errors

  Status append(const devices::SensorSample& sample);
  Status append_raw(double host_time_s, RawDirection direction, std::span<const uint8_t> bytes);
  Status flush();  // pending records to the file (write(2); no fsync)
  // Writes the end record, flushes, syncs and closes. Further calls do nothing.
  Status close();

  uint64_t samples_written() const { return samples_; }
  uint64_t bytes_written() const { return bytes_; }
  const std::string& path() const { return path_; }

 private:
  LogWriter() = default;
  Status flush_if_due(double host_time_s);

  int fd_ = -1;
  std::string path_;
  LogWriterOptions options_;
  std::vector<uint8_t> buffer_;
  uint64_t samples_ = 0;
  uint64_t bytes_ = 0;
  double last_flush_host_s_ = 0;
  bool have_flush_time_ = false;
};

// One CSV line per sample, "host_time_s,sensor,x_m,y_m,z_m,qw,qx,qy,qz" with a newline, no
// header; every number printed with 6 decimals (%.6f): microseconds, micrometres.
// Writes into `buf` (at least 160 bytes) and returns the length; never allocates.
size_t format_sample_csv(const devices::SensorSample& sample, std::span<char> buf);

}  // namespace mimic::sim
