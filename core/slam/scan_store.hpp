// SPDX-License-Identifier: BSD-3-Clause
// commerge: the robot's fixed-size store of encoded keyframe scans (core/cloud/scan_codec.hpp), kept so the
// server can later ask for a few of them by keyframe index.
//
// Memory: one record block of `capacity_bytes` and one index of `max_scans` entries, both allocated in
// Create() (start-up). On success Put/View/Contains never allocate (a sink may, in Spill); CopyEncoded and
// GetPoints allocate only when the caller's vector is too small (or the sink does, in Load). Error paths
// allocate their message.
//
// Record block: a FIFO ring of contiguous records, oldest first, each
//   [keyframe_index u32 LE][encoded_bytes u32 LE][encoded scan: encoded_bytes bytes]
// A record never wraps around the end of the block: when it does not fit between the newest record and
// the end, it goes to offset 0 and the tail gap stays unused until the ring passes it. Hence
//   used_bytes (live records incl. their 8-byte headers) <= capacity_bytes, and after a Put that evicted
//   for space, used_bytes > capacity_bytes - 2 * (largest record): at most one tail gap and one partly
//   freed record are unused.
// Index: a ring of (keyframe index, offset, size) entries in the same FIFO order; keyframe indices increase
// strictly, so lookups are a binary search.
//
// Full store (the new record does not fit in free space, or max_scans scans are held), per policy:
//   kRefuseNew   Put returns ResourceExhausted and the store is unchanged (num_refused + 1).
//   kEvictOldest the oldest scans are dropped, in order, until the new one fits (num_evicted + 1 each).
//                Looking up a dropped index gives NotFound saying it was evicted.
//   kSpillOldest as kEvictOldest, but each dropped record is first handed to the ScanSpillSink (num_spilled
//                + 1 each); CopyEncoded/GetPoints fetch spilled scans back from the sink. When the sink fails,
//                that scan is lost (num_evicted + 1), the new scan is still stored, and Put reports the sink
//                error in ScanPutInfo::spill_status.
// In every policy a scan whose record is larger than the whole block is refused (ResourceExhausted,
// num_refused + 1), and a keyframe index not greater than the newest stored one is an invalid argument.
// Not thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/cloud/scan_codec.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/memory/budget.hpp"

