// TlsFileMonitor (server/auth/tls_file_monitor.h): every change to the TLS files
// that gRPC's reload would refuse, or serve although clients will refuse it,
// is one error line naming the flag and the file; a good renewal is one
// info line with the new expiry; a certificate that expires while served is
// reported once.
#include "server/auth/tls_file_monitor.h"

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include "tests/tls/test_certs.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::CertFiles;
using testing::TestPki;

constexpr int64_t kDay = 86400;

class TlsFileMonitorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("impostor_tls_monitor_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    TestPki pki(dir_ / "pki");
    ca_ = pki.MakeCa("ca");
    first_ = pki.MakeServerCert("first", ca_, "DNS:localhost", /*days=*/2);
    renewed_ = pki.MakeServerCert("renewed", ca_, "DNS:localhost", /*days=*/90);
    expired_ = pki.MakeServerCert("expired", ca_, "DNS:localhost", /*days=*/-1);
    Serve(first_);
    // The lines the monitor logs, kept for the assertions.
    sink_ = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64);
    previous_ = spdlog::default_logger();
    auto logger = std::make_shared<spdlog::logger>("tls_monitor_test", sink_);
    logger->set_level(spdlog::level::info);
    spdlog::set_default_logger(logger);
  }
  void TearDown() override {
    spdlog::set_default_logger(previous_);
    fs::remove_all(dir_);
  }
  // What a renewal script does: both files replaced.
  void Serve(const CertFiles& pair) {
    fs::copy_file(pair.cert, cert(), fs::copy_options::overwrite_existing);
    fs::copy_file(pair.key, key(), fs::copy_options::overwrite_existing);
  }
  fs::path cert() const { return dir_ / "served.crt"; }
  fs::path key() const { return dir_ / "served.key"; }
  ServerTlsOptions Options() const {
    return {.cert_file = cert().string(), .key_file = key().string(), .reload_seconds = 1};
  }
  std::vector<std::string> TakeLines() {
    std::vector<std::string> lines = sink_->last_formatted();
    sink_ = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64);
    spdlog::default_logger()->sinks() = {sink_};
    return lines;
  }
  static int Count(const std::vector<std::string>& lines, const std::string& needle) {
    int n = 0;
    for (const auto& l : lines) n += l.find(needle) != std::string::npos;
    return n;
  }

  fs::path dir_;
  CertFiles ca_, first_, renewed_, expired_;
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_;
  std::shared_ptr<spdlog::logger> previous_;
  std::atomic<int64_t> now_{0};
};

TEST_F(TlsFileMonitorTest, ARenewalIsLoggedWithItsExpiryAndReported) {
  now_ = ::time(nullptr);
  std::vector<int64_t> expiries;
  TlsFileMonitor monitor(Options(), [this] { return now_.load(); }, [&](int64_t t) { expiries.push_back(t); });
  ASSERT_EQ(expiries.size(), 1u);
  EXPECT_GT(expiries[0], now_ + kDay);
  EXPECT_LT(expiries[0], now_ + 3 * kDay);
  EXPECT_TRUE(monitor.CheckNow().ok());
  EXPECT_TRUE(TakeLines().empty()) << "nothing changed, nothing said";

  Serve(renewed_);
  EXPECT_TRUE(monitor.CheckNow().ok());
  const auto lines = TakeLines();
  EXPECT_EQ(Count(lines, "event=tls_reloaded"), 1);
  EXPECT_EQ(Count(lines, cert().string()), 1);
  ASSERT_EQ(expiries.size(), 2u);
  EXPECT_GT(expiries[1], now_ + 80 * kDay);
}

