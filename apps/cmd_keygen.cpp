// SPDX-License-Identifier: BSD-3-Clause
// `commerge keygen`: a new team key file for the daemons' --auth-key (message MACs, platform/lcm/message_auth).
// The file is created with mode 0600 and never overwritten. Key rotation: give the new key another --id, append
// its line to every board's key file (accepted, not yet signing), then move it to the first line (signing), then
// delete the old line (apps/README.md, "Key file and rotation").
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "platform/lcm/message_auth.hpp"

namespace commerge::app {

namespace {

struct KeygenOptions {
  std::string out;
  int id = 1;
};

int RunKeygen(const KeygenOptions& o) {
  auto key = platform::GenerateTeamKey(static_cast<std::uint8_t>(o.id));
  if (!key.ok()) {
    std::fprintf(stderr, "commerge keygen: %s\n", key.status().message().c_str());
    return kExitFailure;
  }
  const std::string text = "# commerge team key (keep secret; mode 0600). First key signs, every key verifies.\n" +
                           platform::FormatTeamKey(*key);
  if (Status st = platform::WriteNewKeyFile(o.out, text); !st.ok()) {
    std::fprintf(stderr, "commerge keygen: %s\n", st.message().c_str());
    return kExitFailure;
  }
  std::printf("wrote team key id %d to %s (mode 0600); copy it to every robot and the server, e.g. "
              "/etc/commerge/team.key\n", o.id, o.out.c_str());
  return kExitOk;
}

}  // namespace

Command AddKeygenCommand(CLI::App& root) {
  auto o = std::make_shared<KeygenOptions>();
  CLI::App* cmd = root.add_subcommand("keygen", "create a team key file for --auth-key (messages signed and verified "
                                                "with it; mode 0600, never overwritten)");
  cmd->add_option("--out", o->out, "the key file to create")->required();
  cmd->add_option("--id", o->id, "key id (0..255): a rotated key needs an id of its own")
      ->check(CLI::Range(0, 255))
      ->capture_default_str();
  return {cmd, [o]() { return RunKeygen(*o); }};
}

}  // namespace commerge::app
