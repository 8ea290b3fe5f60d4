// Checks a daemon's command line against its Abseil flags before
// absl::ParseCommandLine sees it, so that a flag it cannot parse is a usage
// error like every other refused flag (exit 2, one line naming the flag)
// rather than Abseil's exit 1. Exit 1 matters for the daemons: systemd
// restarts on it (the units keep RestartPreventExitStatus=2 4) and the
// local-worker supervisor respawns it, so a typo would loop forever.
// Debian 12's Abseil (20220623) has no parser that returns instead of
// exiting, hence this small re-implementation of its argument rules:
//   --name=value and -name=value; --name value for non-boolean flags;
//   --flag / --noflag for booleans (no value after "=" in either form);
//   a bare "--" ends the flags; anything not starting with "-" is positional.
// Names are matched as given: run UnderscoreFlagNames (flag_names.h) first.
// Abseil's own flag-file flags (--flagfile, --fromenv, --tryfromenv,
// --undefok) and usage flags (--only_check_args, --helpon=...) are left to
// Abseil.
#ifndef IMPOSTOR_COMMON_FLAGS_FLAG_PRECHECK_H_
#define IMPOSTOR_COMMON_FLAGS_FLAG_PRECHECK_H_

#include "absl/status/status.h"

namespace impostor {

// OK, or INVALID_ARGUMENT naming the first flag Abseil would refuse and why
// ("unknown flag --x", "--x needs a value", "--x: <Abseil's reason>").
// Validating a value sets the flag to it; ParseCommandLine sets it again.
absl::Status PrecheckFlags(int argc, char** argv);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_FLAGS_FLAG_PRECHECK_H_