TEST_F(TlsFileMonitorTest, UnusableFilesAreOneErrorNamingTheFlagAndZeroForTheExpiryGauge) {
  now_ = ::time(nullptr);
  std::vector<int64_t> expiries;
  TlsFileMonitor monitor(Options(), [this] { return now_.load(); }, [&](int64_t t) { expiries.push_back(t); });

  // Half a renewal: a new certificate beside the old key.
  fs::copy_file(renewed_.cert, cert(), fs::copy_options::overwrite_existing);
  absl::Status half = monitor.CheckNow();
  EXPECT_EQ(half.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(half.message().find("--tls-key"), std::string::npos) << half;
  auto lines = TakeLines();
  EXPECT_EQ(Count(lines, "event=tls_files_refused"), 1);
  EXPECT_EQ(Count(lines, "--tls-key"), 1);
  EXPECT_EQ(Count(lines, key().string()), 1) << "names the files, not only the flags";
  ASSERT_EQ(expiries.size(), 2u);
  EXPECT_EQ(expiries[1], 0) << "no usable certificate: gRPC's handshakes fail";
  // Still wrong on the next tick: no second line.
  EXPECT_FALSE(monitor.CheckNow().ok());
  EXPECT_TRUE(TakeLines().empty());

  // Garbage in the certificate file.
  std::ofstream(cert()) << "not a certificate\n";
  absl::Status garbage = monitor.CheckNow();
  EXPECT_NE(garbage.message().find("--tls-cert"), std::string::npos) << garbage;
  EXPECT_NE(garbage.message().find(cert().string()), std::string::npos) << garbage;
  EXPECT_EQ(Count(TakeLines(), "event=tls_files_refused"), 1);
  EXPECT_EQ(expiries.back(), 0) << "still none";

  // The key goes too: then both match again and are taken.
  Serve(renewed_);
  EXPECT_TRUE(monitor.CheckNow().ok());
  EXPECT_EQ(Count(TakeLines(), "event=tls_reloaded"), 1);
  EXPECT_GT(expiries.back(), now_ + 80 * kDay);
}

TEST_F(TlsFileMonitorTest, AnExpiredCertificateIsReportedOnceWhetherSwappedInOrRunOutWhileServed) {
  now_ = ::time(nullptr);
  TlsFileMonitor monitor(Options(), [this] { return now_.load(); }, nullptr);

  // An expired pair swapped in: gRPC serves it, every client refuses it.
  Serve(expired_);
  absl::Status swapped = monitor.CheckNow();
  EXPECT_EQ(swapped.code(), absl::StatusCode::kFailedPrecondition) << swapped;
  auto lines = TakeLines();
  EXPECT_EQ(Count(lines, "event=tls_cert_expired"), 1);
  EXPECT_EQ(Count(lines, "event=tls_reloaded"), 0) << "one line: expired, not a reload as well";
  EXPECT_FALSE(monitor.CheckNow().ok());
  EXPECT_TRUE(TakeLines().empty()) << "once";

  // A good pair; then time passes it by while it is served.
  Serve(first_);
  EXPECT_TRUE(monitor.CheckNow().ok());
  TakeLines();
  now_ += 3 * kDay;
  EXPECT_EQ(monitor.CheckNow().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(Count(TakeLines(), "event=tls_cert_expired"), 1);
}

TEST_F(TlsFileMonitorTest, FewerThanThirtyDaysLeftIsAWarningOnceADay) {
  now_ = ::time(nullptr);
  TlsFileMonitor monitor(Options(), [this] { return now_.load(); }, nullptr);
  // Served: 2 days left. The start's line (LogServerTls) counts for today.
  EXPECT_TRUE(monitor.CheckNow().ok());
  EXPECT_TRUE(TakeLines().empty());
  now_ += kDay / 2;
  EXPECT_TRUE(monitor.CheckNow().ok());
  EXPECT_TRUE(TakeLines().empty());
  now_ += kDay / 2 + 1;
  EXPECT_TRUE(monitor.CheckNow().ok());
  EXPECT_EQ(Count(TakeLines(), "event=tls_cert_expiring_soon"), 1);
}

}  // namespace
}  // namespace impostor
