#include "common/flags/flag_precheck.h"

#include <string>
#include <string_view>
#include <vector>

#include "absl/flags/commandlineflag.h"
#include "absl/flags/reflection.h"
#include "absl/strings/str_cat.h"
#include "common/flags/flag_names.h"

namespace impostor {
namespace {

// The flag as the user would type it (UnderscoreFlagNames rewrote it).
std::string Dashed(std::string_view name) { return "--" + DashedFlagName(std::string(name)); }

absl::CommandLineFlag* Find(std::string_view name) {
  return absl::FindCommandLineFlag(absl::string_view(name.data(), name.size()));
}

// Abseil's flag-file flags, and its usage flags, which it does not register
// as flags but recognises by name while parsing.
bool LeftToAbseil(std::string_view name) {
  for (const char* own : {"flagfile", "fromenv", "tryfromenv", "undefok", "help", "helpfull", "helpshort",
                          "helppackage", "helpon", "helpmatch", "version", "only_check_args"}) {
    if (name == own) return true;
  }
  return false;
}

// The names --undefok=a,b lets through unknown (Abseil's rule: "--a" and
// "--noa" both).
std::vector<std::string> UndefinedOk(int argc, char** argv) {
  std::vector<std::string> names;
  for (int i = 1; i < argc; ++i) {
    std::string_view arg = argv[i];
    if (arg == "--") break;
    for (std::string_view prefix : {"--undefok=", "-undefok="}) {
      if (arg.substr(0, prefix.size()) != prefix) continue;
      for (std::string_view rest = arg.substr(prefix.size()); !rest.empty();) {
        const size_t comma = rest.find(',');
        names.emplace_back(rest.substr(0, comma));
        rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
      }
    }
  }
  return names;
}

}  // namespace

absl::Status PrecheckFlags(int argc, char** argv) {
  const std::vector<std::string> undefined_ok = UndefinedOk(argc, argv);
  auto may_be_undefined = [&](std::string_view name) {
    for (const std::string& ok : undefined_ok) {
      if (name == ok || (name.substr(0, 2) == "no" && name.substr(2) == ok)) return true;
    }
    return false;
  };
  for (int i = 1; i < argc; ++i) {
    std::string_view arg = argv[i];
    if (arg == "--") break;
    if (arg.size() < 2 || arg[0] != '-') continue;  // positional (Abseil's rule too)
    arg.remove_prefix(arg[1] == '-' ? 2 : 1);
    const size_t eq = arg.find('=');
    const std::string_view name = arg.substr(0, eq);
    const bool has_value = eq != std::string_view::npos;
    const std::string_view inline_value = has_value ? arg.substr(eq + 1) : std::string_view();
    if (name.empty()) return absl::InvalidArgumentError(absl::StrCat("\"", argv[i], "\" is not a flag"));
    if (LeftToAbseil(name)) continue;
    absl::CommandLineFlag* flag = Find(name);
    if (flag == nullptr && name.substr(0, 2) == "no") {
      absl::CommandLineFlag* positive = Find(name.substr(2));
      if (positive != nullptr && positive->IsOfType<bool>()) {
        if (has_value) {
          return absl::InvalidArgumentError(
              absl::StrCat(Dashed(name), " takes no value (", Dashed(name.substr(2)), "=true|false does)"));
        }
        continue;
      }
      if (positive != nullptr) {
        return absl::InvalidArgumentError(
            absl::StrCat(Dashed(name), ": ", Dashed(name.substr(2)), " is not a switch and has no negative form"));
      }
    }
    if (flag == nullptr && may_be_undefined(name)) continue;
    if (flag == nullptr) {
      // A single-dash name keeps its dashes (only "--" names are rewritten),
      // so show it as typed.
      const std::string typed = argv[i][1] == '-' ? Dashed(name) : "-" + std::string(name);
      return absl::InvalidArgumentError(absl::StrCat("unknown flag ", typed, " (see --help)"));
    }
    std::string value;
    if (flag->IsOfType<bool>()) {
      if (!has_value) continue;
      if (inline_value.empty()) {
        return absl::InvalidArgumentError(absl::StrCat(Dashed(name), "= needs true or false after the \"=\""));
      }
      value = std::string(inline_value);
    } else if (has_value) {
      value = std::string(inline_value);
    } else {
      if (i + 1 >= argc) return absl::InvalidArgumentError(absl::StrCat(Dashed(name), " needs a value"));
      value = argv[++i];
    }
    std::string error;
    if (!flag->ParseFrom(value, &error)) {
      return absl::InvalidArgumentError(absl::StrCat(Dashed(name), ": \"", value, "\" is not a valid value: ", error));
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor
