#include "mimic/sim/log.h"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <bit>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <utility>

#include <nlohmann/json.hpp>

#include "mimic/core/crc32.h"
#include "mimic/core/file.h"

namespace mimic::sim {

static_assert(std::endian::native == std::endian::little, "the log codec assumes a little-endian host");

namespace {

constexpr std::array<uint8_t, 8> kMagic = {0x89, 'M', 'L', 'G', '\r', '\n', 0x1A, '\n'};
constexpr size_t kPrefixBytes = 12;          // magic + u32 version
constexpr size_t kFrameBytes = 9;            // u32 length + u8 type + ... + u32 crc
constexpr uint32_t kMaxPayload = 16u << 20;  // anything longer is a corrupted length
constexpr size_t kSamplePayload = 54;

enum RecordType : uint8_t { kHeader = 1, kSample = 2, kRaw = 3, kEnd = 4 };

template <class T>
void put(std::vector<uint8_t>& out, T v) {
  uint8_t b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.insert(out.end(), b, b + sizeof(T));
}

template <class T>
T get(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// Frames out[start..] (which holds the type byte and payload) as a record: the length goes in
// front, the CRC behind.
void begin_record(std::vector<uint8_t>& out, RecordType type, uint32_t payload_bytes) {
  put<uint32_t>(out, payload_bytes);
  out.push_back(type);
}
void end_record(std::vector<uint8_t>& out, size_t record_start) {
  const uint32_t c = crc32(std::span<const uint8_t>(out.data() + record_start, out.size() - record_start));
  put<uint32_t>(out, c);
}

nlohmann::json transform_json(const rig::RigidTransform& t) {
  return {{"translation_m", {t.translation.x, t.translation.y, t.translation.z}},
          {"rotation_wxyz", {t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z}}};
}

bool read_transform(const nlohmann::json& j, rig::RigidTransform& t) {
  if (!j.is_object()) return false;
  const auto& tr = j.value("translation_m", nlohmann::json());
  const auto& ro = j.value("rotation_wxyz", nlohmann::json());
  if (!tr.is_array() || tr.size() != 3 || !ro.is_array() || ro.size() != 4) return false;
  float v[7];
  for (int i = 0; i < 7; ++i) {
    const auto& x = i < 3 ? tr[static_cast<size_t>(i)] : ro[static_cast<size_t>(i - 3)];
    if (!x.is_number()) return false;
    const double d = x.get<double>();
    if (!(std::abs(d) <= 3.0e38)) return false;  // finite and representable as a float
    v[i] = static_cast<float>(d);
  }
  t.translation = {v[0], v[1], v[2]};
  t.rotation = glm::quat(v[3], v[4], v[5], v[6]);
  return true;
}

std::string header_json(const LogHeader& h) {
  nlohmann::json j;
  j["format"] = "mimic-log";
  j["source"] = h.source;
  j["device"] = h.device;
  j["description"] = h.description;
  if (h.seed) j["seed"] = *h.seed;
  j["rate_hz"] = h.rate_hz;
  j["world_from_reference"] = transform_json(h.world_from_reference);
  j["calibration"] = h.calibration_json;
  auto sensors = nlohmann::json::array();
  for (const auto& s : h.sensors)
    sensors.push_back({{"id", s.id},
                       {"name", s.name},
                       {"segment", s.segment},
                       {"segment_from_sensor", transform_json(s.segment_from_sensor)}});
  j["sensors"] = std::move(sensors);
  return j.dump();
}

// Empty string on success, else what is wrong.
std::string parse_header_json(std::string_view text, LogHeader& h) {
  const auto j = nlohmann::json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return "header is not valid JSON";
  if (!j.is_object()) return "header is not a mimic-log header";
  const auto format = j.find("format");  // (a non-string "format" must not throw)
  if (format == j.end() || !format->is_string() || format->get<std::string>() != "mimic-log")
    return "header is not a mimic-log header";
  auto str = [&](const char* key, std::string& out) {
    const auto it = j.find(key);
    if (it == j.end()) return true;
    if (!it->is_string()) return false;
    out = it->get<std::string>();
    return true;
  };
  if (!str("source", h.source) || !str("device", h.device) || !str("description", h.description) ||
      !str("calibration", h.calibration_json))
    return "header: source, device, description and calibration must be strings";
  if (const auto it = j.find("seed"); it != j.end()) {
    if (!it->is_number_unsigned()) return "header: seed must be an unsigned integer";
    h.seed = it->get<uint64_t>();
  }
  if (const auto it = j.find("rate_hz"); it != j.end()) {
    if (!it->is_number() || !std::isfinite(it->get<double>()) || it->get<double>() < 0)
      return "header: rate_hz must be a non-negative number";
    h.rate_hz = it->get<double>();
  }
  if (const auto it = j.find("world_from_reference"); it != j.end() && !read_transform(*it, h.world_from_reference))
    return "header: bad world_from_reference";
  const auto it = j.find("sensors");
  if (it == j.end() || !it->is_array()) return "header: sensors must be an array";
  for (const auto& s : *it) {
    if (!s.is_object()) return "header: a sensor is not an object";
    LogSensor ls;
    const auto id = s.find("id");
    if (id == s.end() || !id->is_number_unsigned() || id->get<uint64_t>() > 65535)
      return "header: sensor id must be an integer in [0, 65535]";
    ls.id = static_cast<uint16_t>(id->get<uint64_t>());
    const auto name = s.find("name");
    if (name == s.end() || !name->is_string()) return "header: sensor name must be a string";
    ls.name = name->get<std::string>();
    if (const auto seg = s.find("segment"); seg != s.end()) {
      if (!seg->is_string()) return "header: sensor segment must be a string";
      ls.segment = seg->get<std::string>();
    }
    if (const auto m = s.find("segment_from_sensor"); m != s.end() && !read_transform(*m, ls.segment_from_sensor))
      return "header: bad segment_from_sensor for sensor '" + ls.name + "'";
    h.sensors.push_back(std::move(ls));
  }
  return {};
}

}  // namespace

std::string LogDamage::what() const {
  std::string text =
      "damage at byte " + std::to_string(byte_offset) + " (record " + std::to_string(record_index) + "): " + reason;
  if (bytes_skipped > 0) text += "; " + std::to_string(bytes_skipped) + " bytes skipped";
  if (resumed)
    text += ", reading resumed at byte " + std::to_string(resumed_at_byte);
  else if (bytes_skipped > 0)
    text += " to the end";
  return text;
}

void encode_log_prefix(const LogHeader& header, std::vector<uint8_t>& out) {
  out.insert(out.end(), kMagic.begin(), kMagic.end());
  put<uint32_t>(out, kLogVersion);
  const std::string text = header_json(header);
  const size_t start = out.size();
  begin_record(out, kHeader, static_cast<uint32_t>(text.size()));
  out.insert(out.end(), text.begin(), text.end());
  end_record(out, start);
}

void encode_sample_record(const devices::SensorSample& s, std::vector<uint8_t>& out) {
  const size_t start = out.size();
  begin_record(out, kSample, kSamplePayload);
  put<uint16_t>(out, s.sensor);
  put<uint32_t>(out, s.flags);
  put<uint32_t>(out, s.buttons);
  put<double>(out, s.device_time_s);
  put<double>(out, s.host_time_s);
  put<float>(out, s.position_m.x);
  put<float>(out, s.position_m.y);
  put<float>(out, s.position_m.z);
  put<float>(out, s.orientation.w);
  put<float>(out, s.orientation.x);
  put<float>(out, s.orientation.y);
  put<float>(out, s.orientation.z);
  end_record(out, start);
}

void encode_raw_record(double host_time_s, RawDirection direction, std::span<const uint8_t> bytes,
                       std::vector<uint8_t>& out) {
  const size_t start = out.size();
  begin_record(out, kRaw, static_cast<uint32_t>(9 + bytes.size()));
  out.push_back(static_cast<uint8_t>(direction));
  put<double>(out, host_time_s);
  out.insert(out.end(), bytes.begin(), bytes.end());
  end_record(out, start);
}

void encode_end_record(uint64_t sample_count, std::vector<uint8_t>& out) {
  const size_t start = out.size();
  begin_record(out, kEnd, 8);
  put<uint64_t>(out, sample_count);
  end_record(out, start);
}

namespace {

// The records after a log's prefix, read in order; damage is noted in the contents and reading
// resumes at the next good record. Only a damaged header record is an error.
class LogDecoder {
 public:
  explicit LogDecoder(std::span<const uint8_t> bytes) : bytes_(bytes), n_(bytes.size()), d_(bytes.data()) {}
  Result<LogContents> run();

