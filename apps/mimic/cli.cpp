#include "cli.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "command.h"

namespace mimic::app::cli {
namespace {

// Wide enough for "--nats-model-ttl FLOAT in [0 - 86400]"-style names; longer ones put their
// description on the next line.
constexpr size_t kNameColumn = 30;

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// What the option's first validator says about its values ("INT in [0 - 3]"), or "". CLI11 2.1
// reads validators through a non-const accessor that throws when there are none; nothing changes.
std::string first_validator_description(const CLI::Option* opt) {
  try {
    return const_cast<CLI::Option*>(opt)->get_validator(0)->get_description();
  } catch (const CLI::OptionNotFound&) {
    return {};
  }
}

// CLI11's layout with the usage line first (what to type, then what it does) and Mimic's
// lower-case headings.
class Formatter : public CLI::Formatter {
 public:
  Formatter() {
    label("Usage", "usage");
    label("OPTIONS", "options");
    label("Positionals", "arguments");
    label("REQUIRED", "(required)");
    label("Excludes", "excludes");
    label("Needs", "needs");
    column_width(kNameColumn);
  }

  std::string make_usage(const CLI::App* app, std::string name) const override {
    std::string out = get_label("Usage") + ": " + name;
    const bool has_subcommands =
        !app->get_subcommands([](const CLI::App* s) { return !s->get_name().empty(); }).empty();
    if (has_subcommands) out += " <" + get_label("SUBCOMMAND") + ">";
    if (!app->get_options([](const CLI::Option* o) { return o->nonpositional(); }).empty())
      out += " [" + get_label("OPTIONS") + "]";
    for (const CLI::Option* o : app->get_options([](const CLI::Option* o) { return o->get_positional(); }))
      out += " " + make_option_usage(o);
    if (has_subcommands) out += "    (" + name + " <" + get_label("SUBCOMMAND") + "> --help for details)";
    return out + "\n";
  }

  std::string make_help(const CLI::App* app, std::string name, CLI::AppFormatMode mode) const override {
    if (mode == CLI::AppFormatMode::Sub) return make_expanded(app);
    std::string out = make_usage(app, name);
    if (!app->get_description().empty()) out += "\n" + make_description(app);
    out += make_positionals(app);
    out += make_groups(app, mode);
    out += make_subcommands(app, mode);
    if (!app->get_footer().empty()) out += "\n" + make_footer(app);
    return out;
  }

  // "--lod INT in [0 - 3] (default 0)": CLI11 writes the type, then its validators' description
  // after a colon ("INT:INT in [0 - 3]", "TEXT:{idle,walk}"); the description alone says more.
  std::string make_option_opts(const CLI::Option* opt) const override {
    std::string out;
    if (!opt->get_option_text().empty()) return " " + opt->get_option_text();
    if (opt->get_type_size() != 0) {
      std::string type = opt->get_type_name();
      const std::string checks = first_validator_description(opt);
      if (const auto at = checks.empty() ? std::string::npos : type.find(':' + checks); at != std::string::npos)
        type = type.substr(at + 1);
      if (!type.empty()) out += " " + type;
      if (opt->get_expected_max() == CLI::detail::expected_max_vector_size) out += " ...";
      const std::string& fallback = opt->get_default_str();
      if (!fallback.empty() && fallback != "[]") out += " (default " + fallback + ")";
      if (opt->get_required()) out += " " + get_label("REQUIRED");
    }
    for (const auto& [what, list] :
         {std::pair{"Needs", opt->get_needs()}, std::pair{"Excludes", opt->get_excludes()}}) {
      if (list.empty()) continue;
      out += " (" + get_label(what);
      for (const CLI::Option* other : list) out += " " + other->get_name();
      out += ")";
    }
    return out;
  }

