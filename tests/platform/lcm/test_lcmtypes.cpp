// SPDX-License-Identifier: BSD-3-Clause
// The generated message code links and round-trips on this architecture (host and aarch64 under qemu).
#include <doctest/doctest.h>

#include <lcm/lcm-cpp.hpp>

#include <commerge/robot_status_t.hpp>

#include <vector>

#include "tests/platform/lcm/lcm_test_util.hpp"

namespace {

using commerge::platform::SampleRobotStatusT;

struct Receiver {
  int received = 0;
  int undecodable = 0;
  commerge::robot_status_t last;
};

// Raw-buffer subscription, decoded by us: the way commerge receives (bounded decode, counted rejects).
void OnStatus(const lcm::ReceiveBuffer* rbuf, const std::string&, Receiver* rx) {
  if (rx->last.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
    ++rx->undecodable;
    return;
  }
  ++rx->received;
}

}  // namespace

TEST_CASE("robot_status_t encodes and decodes to the same values, and a truncated buffer is refused") {
  const commerge::robot_status_t s = SampleRobotStatusT();
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(s.getEncodedSize()));
  REQUIRE(s.encode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  commerge::robot_status_t d;
  REQUIRE(d.decode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  CHECK(d.utime == s.utime);
  CHECK(d.robot_id == 2);
  CHECK(d.module_name == s.module_name);
  CHECK(d.module_high_water_bytes == s.module_high_water_bytes);
  CHECK(d.session == s.session);
  CHECK(d.queued_chunks == 41);
  CHECK(d.bytes_resent == 4567);
  CHECK(d.state == "sending scans");
  commerge::robot_status_t t;
  CHECK(t.decode(buf.data(), 0, static_cast<int>(buf.size()) - 9) < 0);
  buf[0] ^= 0xFF;  // wrong fingerprint
  CHECK(t.decode(buf.data(), 0, static_cast<int>(buf.size())) < 0);
}

TEST_CASE("robot_status_t travels through LCM in process (memq://, no network)") {
  lcm::LCM lcm("memq://");
  REQUIRE(lcm.good());
  Receiver rx;
  lcm.subscribeFunction("COMMERGE_ROBOT_STATUS", &OnStatus, &rx);
  const commerge::robot_status_t s = SampleRobotStatusT();
  REQUIRE(lcm.publish("COMMERGE_ROBOT_STATUS", &s) == 0);
  while (lcm.handleTimeout(0) > 0) {
  }
  CHECK(rx.received == 1);
  CHECK(rx.undecodable == 0);
  CHECK(rx.last.module_used_bytes == s.module_used_bytes);
}