 private:
  enum class Frame { good, damaged, stop };  // stop: damaged, and nothing good follows

  bool frame_ok_at(size_t q) const;
  void note(LogDamage dmg);
  bool resync(std::string reason);
  void skip_record(std::string reason, size_t total);
  Result<Frame> check_frame(uint32_t& len);
  bool read_record(uint8_t type, const uint8_t* p, uint32_t len, size_t total);

  std::span<const uint8_t> bytes_;
  size_t n_;
  const uint8_t* d_;
  LogContents log_;
  size_t pos_ = kPrefixBytes;
  uint64_t index_ = 0;
};

// A well-framed record (length in range, whole, CRC good) of a type that can follow the header,
// at `q`: where reading resumes after damage. A false match needs a 32-bit CRC to agree by chance.
bool LogDecoder::frame_ok_at(size_t q) const {
  if (n_ - q < kFrameBytes) return false;
  const uint32_t len = get<uint32_t>(d_ + q);
  const uint8_t type = d_[q + 4];
  if (len > n_ - q - kFrameBytes) return false;
  if (type == kSample ? len != kSamplePayload
      : type == kEnd  ? len != 8
      : type == kRaw  ? (len < 9 || d_[q + 5] > 1)
                      : true)
    return false;
  return crc32(bytes_.subspan(q, 5 + len)) == get<uint32_t>(d_ + q + 5 + len);
}

void LogDecoder::note(LogDamage dmg) {
  if (!log_.damage) log_.damage = dmg;
  log_.damages.push_back(std::move(dmg));
}

// Damage at `pos_`: note it, then scan for the next good record; everything from there on is
// read as usual. False when nothing good follows (the rest of the file is skipped).
bool LogDecoder::resync(std::string reason) {
  LogDamage dmg{pos_, index_, std::move(reason)};
  const uint64_t samples_before = log_.samples.size();
  size_t q = pos_ + 1;
  while (q < n_ && !frame_ok_at(q)) ++q;
  dmg.bytes_skipped = (q < n_ ? q : n_) - pos_;
  dmg.resumed_at_byte = q < n_ ? q : n_;
  dmg.samples_before = samples_before;
  dmg.resumed = q < n_;
  log_.bytes_skipped += dmg.bytes_skipped;
  note(std::move(dmg));
  pos_ = q < n_ ? q : n_;
  return q < n_;
}

// A record whose frame and CRC are good but whose content is not: skipped whole.
void LogDecoder::skip_record(std::string reason, size_t total) {
  LogDamage dmg{pos_, index_, std::move(reason)};
  dmg.bytes_skipped = total;
  dmg.resumed_at_byte = pos_ + total;
  dmg.resumed = true;
  dmg.samples_before = log_.samples.size();
  log_.bytes_skipped += total;
  note(std::move(dmg));
}

// The frame of the record at `pos_`: length in range, whole, CRC good (its payload length in
// `len`); else the damage noted and reading resynced.
Result<LogDecoder::Frame> LogDecoder::check_frame(uint32_t& len) {
  auto damaged = [&](std::string reason) { return resync(std::move(reason)) ? Frame::damaged : Frame::stop; };
  if (n_ - pos_ < kFrameBytes) {
    if (index_ == 0) return fail(Errc::parse_error, "Mimic log header record truncated at byte 12");
    return damaged("truncated record frame (" + std::to_string(n_ - pos_) + " bytes left)");
  }
  len = get<uint32_t>(d_ + pos_);
  if (len > kMaxPayload) {
    if (index_ == 0) return fail(Errc::parse_error, "Mimic log header record has an implausible length at byte 12");
    return damaged("implausible record length " + std::to_string(len));
  }
  const size_t total = kFrameBytes + len;
  if (n_ - pos_ < total) {
    if (index_ == 0)
      return fail(Errc::parse_error, "Mimic log header record truncated at byte 12 (needs " + std::to_string(total) +
                                         " bytes, " + std::to_string(n_ - pos_) + " left)");
    return damaged("truncated record (needs " + std::to_string(total) + " bytes, " + std::to_string(n_ - pos_) +
                   " left)");
  }
  const uint32_t stored = get<uint32_t>(d_ + pos_ + 5 + len);
  if (crc32(bytes_.subspan(pos_, 5 + len)) != stored) {
    if (index_ == 0) return fail(Errc::parse_error, "Mimic log header record is corrupted (CRC mismatch at byte 12)");
    return damaged("CRC mismatch");
  }
  return Frame::good;
}

// A well-framed record after the header, payload `p` of `len` bytes. True when it is the end
// record that closes the log.
bool LogDecoder::read_record(uint8_t type, const uint8_t* p, uint32_t len, size_t total) {
  if (type == kHeader) {
    skip_record("a second header record", total);
  } else if (type == kSample) {
    if (len != kSamplePayload) {
      skip_record(
          "sample record of " + std::to_string(len) + " bytes (expected " + std::to_string(kSamplePayload) + ")",
          total);
    } else {
      devices::SensorSample s;
      s.sensor = get<uint16_t>(p);
      s.flags = get<uint32_t>(p + 2);
      s.buttons = get<uint32_t>(p + 6);
      s.device_time_s = get<double>(p + 10);
      s.host_time_s = get<double>(p + 18);
      s.position_m = {get<float>(p + 26), get<float>(p + 30), get<float>(p + 34)};
      s.orientation = glm::quat(get<float>(p + 38), get<float>(p + 42), get<float>(p + 46), get<float>(p + 50));
      log_.samples.push_back(s);
    }
  } else if (type == kRaw) {
    if (len < 9 || p[0] > 1) {
      skip_record("malformed raw-bytes record", total);
    } else {
      RawChunk c;
      c.direction = static_cast<RawDirection>(p[0]);
      c.host_time_s = get<double>(p + 1);
      c.samples_before = log_.samples.size();
      c.bytes.assign(p + 9, p + len);
      log_.raw.push_back(std::move(c));
    }
  } else if (type == kEnd) {
    const uint64_t count = len == 8 ? get<uint64_t>(p) : 0;
    if (len != 8) {
      skip_record("malformed end record", total);
    } else if (count != log_.samples.size() && log_.damages.empty()) {
      skip_record("end record counts " + std::to_string(count) + " samples but " + std::to_string(log_.samples.size()) +
                      " were read",
                  total);
      return true;
    } else {
      // After damage the writer's count says how many samples it cost.
      if (count > log_.samples.size()) log_.samples_lost = count - log_.samples.size();
      log_.complete = true;
      return true;
    }
  }
  // Unknown record types with a good CRC are skipped: later versions may add some.
  return false;
}

Result<LogContents> LogDecoder::run() {
  while (true) {
    if (pos_ == n_) {
      if (index_ == 0) return fail(Errc::parse_error, "Mimic log ends before its header record (byte 12)");
      LogDamage dmg{pos_, index_, "log ends without an end record (recording interrupted)"};
      dmg.resumed_at_byte = n_;
      dmg.samples_before = log_.samples.size();
      note(std::move(dmg));
      break;
    }
    uint32_t len = 0;
    const auto frame = check_frame(len);
    if (!frame) return tl::unexpected(frame.error());
    if (*frame == Frame::stop) break;
    if (*frame == Frame::damaged) continue;
    const size_t total = kFrameBytes + len;
    const uint8_t* p = d_ + pos_ + 5;
    const uint8_t type = d_[pos_ + 4];
    bool ended = false;
    if (index_ == 0) {
      if (type != kHeader) return fail(Errc::parse_error, "Mimic log: the first record (byte 12) is not a header");
      const std::string err = parse_header_json(std::string_view(reinterpret_cast<const char*>(p), len), log_.header);
      if (!err.empty()) return fail(Errc::parse_error, "Mimic log " + err + " (record at byte 12)");
    } else {
      ended = read_record(type, p, len, total);
    }
    ++index_;
    pos_ += total;
    if (ended) break;
  }
  // Bytes after the end record were not written by this log's writer (an appended file, a
  // copy gone wrong, tampering): never read as records, but never passed over in silence.
  if (pos_ < n_) {
    LogDamage dmg{pos_, index_, std::to_string(n_ - pos_) + " bytes after the end record (not read)"};
    dmg.bytes_skipped = n_ - pos_;
    dmg.resumed_at_byte = n_;
    dmg.samples_before = log_.samples.size();
    log_.bytes_skipped += dmg.bytes_skipped;
    note(std::move(dmg));
  }
  log_.records = index_;
  return std::move(log_);
}

}  // namespace

Result<LogContents> decode_log(std::span<const uint8_t> bytes) {
  const size_t n = bytes.size();
  const uint8_t* d = bytes.data();
  if (n == 0) return fail(Errc::parse_error, "not a Mimic log: the file is empty");
  if (n < kMagic.size() || std::memcmp(d, kMagic.data(), kMagic.size()) != 0)
    return fail(Errc::parse_error,
                n < kMagic.size() && std::memcmp(d, kMagic.data(), n) == 0
                    ? "not a complete Mimic log: it ends inside the magic number (" + std::to_string(n) + " bytes)"
                    : "not a Mimic log (bad magic number at byte 0)");
  if (n < kPrefixBytes) return fail(Errc::parse_error, "Mimic log ends inside the version field at byte 8");
  const uint32_t version = get<uint32_t>(d + 8);
  if (version != kLogVersion)
    return fail(Errc::unsupported, "Mimic log version " + std::to_string(version) +
                                       " at byte 8; this build reads version " + std::to_string(kLogVersion));
  return LogDecoder(bytes).run();
}

Result<LogContents> read_log(const std::string& path) {
  auto text = read_file(path);
  if (!text) return tl::unexpected(text.error());
  auto log = decode_log(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(text->data()), text->size()));
  if (!log) return fail(log.error().code, path + ": " + log.error().message);
  return log;
}

size_t format_sample_csv(const devices::SensorSample& s, std::span<char> buf) {
  const int n = std::snprintf(buf.data(), buf.size(), "%.6f,%u,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f\n", s.host_time_s,
                              static_cast<unsigned>(s.sensor), static_cast<double>(s.position_m.x),
                              static_cast<double>(s.position_m.y), static_cast<double>(s.position_m.z),
                              static_cast<double>(s.orientation.w), static_cast<double>(s.orientation.x),
                              static_cast<double>(s.orientation.y), static_cast<double>(s.orientation.z));
  if (n < 0) return 0;
  return std::min(static_cast<size_t>(n), buf.size() ? buf.size() - 1 : 0);
}

// ---- writer ----

namespace {

Status write_all(int fd, const uint8_t* p, size_t n, const std::string& path) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return fail(Errc::io_error, path + ": write failed: " + std::strerror(errno));
    }
    p += w;
    n -= static_cast<size_t>(w);
  }
  return {};
}

}  // namespace

