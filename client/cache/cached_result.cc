// CachedResult: accessors over the shared Rep. A default handle answers
// with empty values.
#include "client/cache/cached_result_rep.h"

namespace impostor::sdk {
namespace {

const EntryView& ViewOf(const std::shared_ptr<const CachedResult::Rep>& rep) {
  static const EntryView* empty = new EntryView();
  return rep != nullptr ? *rep->view : *empty;
}

}  // namespace

CachedResult::CachedResult() = default;
CachedResult::~CachedResult() = default;
CachedResult::CachedResult(const CachedResult&) = default;
CachedResult& CachedResult::operator=(const CachedResult&) = default;
CachedResult::CachedResult(CachedResult&&) noexcept = default;
CachedResult& CachedResult::operator=(CachedResult&&) noexcept = default;
CachedResult::CachedResult(std::shared_ptr<const Rep> rep) : rep_(std::move(rep)) {}

bool CachedResult::valid() const { return rep_ != nullptr; }
const std::string& CachedResult::key() const { return ViewOf(rep_).key; }
const std::filesystem::path& CachedResult::dir() const { return ViewOf(rep_).dir; }
const std::filesystem::path& CachedResult::manifest_path() const { return ViewOf(rep_).manifest_path; }
const std::string& CachedResult::manifest_json() const { return ViewOf(rep_).manifest_json; }
const std::vector<CachedFile>& CachedResult::files() const { return ViewOf(rep_).files; }
int64_t CachedResult::size_bytes() const { return ViewOf(rep_).size_bytes; }
const std::string& CachedResult::layout() const { return ViewOf(rep_).layout; }
uint32_t CachedResult::frames() const { return ViewOf(rep_).frames; }
uint32_t CachedResult::resolution() const { return ViewOf(rep_).resolution; }
const std::string& CachedResult::product() const { return ViewOf(rep_).product; }
uint32_t CachedResult::view_count() const { return ViewOf(rep_).view_count; }
bool CachedResult::texture_array() const { return ViewOf(rep_).texture_array; }
bool CachedResult::downloaded() const { return rep_ != nullptr && rep_->downloaded; }

const CachedFile* CachedResult::map(const std::string& semantic) const {
  for (const CachedFile& f : ViewOf(rep_).files) {
    if (f.semantic == semantic && semantic != "manifest") return &f;
  }
  return nullptr;
}

}  // namespace impostor::sdk
