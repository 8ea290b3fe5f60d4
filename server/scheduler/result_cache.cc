#include "server/scheduler/result_cache.h"

#include <mutex>

namespace impostor {

std::shared_ptr<const v1::Manifest> ResultCache::Find(const std::string& cache_key) const {
  if (capacity_ == 0) return nullptr;
  std::shared_lock lock(mu_);
  auto it = entries_.find(cache_key);
  return it == entries_.end() ? nullptr : it->second;
}

void ResultCache::Fill(const v1::Manifest& manifest) {
  if (capacity_ == 0) return;
  auto entry = std::make_shared<const v1::Manifest>(manifest);
  std::unique_lock lock(mu_);
  if (entries_.size() >= capacity_ && !entries_.count(manifest.cache_key())) entries_.erase(entries_.begin());
  entries_.insert_or_assign(manifest.cache_key(), std::move(entry));
}

void ResultCache::Erase(const std::string& cache_key) {
  std::unique_lock lock(mu_);
  entries_.erase(cache_key);
}

size_t ResultCache::size() const {
  std::shared_lock lock(mu_);
  return entries_.size();
}

}  // namespace impostor
