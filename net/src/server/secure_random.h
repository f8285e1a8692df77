// Unpredictable numbers for the server: session tokens and UDP registration nonces come from the
// kernel's CSPRNG (getrandom), never from a seeded generator whose outputs reveal its state.
#pragma once

#include <cstdint>
#include <span>

namespace mimic::net {

// Fills `out` from getrandom(2); blocks only until the kernel's pool is first initialised.
void secure_random_bytes(std::span<uint8_t> out) noexcept;
uint64_t secure_random_u64() noexcept;

}  // namespace mimic::net
