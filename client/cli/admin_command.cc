// impostor admin purge --worker NAME: AdminService.PurgeWorkerResults (issue
// 14), the answer to a compromised worker. Administration is not part of the
// SDK (games and pipelines never need it), so this talks to the transport.
#include <cstdio>
#include <string>

#include "client/cli/commands.h"
#include "client/cli/connection_options.h"
#include "client/cli/output.h"
#include "client/transport/transport.h"
#include "common/util/log_escape.h"

namespace impostor::cli {

int RunAdminPurge(const CliArgs& args) {
  // --json: every key of the answer (null: not known) and exit_code.
  auto fail = [&](int code, const std::string& reason) {
    if (args.json) PrintJson(PurgeErrorJson(args.worker, reason, code));
    return Fail(code, reason);
  };
  auto transport = sdk::Transport::Connect(ClientOptionsFor(args, kInteractiveOutageSeconds));
  if (!transport.ok()) return fail(kExitServer, Describe(transport.status()));
  v1::PurgeWorkerResultsRequest request;
  request.set_worker(args.worker);
  auto purged = (*transport)->PurgeWorkerResults(request);
  if (!purged.ok()) {
    // A worker name the server refuses, or a token that is not an admin's,
    // is the request's fault, like a bake it refuses as invalid; everything
    // else is the RPC's.
    return fail(IsRefusal(purged.status().code()) ? kExitBakeFailed : kExitServer, Describe(purged.status()));
  }
  if (args.json) {
    nlohmann::json keys = nlohmann::json::array();
    for (const std::string& key : purged->cache_keys()) keys.push_back(key);
    PrintJson({{"worker", args.worker},
               {"cache_keys", keys},
               {"blobs_removed", purged->blobs_removed()},
               {"bytes_freed", purged->bytes_freed()},
               {"blobs_kept", purged->blobs_kept()},
               {"error", nullptr}});
    return kExitOk;
  }
  for (const std::string& key : purged->cache_keys()) std::printf("%s\n", EscapeForTerminal(key, 128).c_str());
  std::fflush(stdout);
  std::fprintf(stderr,
               "impostor: dropped %d result(s) baked by '%s' (their keys bake again); removed %lld blob(s), %s; "
               "kept %lld still in use or within the eviction grace\n",
               purged->cache_keys_size(), EscapeForTerminal(args.worker, 128).c_str(),
               static_cast<long long>(purged->blobs_removed()), HumanBytes(purged->bytes_freed()).c_str(),
               static_cast<long long>(purged->blobs_kept()));
  return kExitOk;
}

}  // namespace impostor::cli
