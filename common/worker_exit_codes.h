// impostor-worker's exit statuses that its supervisors act on: the server's
// --local-workers (server/worker_supervisor.cc) and systemd
// (deploy/systemd/impostor-worker@.service, RestartPreventExitStatus).
#ifndef IMPOSTOR_COMMON_WORKER_EXIT_CODES_H_
#define IMPOSTOR_COMMON_WORKER_EXIT_CODES_H_

namespace impostor {

// A flag value out of range, a token file that cannot be read: restarting
// with the same command line cannot help.
inline constexpr int kWorkerExitUsage = 2;
// No usable Vulkan device.
inline constexpr int kWorkerExitNoDevice = 3;
// The server refused the worker's token (unknown, revoked, expired, not a
// worker's): restarting with the same token cannot help.
inline constexpr int kWorkerExitTokenRefused = 4;

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_WORKER_EXIT_CODES_H_
