#include "common/request/worker_fit.h"

#include <algorithm>
#include <map>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/request/bake_memory_estimate.h"

namespace impostor {
namespace {

bool IsTagByte(char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-'; }

bool IsPrintableAscii(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](char c) { return c >= 0x20 && c < 0x7f; });
}

absl::Status NonNegative(const char* field, const char* name, int64_t value) {
  if (value >= 0) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, ".", name, ": ", value, " bytes is negative"));
}

std::string Amount(const Shortfall& s) { return MemoryAmount(s.need_bytes); }

}  // namespace

bool IsValidWorkerTag(const std::string& tag) {
  return !tag.empty() && tag.size() <= kMaxWorkerTagBytes && std::all_of(tag.begin(), tag.end(), IsTagByte);
}

absl::StatusOr<std::vector<std::string>> NormalizeRequiredTagList(std::vector<std::string> tags, const char* field,
                                                                  bool indexed) {
  if (static_cast<int>(tags.size()) > kMaxWorkerTags) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", tags.size(), " tags is over the limit of ", kMaxWorkerTags));
  }
  for (size_t i = 0; i < tags.size(); ++i) {
    if (!IsValidWorkerTag(tags[i])) {
      return absl::InvalidArgumentError(absl::StrCat(field, indexed ? absl::StrCat("[", i, "]") : "", ": \"",
                                                     absl::CHexEscape(tags[i].substr(0, 80)), "\" is not 1..",
                                                     kMaxWorkerTagBytes, " bytes of [a-z0-9._-]"));
    }
  }
  std::sort(tags.begin(), tags.end());
  tags.erase(std::unique(tags.begin(), tags.end()), tags.end());
  return tags;
}

absl::Status ValidateCapabilities(const v1::WorkerCapabilities& caps, const char* field) {
  if (caps.device_kind().size() > kMaxDeviceKindBytes || !IsPrintableAscii(caps.device_kind())) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".device_kind: ", caps.device_kind().size(),
                                                   " bytes; at most ", kMaxDeviceKindBytes, " printable ASCII"));
  }
  if (auto s = NonNegative(field, "device_memory_bytes", caps.device_memory_bytes()); !s.ok()) return s;
  if (auto s = NonNegative(field, "max_allocation_bytes", caps.max_allocation_bytes()); !s.ok()) return s;
  if (auto s = NonNegative(field, "host_memory_bytes", caps.host_memory_bytes()); !s.ok()) return s;
  if (caps.baker_version().size() > kMaxBakerVersionBytes || !IsPrintableAscii(caps.baker_version())) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".baker_version: ", caps.baker_version().size(),
                                                   " bytes; at most ", kMaxBakerVersionBytes, " printable ASCII"));
  }
  if (caps.tags_size() > kMaxWorkerTags) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".tags: ", caps.tags_size(), " tags, the limit is ", kMaxWorkerTags));
  }
  for (int i = 0; i < caps.tags_size(); ++i) {
    if (!IsValidWorkerTag(caps.tags(i))) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".tags[", i, "]: a tag is 1..", kMaxWorkerTagBytes,
                                                     " bytes of [a-z0-9._-]"));
    }
  }
  return absl::OkStatus();
}

std::optional<Shortfall> WorkerShortfall(const v1::BakeParameters& normalised, const v1::WorkerCapabilities& caps) {
  if (normalised.texture_format() == v1::TEXTURE_FORMAT_KTX2 && !caps.ktx2_encoder()) {
    return Shortfall{.what = "KTX2 encoder"};
  }
  const BakeDevice kind = BakeDeviceOfType(caps.device_kind());
  const BakeMemoryEstimate need = EstimateBakeMemory(normalised, kind);
  // The same totals, in the same order, as the worker's own check
  // (worker/bake_memory_check.cc); what is free now is the worker's to judge.
  if (caps.max_allocation_bytes() > 0 && need.largest_allocation_bytes > caps.max_allocation_bytes()) {
    return Shortfall{"device allocation", need.largest_allocation_bytes, caps.max_allocation_bytes()};
  }
  // A CPU device's heap is nominal: host memory bounds it.
  if (kind != BakeDevice::kCpu && caps.device_memory_bytes() > 0 && need.device_bytes > caps.device_memory_bytes()) {
    return Shortfall{"device memory", need.device_bytes, caps.device_memory_bytes()};
  }
  if (caps.host_memory_bytes() > 0 && need.host_bytes > caps.host_memory_bytes()) {
    return Shortfall{"host memory", need.host_bytes, caps.host_memory_bytes()};
  }
  return std::nullopt;
}

bool HasRequiredTags(const v1::WorkerCapabilities* caps, const std::vector<std::string>& required) {
  if (required.empty()) return true;
  if (caps == nullptr) return false;
  return std::all_of(required.begin(), required.end(), [&](const std::string& tag) {
    return std::find(caps->tags().begin(), caps->tags().end(), tag) != caps->tags().end();
  });
}

std::string UnplaceableReason(const v1::BakeParameters& normalised, const std::vector<v1::WorkerCapabilities>& all,
                              const std::vector<std::string>& required_tags) {
  if (all.empty()) return "";
  std::vector<v1::WorkerCapabilities> workers;
  for (const v1::WorkerCapabilities& caps : all) {
    if (HasRequiredTags(&caps, required_tags)) workers.push_back(caps);
  }
  if (workers.empty()) {
    return absl::StrCat("waiting for a worker tagged ", absl::StrJoin(required_tags, ", "), " (none of the ", all.size(),
                        " workers seen has ", required_tags.size() == 1 ? "it" : "them all", ") for ",
                        DescribeBake(normalised));
  }
  std::optional<Shortfall> first;
  // The most any worker has of each resource a shortfall may name.
  std::map<std::string, int64_t> most;
  for (const v1::WorkerCapabilities& caps : workers) {
    std::optional<Shortfall> s = WorkerShortfall(normalised, caps);
    if (!s) return "";
    if (!first) first = s;
    most["host memory"] = std::max(most["host memory"], caps.host_memory_bytes());
    most["device memory"] = std::max(most["device memory"], caps.device_memory_bytes());
    most["device allocation"] = std::max(most["device allocation"], caps.max_allocation_bytes());
  }
  if (first->what == "KTX2 encoder") {
    return absl::StrCat("waiting for a worker with the KTX2 encoder (basisu; none of the ", workers.size(),
                        " workers seen has it) for ", DescribeBake(normalised));
  }
  return absl::StrCat("waiting for a worker with at least ", Amount(*first), " of ", first->what,
                      " (the most any worker has: ", MemoryAmount(most[first->what]), ") for ",
                      DescribeBake(normalised));
}

}  // namespace impostor