namespace commerge {

/// Where the scans dropped from a full store go.
class ScanSpillSink {
 public:
  virtual ~ScanSpillSink() = default;
  /// Keeps a copy of one encoded scan that the store is about to drop. The store calls it in increasing
  /// keyframe order. A non-OK status means the sink did not keep it (the store then counts the scan as lost).
  virtual Status Spill(std::uint32_t keyframe_index, Span<const std::uint8_t> encoded) = 0;
  /// Replaces `*encoded` with the bytes spilled for `keyframe_index`; NotFound when the sink has none.
  virtual Status Load(std::uint32_t keyframe_index, std::vector<std::uint8_t>* encoded) = 0;
};

/// What a full store does with a new scan (see the file comment).
enum class ScanStorePolicy { kRefuseNew, kEvictOldest, kSpillOldest };

/// "refuse-new", "evict-oldest", "spill-oldest".
const char* ScanStorePolicyName(ScanStorePolicy policy) noexcept;
/// Parses the names above; the error lists them.
Result<ScanStorePolicy> ParseScanStorePolicy(const std::string& name);

struct ScanStoreParams {
  /// Bytes of the record block: encoded scans plus kRecordHeaderBytes each. >= kMinRecordBytes.
  std::size_t capacity_bytes = 0;
  /// Index entries = most scans held at once (kIndexEntryBytes each). >= 1.
  std::size_t max_scans = 0;
  ScanStorePolicy policy = ScanStorePolicy::kEvictOldest;
  /// Zero the record block at creation, so its pages are resident from the start: a daemon on a board that
  /// cannot hold its store fails at start-up, not mid-mission. `commerge run` sizes the store for the largest
  /// scans its datasets can make and leaves the pages to the scans that fill them (false).
  bool touch_at_start = true;
};

/// Counters; all byte figures refer to the record block.
struct ScanStoreStats {
  std::size_t capacity_bytes = 0;
  std::size_t used_bytes = 0;        ///< live records incl. their headers
  std::size_t high_water_bytes = 0;  ///< largest used_bytes ever
  std::size_t num_scans = 0;         ///< resident scans
  std::size_t max_scans = 0;
  std::uint64_t num_stored = 0;   ///< Put calls that stored their scan
  std::uint64_t num_evicted = 0;  ///< scans dropped for good (kEvictOldest, or a failed spill)
  std::uint64_t num_refused = 0;  ///< Put calls refused for space (full under kRefuseNew, or larger than the block)
  std::uint64_t num_spilled = 0;  ///< scans handed to the sink successfully
};

/// Result of a successful Put.
struct ScanPutInfo {
  std::size_t record_bytes = 0;  ///< bytes the scan takes in the block (encoded + header)
  std::size_t num_evicted = 0;   ///< scans this Put dropped for good
  std::size_t num_spilled = 0;   ///< scans this Put handed to the sink
  Status spill_status;           ///< first sink error of this Put; OK when none (the new scan is stored anyway)
};

class ScanStore {
 public:
  static constexpr std::size_t kRecordHeaderBytes = 8;  ///< keyframe index u32 + size u32
  /// Smallest record: an empty scan.
  static constexpr std::size_t kMinRecordBytes = kRecordHeaderBytes + EncodedScanBytes(0);
  /// Bytes of one index entry.
  static constexpr std::size_t kIndexEntryBytes = 16;

  /// Bytes a store with these parameters reserves: record block + index.
  static constexpr std::size_t ReservedBytes(const ScanStoreParams& params) noexcept {
    return params.capacity_bytes + params.max_scans * kIndexEntryBytes;
  }

  /// Validates `params` and allocates the block and the index (the only allocations of the store).
  /// `sink` is required for kSpillOldest (ignored otherwise); it is not owned and must outlive the store.
  /// Errors: invalid argument (capacity below kMinRecordBytes, max_scans 0, spill without sink, sizes that
  /// overflow), resource exhausted (the allocation failed).
  static Result<std::unique_ptr<ScanStore>> Create(const ScanStoreParams& params, ScanSpillSink* sink = nullptr);

  ScanStore(const ScanStore&) = delete;
  ScanStore& operator=(const ScanStore&) = delete;
  ~ScanStore();

  /// Stores a copy of `encoded` (an encoded scan, header checked but not its CRC) for `keyframe_index`, which
  /// must be greater than every keyframe index stored before. Applies the policy when the store is full.
  /// Errors leave the stored scans unchanged: invalid argument (index not increasing, malformed scan, > 4 GiB),
  /// resource exhausted (larger than the whole block; or full under kRefuseNew).
  Result<ScanPutInfo> Put(std::uint32_t keyframe_index, Span<const std::uint8_t> encoded);

  /// True when the scan of `keyframe_index` is in the block.
  bool Contains(std::uint32_t keyframe_index) const noexcept;

  /// The encoded bytes of a resident scan, without copying; valid until the next Put(). NotFound otherwise,
  /// saying whether it was evicted, spilled (use CopyEncoded) or never stored.
  Result<Span<const std::uint8_t>> View(std::uint32_t keyframe_index) const;

  /// Replaces `*out` with the encoded scan: from the block, or (kSpillOldest) loaded from the sink and verified
  /// (CRC). Allocates only when `out` is too small. NotFound as View(); data loss for a corrupt spilled scan.
  Status CopyEncoded(std::uint32_t keyframe_index, std::vector<std::uint8_t>* out) const;

