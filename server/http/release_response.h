// Answers GET and HEAD under /releases/ (--http-releases) with the files of
// a release tree (release_files.h), as a static web server or CDN origin
// would, so that http://HOST:PORT/releases is a mirror base URL:
//   blobs, catalogs  Cache-Control: public, max-age=31536000, immutable;
//                    ETag "<digest>"; checked against their name before
//                    anything is sent (ReleaseTree::Verify): a mismatch is
//                    500 naming the path and both digests, never the bytes
//   channels         Cache-Control: public, max-age=10; ETag: the quoted
//                    SHA-256 of the bytes read for this very request (the
//                    publisher replaces the file by a rename at any time)
// Content-Type: application/octet-stream for blobs, application/json for
// catalogs and channels. Bytes go as stored, never with a Content-Encoding,
// so the ETag is always the digest of what is sent, and Content-Length and
// ranges count the stored bytes.
//
// The check reads a file once per version (ReleaseTree::Verify), not per
// download: bytes are not hashed again as they stream. A file rewritten in
// place during a download can reach that client, whose own check (a client
// verifies every byte against the name it asked for) refuses it; the next
// request sees a new version and checks it.
//
// Conditional and range requests (RFC 9110): If-None-Match listing the
// ETag (weak comparison, or "*") is 304. One "Range: bytes=..." range is
// 206 with Content-Range (a last byte past the end is clamped, byte_range.h);
// one that starts past the end is 416 with "Content-Range: bytes */SIZE".
// Several ranges, or an If-Range naming another tag, get the whole file
// (200), as the RFC allows. Every answer says Accept-Ranges: bytes.
//
// Errors: any path that is not exactly one of the tree's three shapes
// (release_files.h: ParseReleasePath; no "..", no %-escapes, no links) and
// any file not there is 404; none of them is ever a partial body. Errors
// carry Cache-Control: no-store, so a cache in front does not keep the 404
// of a blob that a publish is about to add.
//
// Thread-safety: any thread (the HTTP library's handler threads). The body
// streams from the file opened here after the handler returned (the
// response keeps it open), so `tree` must outlive the server.
#ifndef IMPOSTOR_SERVER_HTTP_RELEASE_RESPONSE_H_
#define IMPOSTOR_SERVER_HTTP_RELEASE_RESPONSE_H_

#include <string_view>

#include <httplib.h>

#include "server/http/release_files.h"

namespace impostor {

// The URL prefix of the release tree: a mirror base URL is
// http://HOST:PORT/releases.
inline constexpr std::string_view kReleasesUrlPrefix = "/releases/";

// Sets `res` to the answer to `req`, a GET or HEAD whose path starts with
// kReleasesUrlPrefix (see above). Reads the request's raw target, not its
// percent-decoded path.
void ServeReleaseFile(ReleaseTree& tree, const httplib::Request& req, httplib::Response& res);

// Whether the If-None-Match header value `header` lists `etag` (a quoted
// entity tag) under the weak comparison RFC 9110 section 13.1.2 prescribes
// for it: W/"x" matches "x", and "*" matches any. False for "". Pure.
bool IfNoneMatchMatches(std::string_view header, std::string_view etag);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_RELEASE_RESPONSE_H_
