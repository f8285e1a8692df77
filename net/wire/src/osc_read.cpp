#include <bit>
#include <cstring>

#include "mimic/net/osc.h"

namespace mimic::net::osc {

const char* error_name(Error e) noexcept {
  switch (e) {
    case Error::ok: return "ok";
    case Error::truncated: return "truncated";
    case Error::misaligned: return "misaligned";
    case Error::bad_address: return "bad_address";
    case Error::bad_type_tags: return "bad_type_tags";
    case Error::unknown_type: return "unknown_type";
    case Error::too_deep: return "too_deep";
    case Error::trailing_bytes: return "trailing_bytes";
    case Error::wrong_arguments: return "wrong_arguments";
    case Error::count_: break;
  }
  return "unknown";
}

namespace detail {

uint32_t be32(const uint8_t* p) {
  return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | uint32_t(p[3]);
}
uint64_t be64(const uint8_t* p) { return uint64_t(be32(p)) << 32 | be32(p + 4); }

bool is_bundle(std::span<const uint8_t> bytes) {
  return bytes.size() >= 8 && std::memcmp(bytes.data(), "#bundle", 8) == 0;
}

namespace {

// A NUL-terminated string at `at`, padded to 4 bytes: its text and the bytes it takes (0 when
// it does not end inside `bytes`).
size_t read_string(std::span<const uint8_t> bytes, size_t at, std::string_view& out) {
  if (at >= bytes.size()) return 0;
  const void* nul = std::memchr(bytes.data() + at, 0, bytes.size() - at);
  if (!nul) return 0;
  const size_t len = size_t(static_cast<const uint8_t*>(nul) - (bytes.data() + at));
  const size_t padded = (len + 4) & ~size_t(3);
  if (padded > bytes.size() - at) return 0;
  out = std::string_view(reinterpret_cast<const char*>(bytes.data() + at), len);
  return padded;
}

// Bytes the argument of type `tag` takes at `at` (0 for the types without data); false when it
// runs past the end or the type is unknown (`unknown` says which).
bool argument_bytes(char tag, std::span<const uint8_t> bytes, size_t at, size_t& size, bool& unknown) {
  unknown = false;
  const size_t left = bytes.size() - at;
  switch (tag) {
    case 'i':
    case 'f':
    case 'c':
    case 'r':
    case 'm': size = 4; return left >= 4;
    case 'h':
    case 'd':
    case 't': size = 8; return left >= 8;
    case 'T':
    case 'F':
    case 'N':
    case 'I': size = 0; return true;
    case 's':
    case 'S': {
      std::string_view s;
      size = read_string(bytes, at, s);
      return size > 0;
    }
    case 'b': {
      if (left < 4) return false;
      const uint64_t n = be32(bytes.data() + at);
      size = 4 + ((n + 3) & ~uint64_t(3));
      return size <= left;
    }
    default: unknown = true; return false;
  }
}

}  // namespace

Error parse_message(std::span<const uint8_t> bytes, uint64_t timetag, Message& out) {
  size_t at = 0;
  const size_t address_bytes = read_string(bytes, at, out.address);
  if (address_bytes == 0) return bytes.empty() || bytes[0] != '/' ? Error::bad_address : Error::truncated;
  if (out.address.empty() || out.address[0] != '/') return Error::bad_address;
  at += address_bytes;
  std::string_view tags;
  const size_t tag_bytes = read_string(bytes, at, tags);
  if (tag_bytes == 0 || tags.empty() || tags[0] != ',')
    return at >= bytes.size() ? Error::truncated : Error::bad_type_tags;
  at += tag_bytes;
  out.tags = tags.substr(1);
  const size_t args_start = at;
  for (char t : out.tags) {
    size_t n = 0;
    bool unknown = false;
    if (!argument_bytes(t, bytes, at, n, unknown)) return unknown ? Error::unknown_type : Error::truncated;
    at += n;
  }
  if (at != bytes.size()) return Error::trailing_bytes;
  out.args = bytes.subspan(args_start, at - args_start);
  out.timetag = timetag;
  return Error::ok;
}

}  // namespace detail

bool Args::number(double& out) {
  if (next_ >= tags_.size()) return false;
  const char t = tags_[next_];
  const size_t need = (t == 'd' || t == 'h') ? 8 : 4;
  if ((t != 'i' && t != 'f' && t != 'd' && t != 'h') || bytes_.size() - at_ < need) return false;
  const uint8_t* p = bytes_.data() + at_;
  switch (t) {
    case 'i': out = double(static_cast<int32_t>(detail::be32(p))); break;
    case 'f': out = double(std::bit_cast<float>(detail::be32(p))); break;
    case 'd': out = std::bit_cast<double>(detail::be64(p)); break;
    default: out = double(static_cast<int64_t>(detail::be64(p))); break;
  }
  at_ += need;
  next_++;
  return true;
}

bool Args::get(float& out) {
  if (next_ < tags_.size() && tags_[next_] == 'f' && bytes_.size() - at_ >= 4) {
    out = std::bit_cast<float>(detail::be32(bytes_.data() + at_));
    at_ += 4;
    next_++;
    return true;
  }
  double d = 0;
  if (!number(d)) return false;
  out = static_cast<float>(d);
  return true;
}

bool Args::get(int32_t& out) {
  if (next_ >= tags_.size() || tags_[next_] != 'i' || bytes_.size() - at_ < 4) return false;
  out = static_cast<int32_t>(detail::be32(bytes_.data() + at_));
  at_ += 4;
  next_++;
  return true;
}

bool Args::get(std::string_view& out) {
  if (next_ >= tags_.size() || (tags_[next_] != 's' && tags_[next_] != 'S')) return false;
  const void* nul = std::memchr(bytes_.data() + at_, 0, bytes_.size() - at_);
  if (!nul) return false;
  const size_t len = size_t(static_cast<const uint8_t*>(nul) - (bytes_.data() + at_));
  out = std::string_view(reinterpret_cast<const char*>(bytes_.data() + at_), len);
  at_ += (len + 4) & ~size_t(3);
  next_++;
  return true;
}

}  // namespace mimic::net::osc
