// SPDX-License-Identifier: Apache-2.0
// The exit statuses of both programs, nearpoint and nearpointd: one table, so that the same kind
// of failure exits the same way whichever binary met it (a supervisor or a script tells "fix the
// configuration" from "retry later" by the number alone). Both binaries print kExitStatusHelp in
// their --help; README.md quotes it.
#pragma once

namespace nearpoint::model {

/// Success; for nearpointd, a graceful shutdown on SIGTERM or SIGINT.
inline constexpr int kExitOk = 0;
/// A failure at run time: the server answered with an error (nearpoint prints its message and
/// the field it names), or nearpointd failed after it had started.
inline constexpr int kExitFailure = 1;
/// Bad command line, configuration or input: an unknown flag or value, a missing, unreadable or
/// malformed file (scene, trajectory, TLS, token), a DDS configuration that is not there. The
/// same input fails the same way again; fix it, do not retry.
inline constexpr int kExitUsage = 2;
/// Something the command needs is unavailable: no server answers (UNAVAILABLE,
/// DEADLINE_EXCEEDED), nearpointd could not be started, an address or port cannot be bound, DDS
/// cannot start. Retrying later may succeed.
inline constexpr int kExitUnavailable = 3;

/// The table as both binaries' --help footers print it.
inline constexpr const char* kExitStatusHelp =
    "Exit status (nearpoint and nearpointd alike): 0 success (nearpointd: stopped by SIGTERM or\n"
    "SIGINT); 1 failure at run time (the server answered with an error); 2 bad command line,\n"
    "configuration or input file (missing or malformed alike); 3 unavailable (no server answers,\n"
    "an address or port cannot be bound, DDS cannot start).\n";

}  // namespace nearpoint::model
