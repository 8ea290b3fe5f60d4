// The benches' command lines. Each bench declares its flags with their help
// text. `--help` prints them. An unknown flag, a flag without its value, or
// a value that is not a number ends the program with exit code 2 and says
// which, before any work starts. A typo must not run a bench with its
// defaults: quality_table, for one, rewrites docs/quality.md.
//
// Flags take their value as the next argument or after '=' (`--frames 12`,
// `--frames=12`). Flag names keep their dashes, as the docs and scripts
// spell them, which is why this is not absl's flags library (its flag names
// must be C identifiers).
#ifndef IMPOSTOR_BENCH_BENCH_ARGS_H_
#define IMPOSTOR_BENCH_BENCH_ARGS_H_

#include <charconv>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace impostor::bench {

class BenchArgs {
 public:
  BenchArgs(std::string program, std::string summary) : program_(std::move(program)), summary_(std::move(summary)) {}

  BenchArgs& Text(std::string name, std::string* out, std::string help) {
    return Add(std::move(name), "TEXT", std::move(help), [out](std::string_view v) {
      *out = std::string(v);
      return true;
    });
  }
  // May be given more than once; each value is appended.
  BenchArgs& Texts(std::string name, std::vector<std::string>* out, std::string help) {
    return Add(std::move(name), "TEXT", std::move(help) + " (repeatable)", [out](std::string_view v) {
      out->emplace_back(v);
      return true;
    });
  }
  BenchArgs& Int(std::string name, int* out, std::string help) {
    return Add(std::move(name), "N", std::move(help), [out](std::string_view v) { return ParseNumber(v, out); });
  }
  BenchArgs& Uint(std::string name, uint32_t* out, std::string help) {
    return Add(std::move(name), "N", std::move(help), [out](std::string_view v) { return ParseNumber(v, out); });
  }
  BenchArgs& Real(std::string name, double* out, std::string help) {
    return Add(std::move(name), "X", std::move(help), [out](std::string_view v) { return ParseNumber(v, out); });
  }
  // A flag without a value: present = true.
  BenchArgs& Switch(std::string name, bool* out, std::string help) {
    flags_.push_back({std::move(name), "", std::move(help), [out](std::string_view) {
                        *out = true;
                        return true;
                      }});
    return *this;
  }
  // Every argument that is not a flag, in order. Without this, one is an error.
  BenchArgs& Positional(std::string name, std::vector<std::string>* out, std::string help) {
    positional_name_ = std::move(name);
    positional_help_ = std::move(help);
    positional_ = out;
    return *this;
  }

  void ParseOrExit(int argc, char** argv) const {
    for (int i = 1; i < argc; ++i) {
      const std::string_view arg = argv[i];
      if (arg == "--help" || arg == "-h") {
        PrintUsage(stdout);
        std::exit(0);
      }
      if (arg.size() < 2 || arg.substr(0, 2) != "--") {
        if (positional_ == nullptr) Fail("unexpected argument '" + std::string(arg) + "'");
        positional_->emplace_back(arg);
        continue;
      }
      const size_t eq = arg.find('=');
      const std::string_view name = arg.substr(0, eq);
      const Flag* flag = Find(name);
      if (flag == nullptr) Fail("unknown flag " + std::string(name));
      std::string_view value;
      if (flag->value_name.empty()) {
        if (eq != std::string_view::npos) Fail(std::string(name) + " takes no value");
      } else if (eq != std::string_view::npos) {
        value = arg.substr(eq + 1);
      } else if (i + 1 < argc) {
        value = argv[++i];
      } else {
        Fail(std::string(name) + " needs a value (" + flag->value_name + ")");
      }
      if (!flag->set(value)) {
        Fail(std::string(name) + ": '" + std::string(value) + "' is not a " +
             (flag->value_name == "N" ? "whole number" : "number"));
      }
    }
  }

 private:
  struct Flag {
    std::string name, value_name, help;
    std::function<bool(std::string_view)> set;
  };

  template <typename T>
  static bool ParseNumber(std::string_view v, T* out) {
    T parsed{};
    const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), parsed);
    if (ec != std::errc() || end != v.data() + v.size() || v.empty()) return false;
    *out = parsed;
    return true;
  }

  BenchArgs& Add(std::string name, std::string value_name, std::string help,
                 std::function<bool(std::string_view)> set) {
    flags_.push_back({std::move(name), std::move(value_name), std::move(help), std::move(set)});
    return *this;
  }

  const Flag* Find(std::string_view name) const {
    for (const Flag& f : flags_) {
      if (f.name == name) return &f;
    }
    return nullptr;
  }

  void PrintUsage(std::FILE* to) const {
    std::fprintf(to, "usage: %s", program_.c_str());
    for (const Flag& f : flags_) {
      std::fprintf(to, " [%s%s%s]", f.name.c_str(), f.value_name.empty() ? "" : " ", f.value_name.c_str());
    }
    if (positional_ != nullptr) std::fprintf(to, " [%s ...]", positional_name_.c_str());
    std::fprintf(to, "\n%s\n", summary_.c_str());
    for (const Flag& f : flags_) {
      std::fprintf(to, "  %s%s%s\n      %s\n", f.name.c_str(), f.value_name.empty() ? "" : " ", f.value_name.c_str(),
                   f.help.c_str());
    }
    if (positional_ != nullptr) std::fprintf(to, "  %s ...\n      %s\n", positional_name_.c_str(), positional_help_.c_str());
  }

  [[noreturn]] void Fail(const std::string& why) const {
    std::fprintf(stderr, "%s: %s\n", program_.c_str(), why.c_str());
    PrintUsage(stderr);
    std::exit(2);
  }

  std::string program_, summary_;
  std::vector<Flag> flags_;
  std::string positional_name_, positional_help_;
  std::vector<std::string>* positional_ = nullptr;
};

}  // namespace impostor::bench

#endif  // IMPOSTOR_BENCH_BENCH_ARGS_H_
