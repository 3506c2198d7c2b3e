// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for one LCM decoder: the row of tests/fuzz/codec_table.hpp that CM_FUZZ_CODEC names (set per
// executable by tests/fuzz/CMakeLists.txt). Every input must be refused with DataLoss or decoded, never crash
// (ASan, UBSan) and never allocate beyond -malloc_limit_mb. Also checked, for every input:
//   * bounded decoding: no single allocation made while decoding exceeds kAmplification x the input size +
//     kSlackBytes (the decoders check every count against the buffer before anything is allocated);
//   * a decoded message re-encodes (the encoder accepts what the decoder accepts) and those bytes decode again;
//   * the decoded bytes without their last byte are refused (truncated), and so are they with one more byte
//     (trailing).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "tests/fuzz/codec_table.hpp"
#include "tests/fuzz/fuzz_support.hpp"

#ifndef CM_FUZZ_CODEC
#error "CM_FUZZ_CODEC must name a row of tests/fuzz/codec_table.hpp (tests/fuzz/CMakeLists.txt sets it)"
#endif

namespace commerge::fuzz {

// One struct per table row (a named namespace: the rows not selected are unused); CM_FUZZ_CODEC picks one.
namespace codecs {
#define CM_FUZZ_DEFINE_CODEC(name, MessageType, DecodeFn, EncodeFn, malloc_limit_mb)  \
  struct name {                                                                      \
    using Message = MessageType;                                                     \
    static constexpr const char* kName = #name;                                     \
    static Result<Message> Decode(Span<const std::uint8_t> bytes) {                  \
      return platform::DecodeFn(bytes);                                              \
    }                                                                                \
    static Status Encode(const Message& m, std::vector<std::uint8_t>* out) {         \
      return platform::EncodeFn(m, out);                                             \
    }                                                                                \
  };
CM_FUZZ_CODECS(CM_FUZZ_DEFINE_CODEC)
#undef CM_FUZZ_DEFINE_CODEC
}  // namespace codecs

namespace {

using Codec = codecs::CM_FUZZ_CODEC;

// The decoded structs hold at most ~4x their wire size in one block; 8x leaves room without letting a count the
// buffer cannot hold through. The compact pose list of pose_update_t is the exception: a pose of a straight
// stretch takes 9 bits on the wire (its decoder refuses a count the bytes cannot hold at that rate) and a
// 128-byte Eigen::Isometry3d in PoseUpdate::T_map_sensor, ~114x; 4096 poses announced in a 40-byte message would
// still be a 512 KiB block, far above 128x.
template <typename Message>
constexpr std::size_t kAmplificationOf = 8;
template <>
constexpr std::size_t kAmplificationOf<PoseUpdate> = 128;
constexpr std::size_t kAmplification = kAmplificationOf<codecs::CM_FUZZ_CODEC::Message>;
constexpr std::size_t kSlackBytes = 4096;

Result<Codec::Message> WatchedDecode(Span<const std::uint8_t> bytes) {
  static const bool hooked = AllocationWatch::Available();
  if (!hooked) Fail("%s: no sanitizer malloc hook: build with CM_FUZZ=ON", Codec::kName);
  AllocationWatch watch;
  Result<Codec::Message> m = Codec::Decode(bytes);
  const std::size_t bound = kAmplification * bytes.size() + kSlackBytes;
  if (watch.largest_bytes() > bound) {
    Fail("%s: decoding %zu bytes (%s) allocated one block of %zu bytes, above %zu x the input + %zu", Codec::kName,
         bytes.size(), m.ok() ? "accepted" : "refused", watch.largest_bytes(), kAmplification, kSlackBytes);
  }
  if (!m.ok() && (m.status().code() != StatusCode::kDataLoss || m.status().message().empty())) {
    Fail("%s: refused %zu bytes with '%s' (decoders refuse with a DataLoss that names the problem)", Codec::kName,
         bytes.size(), m.status().ToString().c_str());
  }
  return m;
}

}  // namespace
}  // namespace commerge::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace commerge;        // NOLINT(google-build-using-namespace): a fuzz entry point
  using namespace commerge::fuzz;  // NOLINT(google-build-using-namespace)
  const Span<const std::uint8_t> bytes(data, size);
  Result<Codec::Message> decoded = WatchedDecode(bytes);
  if (!decoded.ok()) return 0;

  // The wire rules are the same on both sides: what was accepted re-encodes, and that decodes again.
  std::vector<std::uint8_t> again;
  if (Status st = Codec::Encode(*decoded, &again); !st.ok()) {
    Fail("%s: a decoded message (%zu bytes) does not re-encode: %s", Codec::kName, size, st.ToString().c_str());
  }
  if (Result<Codec::Message> twice = WatchedDecode(Span<const std::uint8_t>(again)); !twice.ok()) {
    Fail("%s: the re-encoded message (%zu bytes) does not decode: %s", Codec::kName, again.size(),
         twice.status().ToString().c_str());
  }

  // Truncated or followed by a byte, the accepted message is refused.
  if (WatchedDecode(bytes.subspan(0, size - 1)).ok()) {
    Fail("%s: accepted %zu bytes and also their first %zu (a truncated message)", Codec::kName, size, size - 1);
  }
  std::vector<std::uint8_t> longer;
  longer.reserve(size + 1);  // exactly: a doubling push_back would be the largest block of the run
  longer.assign(data, data + size);
  longer.push_back(0);
  if (WatchedDecode(Span<const std::uint8_t>(longer)).ok()) {
    Fail("%s: accepted %zu bytes and also the same followed by a zero byte (trailing bytes)", Codec::kName, size);
  }
  return 0;
}
