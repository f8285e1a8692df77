// The live status line of `mimic run`: fields added in the order they show, each with a
// priority. On a terminal the line is rewritten in place and fitted to its width (the least
// important fields go first, so it never wraps and scrolls); anywhere else (a log, a pipe) it is
// written as whole lines, one every `log_period`. No allocation after construction.
#pragma once

#include <array>
#include <chrono>
#include <cstdio>

namespace mimic::app {

class StatusLine {
 public:
  using Clock = std::chrono::steady_clock;
  // `columns` > 0 fixes the width (tests); 0 reads the terminal's, when `out` is one.
  explicit StatusLine(std::FILE* out, int columns = 0, Clock::duration log_period = std::chrono::seconds(5));

  bool on_terminal() const { return terminal_; }
  // True when the next line is due (twice a second on a terminal, every log period otherwise).
  bool due(Clock::time_point now) const { return now >= next_; }
  void begin(Clock::time_point now);
  // A field; priority 0 is never dropped, higher numbers are dropped first.
  void add(int priority, const char* format, ...) __attribute__((format(printf, 3, 4)));
  void emit();
  // Ends the line in place (before other output).
  void finish();

 private:
  struct Field {
    std::array<char, 112> text{};
    int length = 0, priority = 0;
  };
  int width() const;
  std::FILE* out_;
  bool terminal_ = false;
  int columns_ = 0;
  Clock::duration period_;
  Clock::time_point next_{};
  std::array<Field, 12> fields_{};
  size_t count_ = 0;
  int last_length_ = 0;
  std::array<char, 1024> line_{};
};

}  // namespace mimic::app
