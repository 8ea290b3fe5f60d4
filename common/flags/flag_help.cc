#include "common/flags/flag_help.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <map>
#include <sstream>

#include "absl/flags/commandlineflag.h"
#include "absl/flags/reflection.h"
#include "absl/strings/numbers.h"
#include "common/flags/flag_names.h"
#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

constexpr size_t kWidth = 80;       // wrap the text at this column
constexpr size_t kHelpColumn = 28;  // where a flag's description starts

// Abseil's parsing flags, listed under their own heading; every other flag
// defined in Abseil's sources (its help variants, --version,
// --only_check_args) is an alias of what this file prints or a tool for
// scripts, and is left out.
constexpr const char* kParsingFlags[] = {"flagfile", "fromenv", "tryfromenv", "undefok"};

bool IsAbseilFlag(const absl::CommandLineFlag& flag) {
  return flag.Filename().find("absl/flags/") != std::string::npos;
}

// What the value looks like, from the flag's type.
std::string Placeholder(const absl::CommandLineFlag& flag) {
  if (flag.IsOfType<bool>()) return "";
  if (flag.IsOfType<int>() || flag.IsOfType<int64_t>() || flag.IsOfType<uint64_t>() ||
      flag.IsOfType<uint32_t>() || flag.IsOfType<int32_t>()) {
    return "=N";
  }
  if (flag.IsOfType<double>() || flag.IsOfType<float>()) return "=X";
  if (flag.IsOfType<std::vector<std::string>>()) return "=A,B,...";
  // A help text that starts with the value's shape ("HOST:PORT to serve
  // on") names it; else the name's kind of thing.
  const std::string help = flag.Help();
  const std::string first_word = help.substr(0, help.find(' '));
  if (first_word.size() > 1 &&
      std::all_of(first_word.begin(), first_word.end(), [](char c) { return std::isupper(c) || c == ':' || c == '_'; })) {
    return "=" + first_word;
  }
  const std::string name(flag.Name());
  if (name.find("file") != std::string::npos || name.find("binary") != std::string::npos) return "=PATH";
  if (name == "data" || name == "scratch" || name.find("dir") != std::string::npos) return "=DIR";
  return "=TEXT";
}

std::string DefaultText(const absl::CommandLineFlag& flag) {
  const std::string value = flag.DefaultValue();
  if (value.empty()) return "none";
  if (flag.IsOfType<std::string>()) return "\"" + value + "\"";
  // Byte counts: also in binary units, when exact.
  const std::string name(flag.Name());
  if (name.size() >= 5 && name.compare(name.size() - 5, 5, "bytes") == 0) {
    int64_t n = 0;
    if (absl::SimpleAtoi(value, &n) && n >= 1024) {
      const char* units[] = {"KiB", "MiB", "GiB", "TiB"};
      int unit = -1;
      while (n % 1024 == 0 && n >= 1024 && unit < 3) {
        n /= 1024;
        ++unit;
      }
      if (unit >= 0) return absl::StrCat(value, " (", n, " ", units[unit], ")");
    }
  }
  return value;
}

// Appends `text` word-wrapped to kWidth, every line indented by `indent`;
// the first line continues `out`'s current line when it ends short of it.
void AppendWrapped(std::string& out, const std::string& text, size_t indent) {
  size_t column = out.size() - (out.rfind('\n') == std::string::npos ? 0 : out.rfind('\n') + 1);
  if (column + 2 > indent && column > 0) {
    out += '\n';
    column = 0;
  }
  out.append(indent - column, ' ');
  column = indent;
  bool first_word = true;
  std::istringstream words(text);
  for (std::string word; words >> word;) {
    if (!first_word && column + 1 + word.size() > kWidth) {
      out += '\n';
      out.append(indent, ' ');
      column = indent;
      first_word = true;
    }
    if (!first_word) {
      out += ' ';
      ++column;
    }
    out.append(word);
    column += word.size();
    first_word = false;
  }
  out += '\n';
}

