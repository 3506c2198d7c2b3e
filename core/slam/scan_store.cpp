// SPDX-License-Identifier: BSD-3-Clause
// Scan store: a FIFO ring of contiguous records in one fixed block, plus a ring index (layout and policies in
// the header file).
#include "core/slam/scan_store.hpp"

#include <cstdint>
#include <cstring>
#include <new>
#include <string>
#include <utility>

#include "core/common/bytes.hpp"
#include "core/common/little_endian.hpp"

namespace commerge {
namespace {

std::string Bytes(std::size_t n) {
  return std::to_string(n) + " B" + (n >= 1024 ? " (" + FormatBytes(static_cast<std::int64_t>(n)) + ")" : "");
}
std::string Kf(std::uint32_t keyframe_index) { return "keyframe " + std::to_string(keyframe_index); }

}  // namespace

const char* ScanStorePolicyName(ScanStorePolicy policy) noexcept {
  switch (policy) {
    case ScanStorePolicy::kRefuseNew:
      return "refuse-new";
    case ScanStorePolicy::kEvictOldest:
      return "evict-oldest";
    case ScanStorePolicy::kSpillOldest:
      return "spill-oldest";
  }
  return "unknown";
}

Result<ScanStorePolicy> ParseScanStorePolicy(const std::string& name) {
  for (const ScanStorePolicy p :
       {ScanStorePolicy::kRefuseNew, ScanStorePolicy::kEvictOldest, ScanStorePolicy::kSpillOldest}) {
    if (name == ScanStorePolicyName(p)) return p;
  }
  return InvalidArgument("unknown scan store policy '" + name + "' (valid: refuse-new, evict-oldest, spill-oldest)");
}

Result<std::unique_ptr<ScanStore>> ScanStore::Create(const ScanStoreParams& params, ScanSpillSink* sink) {
  if (params.capacity_bytes < kMinRecordBytes) {
    return InvalidArgument("scan store capacity " + Bytes(params.capacity_bytes) + " is below the smallest record (" +
                           std::to_string(kMinRecordBytes) + " B: an empty scan)");
  }
  if (params.max_scans == 0) return InvalidArgument("scan store max_scans must be at least 1");
  if (params.max_scans > (SIZE_MAX - params.capacity_bytes) / kIndexEntryBytes) {
    return InvalidArgument("scan store size overflows: " + std::to_string(params.max_scans) + " index entries plus " +
                           Bytes(params.capacity_bytes));
  }
  if (params.policy == ScanStorePolicy::kSpillOldest && sink == nullptr) {
    return InvalidArgument("scan store policy spill-oldest needs a spill sink");
  }
  // value-initialised: the pages are touched now (start-up), not on the first Put that reaches them. Only the
  // bytes Put writes are ever read.
  std::unique_ptr<std::uint8_t[]> block(params.touch_at_start
                                            ? new (std::nothrow) std::uint8_t[params.capacity_bytes]()
                                            : new (std::nothrow) std::uint8_t[params.capacity_bytes]);
  std::unique_ptr<Entry[]> entries(new (std::nothrow) Entry[params.max_scans]());
  if (!block || !entries) {
    return ResourceExhausted("cannot allocate the scan store: " + Bytes(ReservedBytes(params)) + " (" +
                             std::to_string(params.max_scans) + " index entries)");
  }
  std::unique_ptr<ScanStore> store(new (std::nothrow) ScanStore(
      params, params.policy == ScanStorePolicy::kSpillOldest ? sink : nullptr, std::move(block), std::move(entries)));
  if (!store) return ResourceExhausted("cannot allocate the scan store object");
  return Result<std::unique_ptr<ScanStore>>(std::move(store));
}

ScanStore::ScanStore(const ScanStoreParams& params, ScanSpillSink* sink, std::unique_ptr<std::uint8_t[]> block,
                     std::unique_ptr<Entry[]> entries) noexcept
    : capacity_(params.capacity_bytes),
      max_scans_(params.max_scans),
      policy_(params.policy),
      sink_(sink),
      block_(std::move(block)),
      entries_(std::move(entries)) {}

ScanStore::~ScanStore() = default;

std::size_t ScanStore::Find(std::uint32_t keyframe_index) const noexcept {
  std::size_t lo = 0;
  std::size_t hi = count_;
  while (lo < hi) {
    const std::size_t mid = lo + (hi - lo) / 2;
    if (At(mid).keyframe_index < keyframe_index) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return (lo < count_ && At(lo).keyframe_index == keyframe_index) ? lo : count_;
}

std::size_t ScanStore::FindSpace(std::size_t record_bytes) const noexcept {
  if (count_ == 0) return tail_ + record_bytes <= capacity_ ? tail_ : 0;
  const std::size_t head = At(0).offset;
  if (At(count_ - 1).offset >= head) {  // live records = [head, tail_): free [tail_, end) and [0, head)
    if (capacity_ - tail_ >= record_bytes) return tail_;
    if (head >= record_bytes) return 0;
    return kNoFit;
  }
  // wrapped: live records = [head, end of the last record before the wrap) and [0, tail_); free [tail_, head)
  return head - tail_ >= record_bytes ? tail_ : kNoFit;
}

void ScanStore::DropOldest(ScanPutInfo* info) {
  const Entry e = At(0);
  if (policy_ == ScanStorePolicy::kSpillOldest) {
    const Status s = sink_->Spill(e.keyframe_index, Payload(e));
    if (s.ok()) {
      ++num_spilled_;
      ++info->num_spilled;
    } else {
      ++num_evicted_;
      ++info->num_evicted;
      if (info->spill_status.ok()) {
        info->spill_status =
            Status(s.code(), Kf(e.keyframe_index) + " was lost: the spill sink refused it: " + s.message());
      }
    }
  } else {
    ++num_evicted_;
    ++info->num_evicted;
  }
  first_ = (first_ + 1) % max_scans_;
  --count_;
  used_ -= kRecordHeaderBytes + e.encoded_bytes;
  any_dropped_ = true;
  newest_dropped_ = e.keyframe_index;
}

Result<ScanPutInfo> ScanStore::Put(std::uint32_t keyframe_index, Span<const std::uint8_t> encoded) {
  if (any_stored_ && keyframe_index <= newest_stored_) {
    return InvalidArgument(Kf(keyframe_index) + " is not newer than the newest stored scan (" + Kf(newest_stored_) +
                           "): keyframe indices must increase");
  }
  const Result<ScanHeader> header = ParseScanHeader(encoded);
  if (!header.ok()) {
    return InvalidArgument(Kf(keyframe_index) + ": not a valid encoded scan: " + header.status().message());
  }
  if (encoded.size() > UINT32_MAX) {
    return InvalidArgument(Kf(keyframe_index) + ": encoded scan of " + Bytes(encoded.size()) + " exceeds 4 GiB");
  }
  const auto addr = reinterpret_cast<std::uintptr_t>(encoded.data());
  const auto base = reinterpret_cast<std::uintptr_t>(block_.get());
  if (addr >= base && addr < base + capacity_) {
    return InvalidArgument(Kf(keyframe_index) + ": the scan to store lies inside this store (copy it out first)");
  }
  const std::size_t record_bytes = kRecordHeaderBytes + encoded.size();
  if (record_bytes > capacity_) {
    ++num_refused_;
    return ResourceExhausted(Kf(keyframe_index) + ": scan of " + std::to_string(header->num_points) + " points needs " +
                             Bytes(record_bytes) + " (with its " + std::to_string(kRecordHeaderBytes) +
                             " B record header), more than the whole scan store (" + Bytes(capacity_) +
                             "): raise the scan store budget or lower the points per stored scan");
  }

  ScanPutInfo info;
  info.record_bytes = record_bytes;
  std::size_t offset = count_ < max_scans_ ? FindSpace(record_bytes) : kNoFit;
  if (offset == kNoFit) {
    if (policy_ == ScanStorePolicy::kRefuseNew) {
      ++num_refused_;
      const bool index_full = count_ == max_scans_;
      return ResourceExhausted("scan store full (policy refuse-new): " + Kf(keyframe_index) + " needs " +
                               Bytes(record_bytes) + "; " +
                               (index_full ? "all " + std::to_string(max_scans_) + " index entries are taken"
                                           : Bytes(capacity_ - used_) + " of " + Bytes(capacity_) + " are free" +
                                                 (capacity_ - used_ >= record_bytes ? " but not in one piece" : "")) +
                               " (" + std::to_string(count_) + " scans, " + Kf(At(0).keyframe_index) + " to " +
                               std::to_string(newest_stored_) + ")");
    }
    do {
      DropOldest(&info);
      offset = count_ < max_scans_ ? FindSpace(record_bytes) : kNoFit;
    } while (offset == kNoFit);  // ends: an empty store always has room (record_bytes <= capacity_, max_scans_ >= 1)
  }

  std::uint8_t* dst = block_.get() + offset;
  PutU32Le(dst, keyframe_index);
  PutU32Le(dst + 4, static_cast<std::uint32_t>(encoded.size()));
  if (!encoded.empty()) std::memcpy(dst + kRecordHeaderBytes, encoded.data(), encoded.size());
  entries_[(first_ + count_) % max_scans_] = Entry{keyframe_index, static_cast<std::uint32_t>(encoded.size()), offset};
  ++count_;
  tail_ = offset + record_bytes;
  used_ += record_bytes;
  if (used_ > high_water_) high_water_ = used_;
  if (!any_stored_) first_stored_ = keyframe_index;
  any_stored_ = true;
  newest_stored_ = keyframe_index;
  ++num_stored_;
  return info;
}

bool ScanStore::Contains(std::uint32_t keyframe_index) const noexcept { return Find(keyframe_index) < count_; }

bool ScanStore::MaybeSpilled(std::uint32_t keyframe_index) const noexcept {
  return policy_ == ScanStorePolicy::kSpillOldest && any_dropped_ && keyframe_index >= first_stored_ &&
         keyframe_index <= newest_dropped_;
}

Status ScanStore::NotResident(std::uint32_t keyframe_index) const {
  const std::string k = Kf(keyframe_index);
  if (!any_stored_) return NotFound(k + " was never stored: no scan has been stored yet");
  if (keyframe_index > newest_stored_) {
    return NotFound(k + " was never stored (the newest scan is " + Kf(newest_stored_) + ")");
  }
  if (keyframe_index < first_stored_) {
    return NotFound(k + " was never stored (the first scan stored is " + Kf(first_stored_) + ")");
  }
  if (any_dropped_ && keyframe_index <= newest_dropped_) {
    const std::string kept =
        count_ > 0 ? "the store now keeps " + Kf(At(0).keyframe_index) + " to " + std::to_string(newest_stored_)
                   : "the store is empty";
    if (policy_ == ScanStorePolicy::kSpillOldest) {
      return NotFound(k + " was spilled out of the full scan store (" + kept +
                      "): fetch it with CopyEncoded() or GetPoints()");
    }
    return NotFound(k + " was evicted from the full scan store (policy " + ScanStorePolicyName(policy_) + ", " +
                    std::to_string(num_evicted_) + " scans evicted so far; " + kept + ")");
  }
  return NotFound(k + " was never stored (no scan with this index between " + Kf(first_stored_) + " and " +
                  std::to_string(newest_stored_) + "; it may have been refused)");
}

Result<Span<const std::uint8_t>> ScanStore::View(std::uint32_t keyframe_index) const {
  const std::size_t i = Find(keyframe_index);
  if (i == count_) return NotResident(keyframe_index);
  const Entry& e = At(i);
  const std::uint8_t* rec = block_.get() + e.offset;
  if (GetU32Le(rec) != e.keyframe_index || GetU32Le(rec + 4) != e.encoded_bytes) {
    return Status(StatusCode::kInternal, "scan store corrupt: the record of " + Kf(keyframe_index) + " at offset " +
                                             std::to_string(e.offset) + " does not match its index entry");
  }
  return Payload(e);
}

Status ScanStore::CopyEncoded(std::uint32_t keyframe_index, std::vector<std::uint8_t>* out) const {
  if (out == nullptr) return InvalidArgument("ScanStore::CopyEncoded: output vector is null");
  if (Find(keyframe_index) < count_) {
    const Result<Span<const std::uint8_t>> view = View(keyframe_index);
    if (!view.ok()) return view.status();
    out->assign(view->begin(), view->end());
    return Status::Ok();
  }
  out->clear();
  if (!MaybeSpilled(keyframe_index)) return NotResident(keyframe_index);
  const Status loaded = sink_->Load(keyframe_index, out);
  if (!loaded.ok()) {
    out->clear();
    return Status(loaded.code(), Kf(keyframe_index) + " was dropped from the full scan store and loading it from the " +
                                     "spill sink failed: " + loaded.message());
  }
  const Result<ScanHeader> verified = VerifyEncodedScan(Span<const std::uint8_t>(*out));
  if (!verified.ok()) {
    out->clear();
    return DataLoss(Kf(keyframe_index) +
                    " loaded from the spill sink is not a valid scan: " + verified.status().message());
  }
  return Status::Ok();
}

Result<std::size_t> ScanStore::GetPoints(std::uint32_t keyframe_index, std::vector<PointXYZI>* points,
                                         std::vector<std::uint8_t>* spill_buffer) const {
  if (points == nullptr) return InvalidArgument("ScanStore::GetPoints: output vector is null");
  if (Find(keyframe_index) < count_) {
    const Result<Span<const std::uint8_t>> view = View(keyframe_index);
    if (!view.ok()) {
      points->clear();
      return view.status();
    }
    return DecodeScan(*view, points);
  }
  points->clear();
  if (!MaybeSpilled(keyframe_index)) return NotResident(keyframe_index);
  if (spill_buffer == nullptr) {
    return InvalidArgument(Kf(keyframe_index) + " was spilled: GetPoints needs a spill buffer to load it into");
  }
  const Status copied = CopyEncoded(keyframe_index, spill_buffer);
  if (!copied.ok()) return copied;
  return DecodeScan(Span<const std::uint8_t>(*spill_buffer), points);
}

std::uint32_t ScanStore::KeyframeAt(std::size_t i) const noexcept { return At(i).keyframe_index; }

ScanStoreStats ScanStore::stats() const noexcept {
  ScanStoreStats s;
  s.capacity_bytes = capacity_;
  s.used_bytes = used_;
  s.high_water_bytes = high_water_;
  s.num_scans = count_;
  s.max_scans = max_scans_;
  s.num_stored = num_stored_;
  s.num_evicted = num_evicted_;
  s.num_refused = num_refused_;
  s.num_spilled = num_spilled_;
  return s;
}

// SizeMemoryForMission sizes a store by BudgetRecordSizes::StoredScanBytes: the same layout.
static_assert(BudgetRecordSizes::StoredScanBytes(0) ==
                  static_cast<std::int64_t>(ScanStore::kRecordHeaderBytes + EncodedScanBytes(0) +
                                            ScanStore::kIndexEntryBytes),
              "BudgetRecordSizes::kStoredScanOverheadBytes differs from the scan store's layout");
static_assert(BudgetRecordSizes::StoredScanBytes(1) - BudgetRecordSizes::StoredScanBytes(0) ==
                  static_cast<std::int64_t>(EncodedScanBytes(1) - EncodedScanBytes(0)),
              "BudgetRecordSizes::kStoredPointBytes differs from the scan codec");

Result<ScanStoreParams> ScanStoreParamsFromBudget(const MemoryConfig& config, ScanStorePolicy policy) {
  if (config.scan_store_bytes <= 0 || config.max_keyframes_per_robot <= 0 || config.max_points_per_stored_scan <= 0) {
    return InvalidArgument("scan store budget: scan_store_bytes (" + std::to_string(config.scan_store_bytes) +
                           "), max_keyframes_per_robot (" + std::to_string(config.max_keyframes_per_robot) +
                           ") and max_points_per_stored_scan (" + std::to_string(config.max_points_per_stored_scan) +
                           ") must be positive");
  }
  if (static_cast<std::uint64_t>(config.scan_store_bytes) > SIZE_MAX) {
    return InvalidArgument("scan store budget " + FormatBytes(config.scan_store_bytes) +
                           " exceeds this platform's address space");
  }
  const auto budget = static_cast<std::size_t>(config.scan_store_bytes);
  const auto max_scans = static_cast<std::size_t>(config.max_keyframes_per_robot);
  const std::size_t index_bytes = max_scans * ScanStore::kIndexEntryBytes;
  const std::size_t one_scan =
      ScanStore::kRecordHeaderBytes + EncodedScanBytes(static_cast<std::size_t>(config.max_points_per_stored_scan));
  if (budget < index_bytes || budget - index_bytes < one_scan) {
    return InvalidArgument("scan store budget " + Bytes(budget) + " cannot hold the index (" +
                           std::to_string(max_scans) + " keyframes x " + std::to_string(ScanStore::kIndexEntryBytes) +
                           " B = " + Bytes(index_bytes) + ") plus one scan of " +
                           std::to_string(config.max_points_per_stored_scan) + " points (" + Bytes(one_scan) +
                           "): raise --scan-store-mb");
  }
  ScanStoreParams p;
  p.capacity_bytes = budget - index_bytes;
  p.max_scans = max_scans;
  p.policy = policy;
  return p;
}

}  // namespace commerge
