#include "client/transfer/mesh_upload.h"

#include <algorithm>
#include <map>
#include <set>
#include <string>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "client/transfer/blob_batch_upload.h"

namespace impostor::sdk {
namespace {

// `s` (a refusal of the blob in `path`) saying which file it was, its
// payloads (the RPC, the server, its error reason) kept.
absl::Status NamingFile(const absl::Status& s, const std::filesystem::path& path) {
  absl::Status named(s.code(), absl::StrCat("uploading ", path.string(), ": ", s.message()));
  s.ForEachPayload(
      [&named](absl::string_view type_url, const absl::Cord& payload) { named.SetPayload(type_url, payload); });
  return named;
}

}  // namespace

absl::StatusOr<v1::MeshInput> HashMesh(const MeshFiles& files) {
  FileDigestMemo memo;
  return HashMesh(files, memo);
}

absl::StatusOr<v1::MeshInput> HashMesh(const MeshFiles& files, FileDigestMemo& memo) {
  v1::MeshInput mesh;
  auto add = [&memo](const std::filesystem::path& path, v1::InputFile* input, const std::string& name) -> absl::Status {
    absl::StatusOr<v1::Digest> digest = memo.Get(path);
    if (!digest.ok()) return digest.status();
    input->set_path(name);
    *input->mutable_digest() = *digest;
    return absl::OkStatus();
  };
  if (absl::Status s = add(files.entry, mesh.mutable_entry(), files.entry_name); !s.ok()) return s;
  for (const MeshFile& file : files.files) {
    if (absl::Status s = add(file.local_path, mesh.add_files(), file.relative_path); !s.ok()) return s;
  }
  return mesh;
}

absl::StatusOr<UploadedMesh> UploadMesh(Transport& transport, const MeshFiles& files, const CancelSource* cancel) {
  UploadedMesh out;
  absl::StatusOr<v1::MeshInput> mesh = HashMesh(files);
  if (!mesh.ok()) return mesh.status();
  out.mesh = std::move(*mesh);
  std::vector<LocalBlob> blobs;
  auto add = [&](const v1::InputFile& input, const std::filesystem::path& path) {
    blobs.push_back(LocalBlob{path, input.digest()});
    ++out.stats.files;
    out.stats.bytes_total += input.digest().size_bytes();
  };
  add(out.mesh.entry(), files.entry);
  for (int i = 0; i < out.mesh.files_size(); ++i) add(out.mesh.files(i), files.files[i].local_path);

  v1::FindMissingBlobsRequest request;
  for (const LocalBlob& blob : blobs) *request.add_digests() = blob.digest;
  absl::StatusOr<v1::FindMissingBlobsResponse> missing = transport.FindMissingBlobs(request, cancel);
  if (!missing.ok()) return missing.status();

  std::set<std::string> missing_keys;
  for (const v1::Digest& d : missing->missing()) missing_keys.insert(absl::StrCat(d.hash(), "/", d.size_bytes()));
  // Two files with the same content are one blob: upload it once.
  std::set<std::string> done;
  std::vector<LocalBlob> to_upload;
  for (const LocalBlob& blob : blobs) {
    const std::string key = absl::StrCat(blob.digest.hash(), "/", blob.digest.size_bytes());
    if (missing_keys.contains(key) && done.insert(key).second) to_upload.push_back(blob);
  }
  absl::StatusOr<std::vector<absl::Status>> each = UploadBlobFiles(transport, to_upload, cancel);
  if (!each.ok()) return each.status();
  for (size_t i = 0; i < to_upload.size(); ++i) {
    const absl::Status& s = (*each)[i];
    if (!s.ok()) return NamingFile(s, to_upload[i].path);
    ++out.stats.uploaded;
    out.stats.bytes_uploaded += to_upload[i].digest.size_bytes();
  }
  return out;
}

absl::StatusOr<std::vector<absl::StatusOr<UploadedMesh>>> UploadMeshes(Transport& transport,
                                                                      const std::vector<const MeshFiles*>& models,
                                                                      const CancelSource* cancel) {
  std::vector<absl::StatusOr<UploadedMesh>> out;
  out.reserve(models.size());
  // Every distinct blob once, with the first model that has it.
  std::vector<LocalBlob> blobs;
  std::vector<std::vector<size_t>> users;  // per blob: the models that have it, first first
  std::map<std::string, size_t> blob_of;    // "hash/size" -> index in blobs
  FileDigestMemo memo;  // a model baked under several settings is hashed once
  for (size_t m = 0; m < models.size(); ++m) {
    absl::StatusOr<v1::MeshInput> mesh = HashMesh(*models[m], memo);
    if (!mesh.ok()) {
      out.push_back(mesh.status());
      continue;
    }
    UploadedMesh uploaded;
    uploaded.mesh = std::move(*mesh);
    auto add = [&](const v1::InputFile& input, const std::filesystem::path& local) {
      ++uploaded.stats.files;
      uploaded.stats.bytes_total += input.digest().size_bytes();
      const std::string key = absl::StrCat(input.digest().hash(), "/", input.digest().size_bytes());
      auto [it, added] = blob_of.emplace(key, blobs.size());
      if (added) {
        blobs.push_back(LocalBlob{local, input.digest()});
        users.emplace_back();
      }
      if (users[it->second].empty() || users[it->second].back() != m) users[it->second].push_back(m);
    };
    add(uploaded.mesh.entry(), models[m]->entry);
    for (int i = 0; i < uploaded.mesh.files_size(); ++i) add(uploaded.mesh.files(i), models[m]->files[i].local_path);
    out.push_back(std::move(uploaded));
  }

  std::set<std::string> missing_keys;
  for (size_t begin = 0; begin < blobs.size(); begin += kMaxFindMissingDigests) {
    v1::FindMissingBlobsRequest request;
    for (size_t i = begin; i < std::min(blobs.size(), begin + kMaxFindMissingDigests); ++i) {
      *request.add_digests() = blobs[i].digest;
    }
    absl::StatusOr<v1::FindMissingBlobsResponse> missing = transport.FindMissingBlobs(request, cancel);
    if (!missing.ok()) return missing.status();
    for (const v1::Digest& d : missing->missing()) missing_keys.insert(absl::StrCat(d.hash(), "/", d.size_bytes()));
  }
  std::vector<size_t> to_upload;  // indices into blobs
  std::vector<LocalBlob> files;
  for (size_t i = 0; i < blobs.size(); ++i) {
    if (!missing_keys.contains(absl::StrCat(blobs[i].digest.hash(), "/", blobs[i].digest.size_bytes()))) continue;
    to_upload.push_back(i);
    files.push_back(blobs[i]);
  }
  // A refusal of the caller or the connection ends the whole batch.
  absl::StatusOr<std::vector<absl::Status>> each = UploadBlobFiles(transport, files, cancel);
  if (!each.ok()) return each.status();
  for (size_t k = 0; k < to_upload.size(); ++k) {
    const size_t i = to_upload[k];
    if (const absl::Status& s = (*each)[k]; !s.ok()) {
      // The server refused this blob (its disk is full, it is too large):
      // the models that need it fail and the rest go on.
      for (size_t m : users[i]) {
        if (out[m].ok()) out[m] = NamingFile(s, blobs[i].path);
      }
      continue;
    }
    if (!out[users[i].front()].ok()) continue;
    UploadStats& stats = out[users[i].front()]->stats;
    ++stats.uploaded;
    stats.bytes_uploaded += blobs[i].digest.size_bytes();
  }
  return out;
}

}  // namespace impostor::sdk
