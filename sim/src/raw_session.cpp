#include "mimic/sim/raw_session.h"

#include <algorithm>

namespace mimic::sim {

void RawByteRecorder::on_bytes(bool from_device, std::span<const uint8_t> bytes, double host_time_s) {
  if (bytes.empty()) return;
  std::lock_guard lock(mutex_);
  const RawDirection dir = from_device ? RawDirection::from_device : RawDirection::to_device;
  // Consecutive reads of one stream burst become one chunk, up to a record's worth.
  if (!pending_.empty() && pending_.back().direction == dir && pending_.back().bytes.size() + bytes.size() <= 4096 &&
      host_time_s - pending_.back().host_time_s < 0.002) {
    pending_.back().bytes.insert(pending_.back().bytes.end(), bytes.begin(), bytes.end());
    pending_.back().host_time_s = host_time_s;
  } else {
    pending_.push_back(RawChunk{host_time_s, dir, 0, std::vector<uint8_t>(bytes.begin(), bytes.end())});
  }
  bytes_ += bytes.size();
}

Result<size_t> RawByteRecorder::write_to(LogWriter& writer) {
  std::vector<RawChunk> chunks;
  {
    std::lock_guard lock(mutex_);
    chunks.swap(pending_);
  }
  for (const auto& c : chunks)
    if (auto st = writer.append_raw(c.host_time_s, c.direction, c.bytes); !st) return tl::unexpected(st.error());
  return chunks.size();
}

uint64_t RawByteRecorder::bytes_seen() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}

RecordedSerialDevice::RecordedSerialDevice(std::vector<RawChunk> chunks, unsigned baud)
    : SerialDevice(baud, 10), chunks_(std::move(chunks)) {
  uint64_t host_bytes = 0;
  double host_written = chunks_.empty() ? 0.0 : chunks_.front().host_time_s;
  first_recorded_s_ = host_written;
  for (const RawChunk& c : chunks_) {
    if (c.direction == RawDirection::to_device) {
      host_bytes += c.bytes.size();
      host_written = c.host_time_s;
      continue;
    }
    steps_.push_back(Step{c.host_time_s, host_bytes, host_written, &c});
    from_device_bytes_ += c.bytes.size();
  }
}

void RecordedSerialDevice::host_opened(double now_s) {
  // A session is played once, from the start, to the first host that opens the port.
  if (opened_s_ > 0) return;
  opened_s_ = now_s > 0 ? now_s : 1e-9;
  reached_s_ = now_s;
  reached_for_ = 0;
}

void RecordedSerialDevice::receive(std::span<const uint8_t> bytes, double now_s) {
  host_bytes_ += bytes.size();
  if (next_ < steps_.size() && host_bytes_ >= steps_[next_].host_bytes_before &&
      reached_for_ != steps_[next_].host_bytes_before) {
    reached_for_ = steps_[next_].host_bytes_before;
    reached_s_ = now_s;
  }
}

void RecordedSerialDevice::advance(double now_s) {
  if (opened_s_ <= 0) return;
  while (next_ < steps_.size()) {
    const Step& s = steps_[next_];
    if (host_bytes_ < s.host_bytes_before) return;  // the host has not asked for it yet
    if (reached_for_ != s.host_bytes_before) reached_for_ = s.host_bytes_before, reached_s_ = now_s;
    // As long after the host's last write as in the recording (the start for none).
    const double since = s.host_bytes_before == 0 ? s.recorded_s - first_recorded_s_ : s.recorded_s - s.host_written_s;
    if (now_s < reached_s_ + std::max(0.0, since)) return;
    send(s.chunk->bytes, now_s);
    ++next_;
  }
}

}  // namespace mimic::sim
