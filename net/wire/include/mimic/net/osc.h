// OSC 1.0 packets read in place: messages and (nested) bundles as views into the received bytes.
// VMC and OSC tracker senders (SlimeVR, VSeeFace, phone trackers) speak it over UDP. The reader
// is written here rather than taken from liblo because it runs in the realtime loop's read stage:
// it never allocates or throws, and it says why a packet was refused (counted per reason).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace mimic::net::osc {

enum class Error : uint8_t {
  ok = 0,
  truncated,        // a size, string or argument runs past the packet
  misaligned,       // a packet or element size that is not a multiple of 4
  bad_address,      // an address that does not start with '/' (or is not NUL-terminated)
  bad_type_tags,    // type tags missing their ',' or not NUL-terminated
  unknown_type,     // a type tag this reader does not know (its argument's size is unknown)
  too_deep,         // bundles nested past kMaxBundleDepth
  trailing_bytes,   // bytes after a message's last argument
  wrong_arguments,  // a known address with the wrong argument types or count (set by users)
  count_,
};
inline constexpr size_t kErrorCount = static_cast<size_t>(Error::count_);
const char* error_name(Error e) noexcept;

inline constexpr int kMaxBundleDepth = 4;

// One message: its address, its type tags (without the ','), and its arguments' bytes.
struct Message {
  std::string_view address;
  std::string_view tags;
  std::span<const uint8_t> args;
  uint64_t timetag = 1;  // of the innermost bundle (1: immediately, or a bare message)
};

// Reads a message's arguments in order. Each get fails (false) when the next tag is not of that
// kind or the bytes run out; numeric gets accept i, f, d and h (converted).
class Args {
 public:
  explicit Args(const Message& m) : tags_(m.tags), bytes_(m.args) {}
  bool get(float& out);
  bool get(int32_t& out);
  bool get(std::string_view& out);
  bool done() const { return next_ >= tags_.size(); }
  size_t count() const { return tags_.size(); }

 private:
  bool number(double& out);
  std::string_view tags_;
  std::span<const uint8_t> bytes_;
  size_t next_ = 0, at_ = 0;
};

// Calls on_message(const Message&) for each message of `packet` (a message or a bundle), in
// order. Returns the first error; the messages before it were delivered, the rest are not.
template <class F>
Error for_each_message(std::span<const uint8_t> packet, F&& on_message);

// ---- implementation details --------------------------------------------------------------------
namespace detail {
Error parse_message(std::span<const uint8_t> bytes, uint64_t timetag, Message& out);
bool is_bundle(std::span<const uint8_t> bytes);
uint32_t be32(const uint8_t* p);
uint64_t be64(const uint8_t* p);

template <class F>
Error walk(std::span<const uint8_t> bytes, uint64_t timetag, int depth, F& on_message) {
  if (bytes.size() % 4 != 0) return Error::misaligned;
  if (!is_bundle(bytes)) {
    Message m;
    if (const Error e = parse_message(bytes, timetag, m); e != Error::ok) return e;
    on_message(static_cast<const Message&>(m));
    return Error::ok;
  }
  if (depth >= kMaxBundleDepth) return Error::too_deep;
  if (bytes.size() < 16) return Error::truncated;
  const uint64_t tag = be64(bytes.data() + 8);
  size_t at = 16;
  while (at < bytes.size()) {
    if (bytes.size() - at < 4) return Error::truncated;
    const uint32_t n = be32(bytes.data() + at);
    at += 4;
    if (n > bytes.size() - at) return Error::truncated;
    if (n % 4 != 0 || n == 0) return Error::misaligned;
    if (const Error e = walk(bytes.subspan(at, n), tag, depth + 1, on_message); e != Error::ok) return e;
    at += n;
  }
  return Error::ok;
}
}  // namespace detail

template <class F>
Error for_each_message(std::span<const uint8_t> packet, F&& on_message) {
  if (packet.empty()) return Error::truncated;
  return detail::walk(packet, 1, 0, on_message);
}

}  // namespace mimic::net::osc