  // One line per command, as `mimic --help` has always listed them.
  std::string make_subcommand(const CLI::App* sub) const override {
    std::stringstream out;
    CLI::detail::format_help(out, sub->get_name(), sub->get_description(), 18);
    return out.str();
  }
};

// CLI11's messages name the option; these say what Mimic's always said where CLI11's are vague.
// An unknown option is named first even when CLI11 found a missing or bad one before it reached
// the extras: a typo explains the rest.
std::string message_of(const CLI::ParseError& e, CLI::App& app) {
  if (!app.remaining().empty()) {
    std::string out;
    for (const std::string& word : app.remaining()) {
      if (!out.empty()) out += "; ";
      out += word.size() > 1 && word[0] == '-' ? "unknown option " + word : "unexpected argument '" + word + "'";
    }
    if (!out.empty()) return out;
  }
  // "--lod: 1 required INT:INT in [0 - 3] missing"
  const std::string what = e.what();
  // A validator that wrote a whole sentence about its option ("--lean-shift must be 0 to 8,
  // got 9") is printed as written, without CLI11's "--lean-shift: " before it.
  if (const size_t colon = what.find(": "); colon != std::string::npos && colon > 2 && what[0] == '-' &&
                                            what.compare(colon + 2, colon + 1, what.substr(0, colon) + " ") == 0)
    return what.substr(colon + 2);
  if (dynamic_cast<const CLI::ArgumentMismatch*>(&e) && what.find(" required ") != std::string::npos &&
      what.size() > 8 && what.compare(what.size() - 8, 8, " missing") == 0)
    return "option " + what.substr(0, what.find(':')) + " needs a value";
  return what;
}

}  // namespace

Parser::Parser(std::string path, std::string description)
    : path_(std::move(path)),
      app_(std::make_unique<CLI::App>(std::move(description), path_.empty() ? "mimic" : "mimic " + path_)) {
  app_->formatter(std::make_shared<Formatter>());
  app_->option_defaults()->group("options")->always_capture_default();
  app_->set_help_flag("-h,--help", "print this usage and exit");
  app_->get_help_ptr()->group("options");
}

std::optional<int> Parser::parse(const std::vector<std::string>& argv) {
  // CLI11 takes its words in reverse order (it pops from the back).
  std::vector<std::string> words(argv.rbegin(), argv.rend());
  try {
    app_->parse(words);
  } catch (const CLI::CallForHelp&) {
    std::fputs(help().c_str(), stdout);
    return 0;
  } catch (const CLI::CallForAllHelp&) {
    std::fputs(help().c_str(), stdout);
    return 0;
  } catch (const CLI::ParseError& e) {
    return usage_error(message_of(e, *app_));
  }
  return std::nullopt;
}

int Parser::usage_error(const std::string& message) const { return app::usage_error(path_.c_str(), message); }

int Parser::failure(const std::string& message) const { return app::failure(path_.c_str(), message); }

std::string Parser::help() const { return app_->help(); }

std::string OptionGroups::Group::get(const std::string& name) const {
  auto it = members.find(name);
  return it == members.end() ? std::string() : it->second;
}

OptionGroups::OptionGroups(CLI::App& app, const std::string& head, const std::string& head_description,
                           std::string implicit_head)
    : app_(app), implicit_head_(std::move(implicit_head)) {
  head_ = app.add_option(head, head_values_, head_description)->type_name("SPEC")->take_all();
  app.parse_complete_callback([this] { collect(); });
}

CLI::Option* OptionGroups::member(const std::string& name, const std::string& description) {
  CLI::Option* opt = app_.add_option(name, member_values_[name], description)->take_all();
  members_.push_back(opt);
  return opt;
}

void OptionGroups::collect() {
  groups_.clear();
  // Each occurrence is one entry in the parse order, its value the next of the option's results.
  std::map<const CLI::Option*, size_t> next;
  for (const CLI::Option* opt : app_.parse_order()) {
    const auto& values = opt->results();
    const size_t i = next[opt]++;
    if (i >= values.size()) continue;
    const std::string& value = values[i];
    if (opt == head_) {
      groups_.push_back({value, {}});
      continue;
    }
    if (std::find(members_.begin(), members_.end(), opt) == members_.end()) continue;
    const std::string name = opt->get_single_name();
    if (groups_.empty()) groups_.push_back({implicit_head_, {}, true});
    if (!groups_.back().members.emplace(name, value).second)
      throw CLI::ValidationError("two --" + name + " options for one " + head_->get_name());
  }
}

CLI::Validator finite_range(double min, double max, Bound min_bound, Bound max_bound) {
  const bool open = min_bound == Bound::exclusive, open_max = max_bound == Bound::exclusive;
  const std::string range =
      std::isinf(max) ? (open ? "> " : ">= ") + number_text(min)
                      : (open ? "(" : "[") + number_text(min) + " - " + number_text(max) + (open_max ? ")" : "]");
  return CLI::Validator(
      [min, max, open, open_max, range](std::string& input) -> std::string {
        double value = 0;
        const bool ok = CLI::detail::lexical_cast(input, value) && std::isfinite(value) &&
                        (open ? value > min : value >= min) && (open_max ? value < max : value <= max);
        return ok ? std::string() : "expects a finite number " + range + ", got '" + input + "'";
      },
      "FLOAT " + std::string(range[0] == '>' ? "" : "in ") + range);
}

}  // namespace mimic::app::cli
