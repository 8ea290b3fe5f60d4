#include "client/transport/rpc_error.h"

#include <optional>

#include "absl/strings/cord.h"
#include "impostor/client.h"

namespace impostor::sdk {
namespace {

// Payload type URLs; private to this file, read back by GetRpcErrorInfo.
constexpr char kRpcKey[] = "type.impostor.dev/client.rpc";
constexpr char kServerKey[] = "type.impostor.dev/client.server";
constexpr char kServerMessageKey[] = "type.impostor.dev/client.server_message";
constexpr char kReasonKey[] = "type.impostor.dev/client.reason";

}  // namespace

absl::Status MakeRpcError(absl::StatusCode code, std::string_view rpc, std::string_view server,
                          std::string_view server_message, std::string_view reason) {
  std::string message = std::string(rpc) + " (server " + std::string(server) + "): ";
  message += server_message.empty() ? std::string("no message") : std::string(server_message);
  absl::Status status(code, message);
  status.SetPayload(kRpcKey, absl::Cord(std::string(rpc)));
  status.SetPayload(kServerKey, absl::Cord(std::string(server)));
  status.SetPayload(kServerMessageKey, absl::Cord(std::string(server_message)));
  if (!reason.empty()) status.SetPayload(kReasonKey, absl::Cord(std::string(reason)));
  return status;
}

std::optional<RpcErrorInfo> GetRpcErrorInfo(const absl::Status& status) {
  auto rpc = status.GetPayload(kRpcKey);  // absl::optional in Debian's abseil
  if (status.ok() || !rpc.has_value()) return std::nullopt;
  RpcErrorInfo info;
  info.rpc = std::string(*rpc);
  if (auto server = status.GetPayload(kServerKey)) info.server = std::string(*server);
  if (auto msg = status.GetPayload(kServerMessageKey)) info.server_message = std::string(*msg);
  if (auto reason = status.GetPayload(kReasonKey)) info.reason = std::string(*reason);
  return info;
}

}  // namespace impostor::sdk
