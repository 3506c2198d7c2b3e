// SPDX-License-Identifier: BSD-3-Clause
// Message authentication of the daemons (robot, server): the --auth-key and --check flags, loading the team key
// into the bus, the signer check and the summaries.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

#include "apps/app_common.hpp"
#include "core/common/status.hpp"
#include "platform/lcm/lcm_bus.hpp"

namespace commerge::app {

/// The daemons' message authentication and dry-run flags: --auth-key FILE (the team key file; without it,
/// messages are neither signed nor verified, and a warning says so) and --check.
struct AuthFlags {
  std::string key_file;
  bool check = false;  ///< validate everything, print the configuration, exit 0 without opening the network
};
void AddAuthFlags(CLI::App* cmd, AuthFlags* flags);

/// Loads --auth-key into `bus` (sender = robot id or platform::kAuthServerSender, session, robot ids
/// 0..robots-1 accepted). Returns kExitOk, or kExitUsage with the reason (naming the file) on stderr.
int SetUpAuth(const char* tag, const AuthFlags& flags, std::uint16_t sender, std::int64_t session, int robots,
              platform::LcmBusParams* bus);
/// One line for --check and the start-up banner: "messages signed with key 1 of 2 from FILE" or the warning.
std::string AuthDescription(const AuthFlags& flags, const platform::LcmBusParams& bus);
/// Refuses a message whose authenticated signer is not `expected` (a robot id, or kAuthServerSender): a team
/// member speaking for another. Unauthenticated messages (sender -1) pass.
Status CheckSigner(const platform::BusMessage& message, int expected);
/// Messages the bus refused for authentication (0 without authentication).
std::uint64_t AuthRejected(const platform::LcmBus& bus);
/// "auth: 1234 messages signed, 40 B each = 48.2 KiB (3.1 % of 1.5 MiB sent); 7 refused (bad MAC 3, replayed 4)"
/// or "auth: off".
std::string AuthSummary(const platform::LcmBus& bus);

}  // namespace commerge::app
