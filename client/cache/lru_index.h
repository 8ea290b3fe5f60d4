// Least-recently-used accounting of installed results: sizes, last use and
// the order in which they go when the cache is over its cap. Pure
// bookkeeping (no files); not thread-safe: the cache guards it with its
// mutex.
#ifndef IMPOSTOR_CLIENT_CACHE_LRU_INDEX_H_
#define IMPOSTOR_CLIENT_CACHE_LRU_INDEX_H_

#include <cstdint>
#include <functional>
#include <list>
#include <string>
#include <unordered_map>
#include <vector>

namespace impostor::sdk {

class LruIndex {
 public:
  struct Item {
    std::string key;
    int64_t size_bytes = 0;
    int64_t last_used = 0;  // caller's clock, e.g. Unix seconds
  };

  // Adds `key` as the most recently used (replacing its size and time if
  // present).
  void Insert(const std::string& key, int64_t size_bytes, int64_t last_used);
  // Makes `key` the most recently used; no-op when absent.
  void Touch(const std::string& key, int64_t now);
  void Erase(const std::string& key);
  bool Contains(const std::string& key) const { return items_.contains(key); }

  int64_t total_bytes() const { return total_bytes_; }
  size_t size() const { return items_.size(); }

  // Keys to evict, least recently used first, so that the total drops to at
  // most `cap_bytes`; keys for which `pinned` is true are skipped. May not
  // reach the cap when pinned items hold more than it.
  std::vector<std::string> Victims(int64_t cap_bytes, const std::function<bool(const std::string&)>& pinned) const;

  // Every item, most recently used first.
  std::vector<Item> Items() const;

 private:
  std::list<Item> order_;  // front = most recently used
  std::unordered_map<std::string, std::list<Item>::iterator> items_;
  int64_t total_bytes_ = 0;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_LRU_INDEX_H_
