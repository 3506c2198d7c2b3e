// SPDX-License-Identifier: BSD-3-Clause
#include "apps/app_auth.hpp"

#include <algorithm>
#include <cstdio>
#include <optional>

#include "core/common/bytes.hpp"

namespace commerge::app {

void AddAuthFlags(CLI::App* cmd, AuthFlags* flags) {
  cmd->add_option("--auth-key", flags->key_file,
                  "team key file (mode 0600, from `commerge keygen`): every message is signed and every received one "
                  "verified; without it nothing is authenticated")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--check", flags->check,
                "check the flags, the key file and the memory budget, print the configuration and exit (0 = it would "
                "start) without touching the network");
}

int SetUpAuth(const char* tag, const AuthFlags& flags, std::uint16_t sender, std::int64_t session, int robots,
              platform::LcmBusParams* bus) {
  bus->authenticate = false;
  if (flags.key_file.empty()) return kExitOk;
  auto ring = platform::LoadTeamKeyring(flags.key_file);
  if (!ring.ok()) {
    std::fprintf(stderr, "%s: --auth-key: %s\n", tag, ring.status().message().c_str());
    return kExitUsage;
  }
  bus->authenticate = true;
  bus->auth.keyring = std::move(*ring);
  bus->auth.sender = sender;
  bus->auth.session = session;
  bus->auth.max_robots = static_cast<std::uint16_t>(std::clamp(robots, 1, int{platform::kAuthMaxRobots}));
  if (auto check = platform::MessageAuthenticator::Create(bus->auth); !check.ok()) {
    std::fprintf(stderr, "%s: --auth-key %s: %s\n", tag, flags.key_file.c_str(), check.status().message().c_str());
    return kExitUsage;
  }
  return kExitOk;
}

std::string AuthDescription(const AuthFlags& flags, const platform::LcmBusParams& bus) {
  if (!bus.authenticate) {
    return "WARNING: messages are NOT authenticated (no --auth-key): anyone on the network can publish on the "
           "commerge channels";
  }
  return "messages signed with key id " + std::to_string(bus.auth.keyring.keys.front().id) + " (" +
         std::to_string(bus.auth.keyring.keys.size()) + " key(s) accepted) from " + flags.key_file;
}

Status CheckSigner(const platform::BusMessage& message, int expected) {
  if (message.sender < 0 || message.sender == expected) return Status::Ok();
  auto name = [](int id) {
    return id == platform::kAuthServerSender ? std::string("the server") : "robot " + std::to_string(id);
  };
  return InvalidArgument("signed by " + name(message.sender) + " but speaks for " + name(expected));
}

std::uint64_t AuthRejected(const platform::LcmBus& bus) {
  const std::optional<platform::AuthStats> a = bus.auth_stats();
  return a ? a->rejected() : 0;
}

std::string AuthSummary(const platform::LcmBus& bus) {
  const std::optional<platform::AuthStats> a = bus.auth_stats();
  if (!a) return "auth: off";
  const std::uint64_t published_bytes = bus.stats().published_bytes;
  const double sent = static_cast<double>(published_bytes);
  char head[256];
  std::snprintf(head, sizeof(head), "auth: %llu messages signed, %zu B each = %s (%.1f %% of %s sent); %llu refused",
                static_cast<unsigned long long>(a->signed_messages), platform::kAuthTrailerBytes,
                FormatBytes(static_cast<std::int64_t>(a->trailer_bytes)).c_str(),
                sent > 0 ? 100.0 * static_cast<double>(a->trailer_bytes) / sent : 0.0,
                FormatBytes(static_cast<std::int64_t>(published_bytes)).c_str(), static_cast<unsigned long long>(a->rejected()));
  std::string out = head;
  std::string detail;
  for (std::size_t v = 0; v < platform::kAuthVerdictCount; ++v) {
    const auto verdict = static_cast<platform::AuthVerdict>(v);
    if (verdict == platform::AuthVerdict::kOk || verdict == platform::AuthVerdict::kOwnEcho || a->verdicts[v] == 0) {
      continue;
    }
    detail += (detail.empty() ? "" : ", ") + std::string(platform::AuthVerdictName(verdict)) + " " +
              std::to_string(a->verdicts[v]);
  }
  if (!detail.empty()) out += " (" + detail + ")";
  return out;
}

}  // namespace commerge::app
