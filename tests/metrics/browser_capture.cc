#include "tests/metrics/browser_capture.h"

#include <fstream>


namespace impostor::testing {

std::string Base64Decode(const std::string& in) {
  std::string out;
  int value = 0, bits = -8;
  for (unsigned char c : in) {
    int d;
    if (c >= 'A' && c <= 'Z') d = c - 'A';
    else if (c >= 'a' && c <= 'z') d = c - 'a' + 26;
    else if (c >= '0' && c <= '9') d = c - '0' + 52;
    else if (c == '+') d = 62;
    else if (c == '/') d = 63;
    else continue;
    value = (value << 6) | d;
    bits += 6;
    if (bits >= 0) {
      out.push_back(static_cast<char>((value >> bits) & 0xff));
      bits -= 8;
    }
  }
  return out;
}

nlohmann::json RunPage(int port, const std::string& path, const std::string& until, const std::string& eval,
                       const std::filesystem::path& screenshot) {
  std::vector<std::string> argv = {"/usr/bin/node", "--experimental-websocket",
                                   std::string(IMPOSTOR_SOURCE_DIR) + "/tests/metrics/browser/cdp_page.mjs",
                                   "--chromium", "/usr/bin/chromium", "--url",
                                   "http://127.0.0.1:" + std::to_string(port) + path, "--until", until,
                                   "--timeout-ms", "180000"};
  if (!eval.empty()) argv.insert(argv.end(), {"--eval", eval});
  if (!screenshot.empty()) argv.insert(argv.end(), {"--screenshot", screenshot.string()});
  const ToolRun run = RunTool(argv, std::chrono::seconds(240));
  nlohmann::json report = nlohmann::json::parse(run.out, nullptr, false);
  if (report.is_discarded()) ADD_FAILURE() << "cdp_page.mjs printed no report: " << run.out << run.err;
  return report;
}

int RingViews(LayoutKind kind, const v1::Manifest& m) {
  return kind == LayoutKind::kRingTop ? m.views_size() - 1 : kind == LayoutKind::kBillboard ? 8 : 0;
}

std::vector<std::string> SubmitEveryLayout(ServerProcess& server, const v1::MeshInput& mesh) {
  std::vector<std::string> jobs;
  for (const LayoutCase& c : kEveryLayout) {
    v1::SubmitBakeRequest request;
    *request.mutable_mesh() = mesh;
    request.mutable_parameters()->set_layout(c.layout);
    if (c.frames) request.mutable_parameters()->set_frames(c.frames);
    if (c.ring_views) request.mutable_parameters()->set_ring_views(c.ring_views);
    request.mutable_parameters()->set_resolution(256);
    request.mutable_parameters()->set_quality_views(0);
    v1::SubmitBakeResponse response;
    const grpc::Status s = server.bake().SubmitBake(ContextWithin().get(), request, &response);
    if (!s.ok()) {
      ADD_FAILURE() << c.name << ": " << s.error_message();
      break;
    }
    jobs.push_back(response.job_id());
  }
  return jobs;
}

std::vector<uint8_t> SavePngDataUrl(const std::string& url, const std::filesystem::path& file, int* width,
                                    int* height) {
  const std::string prefix = "data:image/png;base64,";
  if (url.rfind(prefix, 0) != 0) {
    ADD_FAILURE() << "not a PNG data URL: " << url.substr(0, 80);
    return {};
  }
  std::ofstream(file, std::ios::binary) << Base64Decode(url.substr(prefix.size()));
  return ReadRgba<uint8_t>(file, width, height);
}

}  // namespace impostor::testing
