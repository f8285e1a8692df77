// BVH text -> BvhClip. The header is small and tokenised line by line; the motion section is
// parsed straight from the text with from_chars (it is nearly all of the bytes).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <optional>
#include <string>
#include <unordered_set>

#include "mimic/rig/bvh.h"
#include "mimic/core/file.h"

namespace mimic::rig {

namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

std::string quoted(std::string_view s) {
  constexpr size_t kMax = 40;
  std::string out = "'";
  for (char c : s.substr(0, kMax)) out += (static_cast<unsigned char>(c) < 32 || c == 127) ? '?' : c;
  if (s.size() > kMax) out += "...";
  return out + "'";
}

enum class NumberStatus { ok, not_a_number, non_finite };

// A whole token as a number. from_chars rejects a leading '+', which some writers emit.
NumberStatus parse_number(std::string_view tok, double& out) {
  if (!tok.empty() && tok[0] == '+') tok.remove_prefix(1);
  if (tok.empty()) return NumberStatus::not_a_number;
  const auto [end, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  if (ec == std::errc::result_out_of_range) return NumberStatus::non_finite;
  if (ec != std::errc() || end != tok.data() + tok.size()) return NumberStatus::not_a_number;
  if (!std::isfinite(out)) return NumberStatus::non_finite;
  return NumberStatus::ok;
}

std::optional<BvhChannel> channel_from_name(std::string_view s) {
  static constexpr std::pair<const char*, BvhChannel> kNames[] = {
      {"Xposition", BvhChannel::x_position}, {"Yposition", BvhChannel::y_position},
      {"Zposition", BvhChannel::z_position}, {"Xrotation", BvhChannel::x_rotation},
      {"Yrotation", BvhChannel::y_rotation}, {"Zrotation", BvhChannel::z_rotation}};
  for (const auto& [n, c] : kNames)
    if (iequals(s, n)) return c;
  return std::nullopt;
}

struct Token {
  std::string_view text;
  int line;
};

class Parser {
 public:
  Parser(std::string_view text, std::string_view source, const BvhParseOptions& options)
      : text_(text), source_(source) {
    clip_.source_name = std::string(source);
    clip_.metres_per_unit = options.metres_per_unit;
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") text_.remove_prefix(3);  // UTF-8 byte order mark
  }

  Result<BvhClip> run() {
    if (!(clip_.metres_per_unit > 0) || !std::isfinite(clip_.metres_per_unit))
      return fail(Errc::invalid_argument, source_ + ": metres_per_unit must be a positive number");
    if (auto s = tokenize_header(); !s) return tl::unexpected(s.error());
    if (auto s = parse_hierarchy(); !s) return tl::unexpected(s.error());
    if (auto s = parse_motion(); !s) return tl::unexpected(s.error());
    return std::move(clip_);
  }

 private:
  tl::unexpected<Error> error(int line, const std::string& what) const {
    return fail(Errc::parse_error, source_ + ":" + std::to_string(line) + ": " + what);
  }

  // Next line of text (without the line break); false at the end.
  bool next_line(std::string_view& out) {
    if (pos_ >= text_.size()) return false;
    const size_t nl = text_.find('\n', pos_);
    const size_t end = nl == std::string_view::npos ? text_.size() : nl;
    out = text_.substr(pos_, end - pos_);
    pos_ = nl == std::string_view::npos ? text_.size() : nl + 1;
    ++line_;
    return true;
  }

  // Tokens of every line up to the one that starts with MOTION (left for parse_motion).
  Status tokenize_header() {
    std::string_view line;
    while (true) {
      const size_t line_start = pos_;
      if (!next_line(line)) break;
      size_t i = 0;
      bool first = true;
      while (i < line.size()) {
        while (i < line.size() && is_space(line[i])) ++i;
        if (i >= line.size()) break;
        size_t j = i;
        while (j < line.size() && !is_space(line[j])) ++j;
        std::string_view tok = line.substr(i, j - i);
        if (first && iequals(tok, "MOTION")) {
          motion_line_ = line_;
          motion_rest_ = line.substr(j);
          (void)line_start;
          return {};
        }
        first = false;
        // Braces glued to a word ("Hips{") are split off so either layout reads the same.
        while (!tok.empty()) {
          size_t b = tok.find_first_of("{}");
          if (b == std::string_view::npos) {
            tokens_.push_back({tok, line_});
            break;
          }
          if (b > 0) tokens_.push_back({tok.substr(0, b), line_});
          tokens_.push_back({tok.substr(b, 1), line_});
          tok.remove_prefix(b + 1);
        }
        i = j;
      }
    }
    return {};
  }

  bool at_end() const { return cursor_ >= tokens_.size(); }
  int last_line() const { return tokens_.empty() ? std::max(line_, 1) : tokens_.back().line; }
  int current_line() const { return at_end() ? last_line() : tokens_[cursor_].line; }

  // Numbers that must follow a keyword on its own line.
  Status read_numbers(const Token& keyword, int count, double* out) {
    for (int k = 0; k < count; ++k) {
      if (at_end() || tokens_[cursor_].line != keyword.line)
        return error(keyword.line, "expected " + std::to_string(count) + " numbers after " + std::string(keyword.text) +
                                       ", got " + std::to_string(k));
      const Token& t = tokens_[cursor_++];
      const NumberStatus s = parse_number(t.text, out[k]);
      if (s == NumberStatus::non_finite)
        return error(t.line, "non-finite number " + quoted(t.text) + " after " + std::string(keyword.text));
      if (s != NumberStatus::ok)
        return error(t.line, "expected " + std::to_string(count) + " numbers after " + std::string(keyword.text) +
                                 ", got " + quoted(t.text));
    }
    if (!at_end() && tokens_[cursor_].line == keyword.line && tokens_[cursor_].text != "{" &&
        tokens_[cursor_].text != "}")
      return error(keyword.line, "unexpected " + quoted(tokens_[cursor_].text) + " after " + std::to_string(count) +
                                     " numbers of " + std::string(keyword.text));
    return {};
  }

  Status expect_open_brace(const std::string& what, int line) {
    if (at_end()) return error(last_line(), "expected '{' after " + what + ", got end of file");
    const Token& t = tokens_[cursor_];
    if (t.text != "{") return error(t.line, "expected '{' after " + what + ", got " + quoted(t.text));
    (void)line;
    ++cursor_;
    return {};
  }

  Status parse_channels(const Token& keyword, BvhJoint& joint) {
    double n = 0;
    if (at_end() || tokens_[cursor_].line != keyword.line)
      return error(keyword.line, "expected a channel count after CHANNELS");
    const Token& count_tok = tokens_[cursor_++];
    if (parse_number(count_tok.text, n) != NumberStatus::ok || n < 0 || n > 6 || n != std::floor(n))
      return error(count_tok.line, "expected a channel count 0..6 after CHANNELS, got " + quoted(count_tok.text));
    const int count = static_cast<int>(n);
    joint.channels.clear();
    for (int k = 0; k < count; ++k) {
      if (at_end() || tokens_[cursor_].line != keyword.line)
        return error(keyword.line,
                     "CHANNELS " + std::to_string(count) + " lists only " + std::to_string(k) + " channel names");
      const Token& t = tokens_[cursor_++];
      const auto c = channel_from_name(t.text);
      if (!c) return error(t.line, "unknown channel " + quoted(t.text) + " (expected X/Y/Zposition or X/Y/Zrotation)");
      if (std::find(joint.channels.begin(), joint.channels.end(), *c) != joint.channels.end())
        return error(t.line, "channel " + quoted(t.text) + " listed twice for joint '" + joint.name + "'");
      joint.channels.push_back(*c);
    }
    if (!at_end() && tokens_[cursor_].line == keyword.line && tokens_[cursor_].text != "{" &&
        tokens_[cursor_].text != "}")
      return error(keyword.line,
                   "CHANNELS " + std::to_string(count) + " is followed by extra " + quoted(tokens_[cursor_].text));
    return {};
  }

  // Joint name: the rest of the keyword's line up to a brace (names may contain spaces).
  Result<std::string> read_name(const Token& keyword) {
    std::string name;
    while (!at_end() && tokens_[cursor_].line == keyword.line && tokens_[cursor_].text != "{" &&
           tokens_[cursor_].text != "}") {
      if (!name.empty()) name += ' ';
      name += tokens_[cursor_++].text;
    }
    if (name.empty()) return error(keyword.line, "expected a joint name after " + std::string(keyword.text));
    return name;
  }

  struct Open {
    int joint;  // -1 for an End Site
    int open_line;
    bool has_offset = false;
    bool has_channels = false;
  };

  Status parse_hierarchy() {
    if (at_end()) {
      if (motion_line_ > 0) return error(motion_line_, "expected HIERARCHY before MOTION");
      return error(std::max(line_, 1), "expected HIERARCHY, got end of file");
    }
    if (!iequals(tokens_[cursor_].text, "HIERARCHY"))
      return error(tokens_[cursor_].line, "expected HIERARCHY, got " + quoted(tokens_[cursor_].text));
    ++cursor_;
    if (at_end()) return error(last_line(), "expected ROOT after HIERARCHY");
    if (!iequals(tokens_[cursor_].text, "ROOT"))
      return error(tokens_[cursor_].line, "expected ROOT, got " + quoted(tokens_[cursor_].text));

    std::vector<Open> stack;
    std::unordered_set<std::string> names;
    bool root_done = false;
    while (!at_end()) {
      const Token t = tokens_[cursor_++];
      if (root_done)
        return error(t.line, "unexpected " + quoted(t.text) + " after the root joint closed" +
                                 (iequals(t.text, "ROOT") ? " (only one ROOT is supported)" : ""));
      const bool is_root = iequals(t.text, "ROOT");
      if (is_root || iequals(t.text, "JOINT")) {
        if (is_root != stack.empty())
          return error(t.line, is_root ? "ROOT inside another joint" : "JOINT outside the ROOT");
        if (!stack.empty() && stack.back().joint < 0) return error(t.line, "JOINT inside an End Site");
        auto name = read_name(t);
        if (!name) return tl::unexpected(name.error());
        if (!names.insert(*name).second) return error(t.line, "duplicate joint name " + quoted(*name));
        if (auto s = expect_open_brace(std::string(t.text) + " " + *name, t.line); !s) return s;
        BvhJoint j;
        j.name = std::move(*name);
        j.parent = stack.empty() ? -1 : stack.back().joint;
        clip_.joints.push_back(std::move(j));
        stack.push_back({static_cast<int>(clip_.joints.size()) - 1, t.line});
        continue;
      }
      if (iequals(t.text, "End")) {
        if (stack.empty()) return error(t.line, "End Site outside the ROOT");
        if (stack.back().joint < 0) return error(t.line, "End Site inside an End Site");
        if (at_end() || !iequals(tokens_[cursor_].text, "Site")) return error(t.line, "expected 'Site' after 'End'");
        ++cursor_;
        if (auto s = expect_open_brace("End Site", t.line); !s) return s;
        stack.push_back({-1, t.line});
        clip_.joints[stack[stack.size() - 2].joint].end_sites.emplace_back(0.0);
        continue;
      }
      if (stack.empty()) return error(t.line, "unexpected " + quoted(t.text) + " outside the ROOT");
      Open& open = stack.back();
      const std::string owner = open.joint < 0 ? "End Site" : "joint '" + clip_.joints[open.joint].name + "'";
      if (iequals(t.text, "OFFSET")) {
        if (open.has_offset) return error(t.line, "second OFFSET in " + owner);
        double v[3];
        if (auto s = read_numbers(t, 3, v); !s) return s;
        const glm::dvec3 offset(v[0], v[1], v[2]);
        if (open.joint < 0)
          clip_.joints[stack[stack.size() - 2].joint].end_sites.back() = offset;
        else
          clip_.joints[open.joint].offset = offset;
        open.has_offset = true;
      } else if (iequals(t.text, "CHANNELS")) {
        if (open.joint < 0) return error(t.line, "CHANNELS in an End Site");
        if (open.has_channels) return error(t.line, "second CHANNELS in " + owner);
        if (auto s = parse_channels(t, clip_.joints[open.joint]); !s) return s;
        open.has_channels = true;
      } else if (t.text == "}") {
        if (!open.has_offset)
          return error(t.line, owner + " (opened at line " + std::to_string(open.open_line) + ") has no OFFSET");
        if (open.joint >= 0 && !open.has_channels)
          return error(t.line, owner + " (opened at line " + std::to_string(open.open_line) + ") has no CHANNELS");
        stack.pop_back();
        if (stack.empty()) root_done = true;
      } else if (t.text == "{") {
        return error(t.line, "unbalanced braces: unexpected '{' in " + owner);
      } else {
        return error(t.line, "unexpected " + quoted(t.text) + " in " + owner);
      }
    }
    if (!stack.empty()) {
      const Open& open = stack.back();
      const std::string owner = open.joint < 0 ? "End Site" : "joint '" + clip_.joints[open.joint].name + "'";
      const int where = motion_line_ > 0 ? motion_line_ : last_line();
      return error(where, "unbalanced braces: " + owner + " opened at line " + std::to_string(open.open_line) +
                              " is not closed");
    }
    if (clip_.joints.empty()) return error(last_line(), "no ROOT joint");
    int column = 0;
    for (auto& j : clip_.joints) {
      j.first_channel = column;
      column += static_cast<int>(j.channels.size());
    }
    clip_.channel_count = column;
    return {};
  }

  // "Frames: N" / "Frame Time: T": the label, an optional space, a colon, one number.
  Status read_labelled_number(std::string_view label, double& out, int& line_out) {
    std::string_view line;
    while (next_line(line)) {
      size_t i = 0;
      while (i < line.size() && is_space(line[i])) ++i;
      if (i == line.size()) continue;  // blank line
      line_out = line_;
      std::string_view rest = line.substr(i);
      // Compare the label with any run of whitespace matching one space.
      size_t k = 0;
      for (char c : label) {
        if (c == ' ') {
          if (k >= rest.size() || !is_space(rest[k])) goto mismatch;
          while (k < rest.size() && is_space(rest[k])) ++k;
        } else {
          if (k >= rest.size() || !iequals(std::string_view(&rest[k], 1), std::string_view(&c, 1))) goto mismatch;
          ++k;
        }
      }
      while (k < rest.size() && is_space(rest[k])) ++k;
      if (k >= rest.size() || rest[k] != ':') goto mismatch;
      ++k;
      {
        std::string_view value = rest.substr(k);
        while (!value.empty() && is_space(value.front())) value.remove_prefix(1);
        while (!value.empty() && is_space(value.back())) value.remove_suffix(1);
        const NumberStatus s = parse_number(value, out);
        if (s == NumberStatus::non_finite)
          return error(line_, "non-finite number " + quoted(value) + " after " + std::string(label) + ":");
        if (s != NumberStatus::ok)
          return error(line_, "expected a number after '" + std::string(label) + ":', got " + quoted(value));
        return {};
      }
    mismatch:
      return error(line_, "expected '" + std::string(label) + ": <number>', got " + quoted(rest));
    }
    return error(std::max(line_, 1), "expected '" + std::string(label) + ":', got end of file");
  }

  Status parse_motion() {
    if (motion_line_ == 0) return error(std::max(line_, 1), "expected MOTION after the hierarchy, got end of file");
    {
      std::string_view rest = motion_rest_;
      while (!rest.empty() && is_space(rest.front())) rest.remove_prefix(1);
      if (!rest.empty()) return error(motion_line_, "unexpected " + quoted(rest) + " after MOTION");
    }
    double frames = 0, frame_time = 0;
    int frames_line = 0, time_line = 0;
    if (auto s = read_labelled_number("Frames", frames, frames_line); !s) return s;
    if (frames < 0 || frames != std::floor(frames) || frames > 1e9)
      return error(frames_line, "frame count must be a whole number >= 0, got " + std::to_string(frames));
    if (auto s = read_labelled_number("Frame Time", frame_time, time_line); !s) return s;
    if (!(frame_time > 0)) return error(time_line, "Frame Time must be positive");
    const long declared = static_cast<long>(frames);
    clip_.frame_time_s = frame_time;
    const size_t cols = static_cast<size_t>(clip_.channel_count);
    // Never trust the declared count for the allocation: a frame needs at least 2 bytes a value.
    clip_.values.reserve(std::min(static_cast<size_t>(declared) * cols, (text_.size() - pos_) / 2 + 1));

    long read = 0;
    int last_frame_line = time_line;
    std::string_view line;
    while (next_line(line)) {
      const char* p = line.data();
      const char* end = p + line.size();
      while (p < end && is_space(*p)) ++p;
      if (p == end) continue;  // blank lines (and trailing ones) carry nothing
      if (read >= declared)
        return error(line_, "more frame lines than 'Frames: " + std::to_string(declared) + "' (line " +
                                std::to_string(frames_line) + ") declares");
      size_t n = 0;
      while (p < end) {
        const char* q = p;
        while (q < end && !is_space(*q)) ++q;
        std::string_view tok(p, static_cast<size_t>(q - p));
        double v = 0;
        const NumberStatus s = parse_number(tok, v);
        if (s == NumberStatus::non_finite)
          return error(line_, "frame " + std::to_string(read) + ": non-finite value " + quoted(tok) + " in column " +
                                  std::to_string(n + 1));
        if (s != NumberStatus::ok)
          return error(line_, "frame " + std::to_string(read) + ": expected a number in column " +
                                  std::to_string(n + 1) + ", got " + quoted(tok));
        if (n >= cols)
          return error(line_, "frame " + std::to_string(read) + " has too many values: more than the " +
                                  std::to_string(cols) + " channels of the hierarchy");
        clip_.values.push_back(v);
        ++n;
        p = q;
        while (p < end && is_space(*p)) ++p;
      }
      if (n < cols)
        return error(line_, "frame " + std::to_string(read) + " has too few values: " + std::to_string(n) + " of the " +
                                std::to_string(cols) + " channels of the hierarchy");
      ++read;
      last_frame_line = line_;
    }
    if (read != declared)
      return error(frames_line, "'Frames: " + std::to_string(declared) + "' but the file has " + std::to_string(read) +
                                    " frame lines (last at line " + std::to_string(last_frame_line) + ")");
    clip_.frame_count = static_cast<int>(read);
    return {};
  }

  std::string_view text_;
  std::string source_;
  size_t pos_ = 0;
  int line_ = 0;
  std::vector<Token> tokens_;
  size_t cursor_ = 0;
  int motion_line_ = 0;
  std::string_view motion_rest_;
  BvhClip clip_;
};

}  // namespace

const char* bvh_channel_name(BvhChannel c) {
  switch (c) {
    case BvhChannel::x_position: return "Xposition";
    case BvhChannel::y_position: return "Yposition";
    case BvhChannel::z_position: return "Zposition";
    case BvhChannel::x_rotation: return "Xrotation";
    case BvhChannel::y_rotation: return "Yrotation";
    case BvhChannel::z_rotation: return "Zrotation";
  }
  return "?";
}

int BvhClip::find_joint(std::string_view name) const {
  for (size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return static_cast<int>(j);
  return -1;
}

Result<BvhClip> parse_bvh(std::string_view text, std::string_view source_name, const BvhParseOptions& options) {
  return Parser(text, source_name, options).run();
}

Result<BvhClip> load_bvh(const std::string& path, const BvhParseOptions& options) {
  auto text = read_file(path);
  if (!text) return tl::unexpected(text.error());
  return parse_bvh(*text, path, options);
}

}  // namespace mimic::rig
