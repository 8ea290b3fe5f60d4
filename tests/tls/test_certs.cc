#include "tests/tls/test_certs.h"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>

#include <gtest/gtest.h>

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

std::string Quote(const fs::path& path) { return "'" + path.string() + "'"; }

}  // namespace

TestPki::TestPki(fs::path dir) : dir_(std::move(dir)) { fs::create_directories(dir_); }

bool TestPki::Run(const std::string& command) {
  // stderr joins stdout so that a failure shows openssl's reason.
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) {
    ADD_FAILURE() << "cannot run: " << command;
    return false;
  }
  std::string output;
  std::array<char, 4096> buffer;
  while (size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe)) output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    ADD_FAILURE() << "openssl failed (status " << status << "): " << command << "\n" << output;
    return false;
  }
  return true;
}

CertFiles TestPki::MakeCa(const std::string& name) {
  CertFiles ca{dir_ / (name + ".crt"), dir_ / (name + ".key")};
  if (!Run("openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 2 -subj '/CN=" + name +
           "' -addext basicConstraints=critical,CA:TRUE -addext keyUsage=critical,keyCertSign,cRLSign -keyout " +
           Quote(ca.key) + " -out " + Quote(ca.cert))) {
    return {};
  }
  return ca;
}

CertFiles TestPki::MakeLeaf(const std::string& name, const CertFiles& ca, const std::string& extensions, int days) {
  CertFiles leaf{dir_ / (name + ".crt"), dir_ / (name + ".key")};
  const fs::path csr = dir_ / (name + ".csr");
  const fs::path ext = dir_ / (name + ".ext");
  std::ofstream(ext) << "basicConstraints=CA:FALSE\n" << extensions;
  if (!Run("openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj '/CN=" + name + "' -keyout " +
           Quote(leaf.key) + " -out " + Quote(csr)) ||
      !Run("openssl x509 -req -days " + std::to_string(days) + " -in " + Quote(csr) + " -CA " + Quote(ca.cert) + " -CAkey " + Quote(ca.key) +
           " -CAcreateserial -extfile " + Quote(ext) + " -out " + Quote(leaf.cert))) {
    return {};
  }
  return leaf;
}

CertFiles TestPki::MakeServerCert(const std::string& name, const CertFiles& ca, const std::string& san, int days) {
  return MakeLeaf(name, ca, "extendedKeyUsage=serverAuth\nsubjectAltName=" + san + "\n", days);
}

CertFiles TestPki::MakeClientCert(const std::string& name, const CertFiles& ca, int days) {
  return MakeLeaf(name, ca, "extendedKeyUsage=clientAuth\n", days);
}

}  // namespace impostor::testing
