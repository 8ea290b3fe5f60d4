// cpp-httplib's Server with every request's size bounded. Debian's
// cpp-httplib (0.11.4, a compiled library) reads a request line or header
// line into memory until its CRLF, however long, and only then compares it
// with its limits: one unauthenticated connection sending "GET /" and then
// endless bytes grew the server past a gigabyte until std::bad_alloc ended
// the process. The library offers no setting for it, so this class does what
// it should: it serves each connection itself (the keep-alive loop of the
// library's own process_and_close_socket) through a stream that refuses to
// read more than kMaxRequestBytes for one request, head and body together,
// and the library's protected process_request parses and routes as before.
// Request bodies are capped at kMaxBodyBytes (set_payload_max_length: 413).
#ifndef IMPOSTOR_SERVER_HTTP_BOUNDED_HTTP_SERVER_H_
#define IMPOSTOR_SERVER_HTTP_BOUNDED_HTTP_SERVER_H_

#include <cstddef>

#include <httplib.h>

namespace impostor {

class BoundedHttpServer : public httplib::Server {
 public:
  // The largest request body the API takes (the login form's token).
  static constexpr size_t kMaxBodyBytes = 64 * 1024;
  // The most bytes read for one request: a request line, headers and a body
  // within their limits fit with room to spare.
  static constexpr size_t kMaxRequestBytes = 256 * 1024;

  BoundedHttpServer();

 private:
  bool process_and_close_socket(socket_t sock) override;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_BOUNDED_HTTP_SERVER_H_
