#include "common/net/grpc_log.h"

#include <grpc/support/log.h>
#include <spdlog/spdlog.h>

#include <filesystem>

#include "common/util/log_escape.h"

namespace impostor {

void RouteGrpcLogsToSpdlog() {
  gpr_set_log_function([](gpr_log_func_args* args) {
    // The message may carry what a peer sent (a name, an address).
    const std::string message = EscapeUntrusted(args->message != nullptr ? args->message : "");
    const std::string where =
        std::filesystem::path(args->file != nullptr ? args->file : "").filename().string() + ":" +
        std::to_string(args->line);
    if (args->severity == GPR_LOG_SEVERITY_ERROR) {
      spdlog::warn("event=grpc_log at={} message=\"{}\"", where, message);
    } else {
      spdlog::debug("event=grpc_log at={} message=\"{}\"", where, message);
    }
  });
}

}  // namespace impostor
