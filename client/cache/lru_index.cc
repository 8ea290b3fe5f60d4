#include "client/cache/lru_index.h"

namespace impostor::sdk {

void LruIndex::Insert(const std::string& key, int64_t size_bytes, int64_t last_used) {
  Erase(key);
  order_.push_front(Item{key, size_bytes, last_used});
  items_[key] = order_.begin();
  total_bytes_ += size_bytes;
}

void LruIndex::Touch(const std::string& key, int64_t now) {
  auto it = items_.find(key);
  if (it == items_.end()) return;
  it->second->last_used = now;
  order_.splice(order_.begin(), order_, it->second);
}

void LruIndex::Erase(const std::string& key) {
  auto it = items_.find(key);
  if (it == items_.end()) return;
  total_bytes_ -= it->second->size_bytes;
  order_.erase(it->second);
  items_.erase(it);
}

std::vector<std::string> LruIndex::Victims(int64_t cap_bytes,
                                           const std::function<bool(const std::string&)>& pinned) const {
  std::vector<std::string> victims;
  int64_t total = total_bytes_;
  for (auto it = order_.rbegin(); it != order_.rend() && total > cap_bytes; ++it) {
    if (pinned && pinned(it->key)) continue;
    victims.push_back(it->key);
    total -= it->size_bytes;
  }
  return victims;
}

std::vector<LruIndex::Item> LruIndex::Items() const { return {order_.begin(), order_.end()}; }

}  // namespace impostor::sdk