  /// Decodes the scan into `*points` (see DecodeScan). A spilled scan is loaded into `*spill_buffer` first,
  /// which must then be non-null. Returns the number of points.
  Result<std::size_t> GetPoints(std::uint32_t keyframe_index, std::vector<PointXYZI>* points,
                                std::vector<std::uint8_t>* spill_buffer = nullptr) const;

  /// Resident scans, oldest first: KeyframeAt(0) is the oldest. Precondition: i < num_scans().
  std::uint32_t KeyframeAt(std::size_t i) const noexcept;
  std::size_t num_scans() const noexcept { return count_; }
  ScanStorePolicy policy() const noexcept { return policy_; }
  ScanStoreStats stats() const noexcept;
  /// ReservedBytes(params) of this store.
  std::size_t reserved_bytes() const noexcept { return capacity_ + max_scans_ * kIndexEntryBytes; }

 private:
  struct Entry {
    std::uint32_t keyframe_index;
    std::uint32_t encoded_bytes;
    std::size_t offset;  // of the record header in the block
  };
  static_assert(sizeof(Entry) <= kIndexEntryBytes, "index entry larger than budgeted");
  static constexpr std::size_t kNoFit = static_cast<std::size_t>(-1);

  ScanStore(const ScanStoreParams& params, ScanSpillSink* sink, std::unique_ptr<std::uint8_t[]> block,
            std::unique_ptr<Entry[]> entries) noexcept;

  const Entry& At(std::size_t i) const noexcept { return entries_[(first_ + i) % max_scans_]; }
  /// Logical position of `keyframe_index` among the resident scans, or count_ when absent.
  std::size_t Find(std::uint32_t keyframe_index) const noexcept;
  /// Offset where `record_bytes` fit without touching live records, or kNoFit.
  std::size_t FindSpace(std::size_t record_bytes) const noexcept;
  /// Drops the oldest scan (spilling it under kSpillOldest); records a sink error in `*info`.
  void DropOldest(ScanPutInfo* info);
  Status NotResident(std::uint32_t keyframe_index) const;
  bool MaybeSpilled(std::uint32_t keyframe_index) const noexcept;
  Span<const std::uint8_t> Payload(const Entry& e) const noexcept {
    return Span<const std::uint8_t>(block_.get() + e.offset + kRecordHeaderBytes, e.encoded_bytes);
  }

  std::size_t capacity_ = 0;
  std::size_t max_scans_ = 0;
  ScanStorePolicy policy_ = ScanStorePolicy::kEvictOldest;
  ScanSpillSink* sink_ = nullptr;
  std::unique_ptr<std::uint8_t[]> block_;
  std::unique_ptr<Entry[]> entries_;
  std::size_t first_ = 0;  // ring position of the oldest entry
  std::size_t count_ = 0;
  std::size_t tail_ = 0;  // end offset of the newest record (kept when the store empties)
  std::size_t used_ = 0;
  std::size_t high_water_ = 0;
  bool any_stored_ = false;
  std::uint32_t first_stored_ = 0;  // keyframe index of the first scan ever stored
  std::uint32_t newest_stored_ = 0;
  bool any_dropped_ = false;
  std::uint32_t newest_dropped_ = 0;  // keyframe index of the most recently dropped (evicted/spilled) scan
  std::uint64_t num_stored_ = 0;
  std::uint64_t num_evicted_ = 0;
  std::uint64_t num_refused_ = 0;
  std::uint64_t num_spilled_ = 0;
};

/// Parameters that keep the whole store (record block + index) within the robot's scan_store budget:
/// max_scans = config.max_keyframes_per_robot, capacity_bytes = scan_store_bytes - the index.
/// Errors (invalid argument, naming the figures): the block left cannot hold one scan of
/// max_points_per_stored_scan points.
Result<ScanStoreParams> ScanStoreParamsFromBudget(const MemoryConfig& config, ScanStorePolicy policy);

}  // namespace commerge