Result<LogWriter> LogWriter::create(const std::string& path, const LogHeader& header, const LogWriterOptions& options) {
  if (options.buffer_bytes < 256) return fail(Errc::invalid_argument, "log writer buffer must hold at least 256 bytes");
  const std::string part = path + ".part";
  const int fd = ::open(part.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return fail(Errc::io_error, part + ": cannot create: " + std::strerror(errno));
  std::vector<uint8_t> prefix;
  encode_log_prefix(header, prefix);
  Status st = write_all(fd, prefix.data(), prefix.size(), part);
  if (st && ::fsync(fd) != 0) st = fail(Errc::io_error, part + ": fsync failed: " + std::strerror(errno));
  if (st && ::rename(part.c_str(), path.c_str()) != 0)
    st = fail(Errc::io_error, "cannot rename " + part + " to " + path + ": " + std::strerror(errno));
  if (!st) {
    ::close(fd);
    ::unlink(part.c_str());
    return tl::unexpected(st.error());
  }
  LogWriter w;
  w.fd_ = fd;
  w.path_ = path;
  w.options_ = options;
  w.buffer_.reserve(options.buffer_bytes + 128);
  w.bytes_ = prefix.size();
  return w;
}

LogWriter::LogWriter(LogWriter&& o) noexcept { *this = std::move(o); }

LogWriter& LogWriter::operator=(LogWriter&& o) noexcept {
  if (this != &o) {
    (void)close();
    fd_ = std::exchange(o.fd_, -1);
    path_ = std::move(o.path_);
    options_ = o.options_;
    buffer_ = std::move(o.buffer_);
    samples_ = o.samples_;
    bytes_ = o.bytes_;
    last_flush_host_s_ = o.last_flush_host_s_;
    have_flush_time_ = o.have_flush_time_;
  }
  return *this;
}

LogWriter::~LogWriter() { (void)close(); }

Status LogWriter::flush_if_due(double host_time_s) {
  if (!have_flush_time_) {
    last_flush_host_s_ = host_time_s;
    have_flush_time_ = true;
  }
  if (buffer_.size() >= options_.buffer_bytes || host_time_s - last_flush_host_s_ >= options_.flush_interval_s) {
    last_flush_host_s_ = host_time_s;
    return flush();
  }
  return {};
}

Status LogWriter::append(const devices::SensorSample& sample) {
  if (fd_ < 0) return fail(Errc::io_error, path_ + ": log is closed");
  if (buffer_.size() + kFrameBytes + kSamplePayload > buffer_.capacity())
    if (auto st = flush(); !st) return st;
  encode_sample_record(sample, buffer_);
  ++samples_;
  return flush_if_due(sample.host_time_s);
}

Status LogWriter::append_raw(double host_time_s, RawDirection direction, std::span<const uint8_t> bytes) {
  if (fd_ < 0) return fail(Errc::io_error, path_ + ": log is closed");
  if (bytes.size() > kMaxPayload - 9) return fail(Errc::out_of_range, "raw chunk too large for one record");
  if (buffer_.size() + kFrameBytes + 9 + bytes.size() > buffer_.capacity())
    if (auto st = flush(); !st) return st;
  encode_raw_record(host_time_s, direction, bytes, buffer_);
  return flush_if_due(host_time_s);
}

Status LogWriter::flush() {
  if (fd_ < 0) return {};
  Status st = write_all(fd_, buffer_.data(), buffer_.size(), path_);
  if (st) bytes_ += buffer_.size();
  buffer_.clear();
  return st;
}

Status LogWriter::close() {
  if (fd_ < 0) return {};
  encode_end_record(samples_, buffer_);
  Status st = flush();
  if (st && options_.fsync_on_close && ::fsync(fd_) != 0)
    st = fail(Errc::io_error, path_ + ": fsync failed: " + std::strerror(errno));
  if (::close(fd_) != 0 && st) st = fail(Errc::io_error, path_ + ": close failed: " + std::strerror(errno));
  fd_ = -1;
  return st;
}

}  // namespace mimic::sim
