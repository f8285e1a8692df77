#include "status_line.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdarg>
#include <cstring>

namespace mimic::app {

StatusLine::StatusLine(std::FILE* out, int columns, Clock::duration log_period)
    : out_(out), terminal_(::isatty(::fileno(out)) != 0), columns_(columns), period_(log_period) {
  if (terminal_) period_ = std::chrono::milliseconds(500);
  next_ = Clock::now() + std::chrono::milliseconds(500);
}

int StatusLine::width() const {
  if (columns_ > 0) return columns_;
  winsize ws{};
  if (::ioctl(::fileno(out_), TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
  return 80;
}

void StatusLine::begin(Clock::time_point now) {
  count_ = 0;
  next_ = now + period_;
}

void StatusLine::add(int priority, const char* format, ...) {
  if (count_ >= fields_.size()) return;
  Field& f = fields_[count_++];
  va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(f.text.data(), f.text.size(), format, args);
  va_end(args);
  f.length = std::clamp(n, 0, int(f.text.size()) - 1);
  f.priority = priority;
}

void StatusLine::emit() {
  constexpr int kSeparator = 3;  // " | "
  std::array<bool, 12> shown{};
  int total = 0;
  for (size_t i = 0; i < count_; ++i) {
    shown[i] = true;
    total += fields_[i].length + (i > 0 ? kSeparator : 0);
  }
  // On a terminal, drop the least important fields (the last of them first) until the line fits
  // one row less a column (a cursor in the last column wraps on some terminals).
  const int limit = terminal_ ? width() - 1 : int(line_.size()) - 2;
  while (total > limit) {
    int drop = -1;
    for (size_t i = 0; i < count_; ++i)
      if (shown[i] && fields_[i].priority > 0 && (drop < 0 || fields_[i].priority >= fields_[size_t(drop)].priority))
        drop = int(i);
    if (drop < 0) break;
    shown[size_t(drop)] = false;
    total -= fields_[size_t(drop)].length + kSeparator;
  }
  int n = 0;
  auto put = [&](const char* s, int len) {
    len = std::min(len, int(line_.size()) - 2 - n);
    if (len > 0) std::memcpy(line_.data() + n, s, size_t(len)), n += len;
  };
  bool first = true;
  for (size_t i = 0; i < count_; ++i) {
    if (!shown[i]) continue;
    if (!first) put(" | ", kSeparator);
    put(fields_[i].text.data(), fields_[i].length);
    first = false;
  }
  if (terminal_) {
    n = std::min(n, std::max(limit, 0));
    // Spaces over what the previous, longer line left.
    const int pad = std::max(0, std::min(last_length_, limit) - n);
    std::fputc('\r', out_);
    std::fwrite(line_.data(), 1, size_t(n), out_);
    for (int i = 0; i < pad; ++i) std::fputc(' ', out_);
    last_length_ = n;
  } else {
    line_[size_t(n++)] = '\n';
    std::fwrite(line_.data(), 1, size_t(n), out_);
  }
  std::fflush(out_);
}

void StatusLine::finish() {
  if (terminal_ && last_length_ > 0) std::fputc('\n', out_);
  last_length_ = 0;
  std::fflush(out_);
}

}  // namespace mimic::app
