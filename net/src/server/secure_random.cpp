#include "server/secure_random.h"

#include <sys/random.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace mimic::net {

void secure_random_bytes(std::span<uint8_t> out) noexcept {
  size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = ::getrandom(out.data() + done, out.size() - done, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      // No kernel randomness means no safe tokens: better to stop than to hand out guessable ones.
      std::abort();
    }
    done += static_cast<size_t>(n);
  }
}

uint64_t secure_random_u64() noexcept {
  uint8_t b[8];
  secure_random_bytes(b);
  uint64_t v = 0;
  std::memcpy(&v, b, sizeof v);
  return v;
}

}  // namespace mimic::net