void AppendFlag(std::string& out, const absl::CommandLineFlag& flag) {
  const std::string name = DashedFlagName(std::string(flag.Name()));
  out += absl::StrCat("  --", name, Placeholder(flag));
  std::string help = flag.Help();
  if (flag.IsOfType<bool>()) help += absl::StrCat(" (--no", name, " to turn off)");
  // A help text that explains an empty default itself ("(default: next to
  // this binary)", "Default: token unless ...") is not followed by
  // "Default: none".
  const bool explains_default =
      help.find("(default") != std::string::npos || help.find("Default:") != std::string::npos;
  if (flag.DefaultValue().empty() && explains_default) {
    AppendWrapped(out, help + ".", kHelpColumn);
  } else {
    // The default is never split across lines: its spaces are held as \x01
    // while wrapping.
    std::string value = DefaultText(flag);
    std::replace(value.begin(), value.end(), ' ', '\x01');
    const size_t from = out.size();
    AppendWrapped(out, absl::StrCat(help, ". Default: ", value, "."), kHelpColumn);
    std::replace(out.begin() + from, out.end(), '\x01', ' ');
  }
}

bool Matches(const FlagGroup& group, const std::string& name) {
  return std::any_of(group.prefixes.begin(), group.prefixes.end(),
                     [&](const std::string& prefix) { return name.rfind(prefix, 0) == 0; });
}

}  // namespace

std::string FlagHelpText(const ProgramHelp& help) {
  // Sorted by name within each group, so the text is stable.
  std::map<std::string, const absl::CommandLineFlag*> ours;
  std::map<std::string, const absl::CommandLineFlag*> parsing;
  for (const auto& [name, flag] : absl::GetAllFlags()) {
    if (flag->IsRetired()) continue;
    if (!IsAbseilFlag(*flag)) {
      ours.emplace(std::string(name), flag);
    } else if (std::find(std::begin(kParsingFlags), std::end(kParsingFlags), name) != std::end(kParsingFlags)) {
      parsing.emplace(std::string(name), flag);
    }
  }

  std::string out;
  for (size_t i = 0; i < help.usage.size(); ++i) {
    out += absl::StrCat(i == 0 ? "Usage: " : "       ", help.program, " ", help.usage[i], "\n");
  }
  out += '\n';
  AppendWrapped(out, help.summary, 0);

  std::vector<std::vector<const absl::CommandLineFlag*>> grouped(help.groups.size() + 1);
  for (const auto& [name, flag] : ours) {
    size_t g = 0;
    while (g < help.groups.size() && !Matches(help.groups[g], name)) ++g;
    grouped[g].push_back(flag);
  }
  for (size_t g = 0; g < grouped.size(); ++g) {
    if (grouped[g].empty()) continue;
    out += absl::StrCat("\n", g < help.groups.size() ? help.groups[g].title : "Other", ":\n");
    for (const absl::CommandLineFlag* flag : grouped[g]) AppendFlag(out, *flag);
  }

  out += "\nGeneral:\n";
  out += "  --help                    Print this text and exit.\n";
  out += "  --version                 Print the version and the baker version and exit.\n";
  for (const auto& [name, flag] : parsing) AppendFlag(out, *flag);
  out += "\nFlags take their value as --flag=VALUE or --flag VALUE; names may be spelled\n"
         "with dashes or underscores (--local-workers, --local_workers).\n";
  if (!help.footer.empty()) {
    out += '\n';
    std::istringstream paragraphs(help.footer);
    for (std::string paragraph; std::getline(paragraphs, paragraph);) AppendWrapped(out, paragraph, 0);
  }
  return out;
}

std::string VersionLine(std::string_view program) {
  return std::string(program) + " " IMPOSTOR_VERSION " (baker " IMPOSTOR_BAKER_VERSION ")";
}

std::optional<int> HandleHelpAndVersion(int argc, char** argv, const ProgramHelp& help) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--") break;
    const std::string name = DashedFlagName(std::string(arg.substr(0, arg.find('='))));
    if (name == "--help" || name == "-h" || name == "--helpfull" || name == "--helpshort") {
      std::fputs(FlagHelpText(help).c_str(), stdout);
      return 0;
    }
    if (name == "--version") {
      std::printf("%s\n", VersionLine(help.program).c_str());
      return 0;
    }
  }
  return std::nullopt;
}

}  // namespace impostor
