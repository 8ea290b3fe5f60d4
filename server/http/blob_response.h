// Answers an HTTP GET with one blob of the content-addressed store (a job's
// mesh file, a result's file), streamed: whatever the blob's size, a
// response holds two chunks of kBlobChunkBytes (the one read and the one
// held back, below), where it used to hold the whole blob: twelve readers
// of a 400 MB mesh took 8 GB.
//
// Integrity, as ReadBlob over gRPC: the blob is verified (BlobStore::Verify)
// while the status can still say so, so a blob missing from the store is
// 404 and one known to be corrupt is 500 (and quarantined). A whole blob is
// hashed again as it streams (BlobStore::Read); the final chunk is held
// back until that hash matched, and when it does not (the bytes rotted
// since they were last verified) or a read fails, the connection is closed
// instead: the client gets fewer bytes than Content-Length announced, an
// error to any HTTP client, never a complete forged body. A range is served
// after Verify alone (a range has no digest of its own), as ReadBlob with
// an offset is.
//
// Ranges (RFC 9110): one "Range: bytes=..." range is 206 with Content-Range
// (a last byte past the end is clamped); one that starts past the end is
// 416 with "Content-Range: bytes */SIZE". Several ranges get the whole blob
// (200), which the RFC allows; nothing asks this API for multipart ranges.
// Bytes go as stored: no Content-Encoding, so Content-Length and ranges
// always count the stored bytes and no compressor state grows per stream.
//
// Thread-safety: any thread (the HTTP library's handler threads). The
// response streams after the handler returned, so `blobs` must outlive the
// server (HttpFrontend stops and joins its server before it goes).
#ifndef IMPOSTOR_SERVER_HTTP_BLOB_RESPONSE_H_
#define IMPOSTOR_SERVER_HTTP_BLOB_RESPONSE_H_

#include <cstddef>
#include <string>

#include <httplib.h>

#include "absl/status/status.h"
#include "server/blobs/blob_store.h"

namespace impostor {

// As ReadBlob's messages (asset_service.cc): small enough that a response
// costs little memory, large enough that loopback throughput does not care.
inline constexpr size_t kBlobChunkBytes = size_t{64} << 10;

// Sets `res` to stream the blob `digest` as `content_type` (200, 206 or
// 416, see above) and returns OK; nothing is read until the library writes
// the body. NOT_FOUND when the blob is not in the store, DATA_LOSS when its
// bytes no longer match the digest (it is quarantined): `res` is untouched,
// for the caller's error answer.
absl::Status ServeBlob(const BlobStore& blobs, const BlobDigest& digest, const std::string& content_type,
                       const httplib::Request& req, httplib::Response& res);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_BLOB_RESPONSE_H_
