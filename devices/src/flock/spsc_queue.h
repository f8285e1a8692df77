// Bounded single-producer single-consumer queue: the reader thread pushes, the realtime loop
// pops. Fixed storage allocated up front; push and pop never block or allocate.
#pragma once

#include <atomic>
#include <cstddef>
#include <span>
#include <vector>

namespace mimic::devices {

template <class T>
class SpscQueue {
 public:
  explicit SpscQueue(size_t capacity) {
    size_t n = 2;
    while (n < capacity + 1) n <<= 1;
    buf_.resize(n);
    mask_ = n - 1;
  }

  // Producer side. False (and the item is dropped) when the consumer is too far behind.
  bool push(const T& item) {
    const size_t head = head_.load(std::memory_order_relaxed);
    const size_t next = (head + 1) & mask_;
    if (next == tail_.load(std::memory_order_acquire)) return false;
    buf_[head] = item;
    head_.store(next, std::memory_order_release);
    return true;
  }

  // Consumer side: moves up to out.size() items, oldest first.
  size_t pop(std::span<T> out) {
    size_t tail = tail_.load(std::memory_order_relaxed);
    const size_t head = head_.load(std::memory_order_acquire);
    size_t n = 0;
    while (n < out.size() && tail != head) {
      out[n++] = buf_[tail];
      tail = (tail + 1) & mask_;
    }
    tail_.store(tail, std::memory_order_release);
    return n;
  }

 private:
  std::vector<T> buf_;
  size_t mask_ = 0;
  alignas(64) std::atomic<size_t> head_{0};
  alignas(64) std::atomic<size_t> tail_{0};
};

}  // namespace mimic::devices
