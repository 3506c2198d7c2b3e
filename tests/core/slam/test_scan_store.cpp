// SPDX-License-Identifier: BSD-3-Clause
// Scan store against a reference model: a std::deque of (keyframe index, bytes) plus the placement rule
// stated the other way round from the implementation. The implementation finds free space from physical
// offsets (head, tail, wrapped or not); the model gives every record a virtual position on an endless tape
// (a record never straddles a multiple of the capacity; all live records must lie in one window of
// `capacity` bytes ending at the newest record's end), so both must agree on which scans are evicted.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
#include <deque>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/cloud/scan_codec.hpp"
#include "core/slam/scan_store.hpp"
#include "tests/support/scan_chunks.hpp"
#include "tests/support/strings.hpp"

namespace commerge {
namespace {

using test::Contains;

// An encoded scan of `n` points whose coordinates identify the keyframe and the point.
std::vector<std::uint8_t> MakeScan(std::uint32_t keyframe, std::size_t n) {
  std::vector<PointXYZI> cloud(n);
  for (std::size_t i = 0; i < n; ++i) {
    cloud[i] = {static_cast<float>(keyframe % 30000) * 0.01f, static_cast<float>(i % 30000) * 0.01f,
                static_cast<float>((keyframe + i) % 200) - 100.0f, 0.0f};
  }
  const std::vector<std::uint8_t> buf = test::EncodeForTest(cloud);
  REQUIRE(buf.size() == EncodedScanBytes(n));
  return buf;
}

std::unique_ptr<ScanStore> MakeStore(std::size_t capacity_bytes, std::size_t max_scans, ScanStorePolicy policy,
                                     ScanSpillSink* sink = nullptr, bool touch_at_start = true) {
  ScanStoreParams p;
  p.capacity_bytes = capacity_bytes;
  p.max_scans = max_scans;
  p.policy = policy;
  p.touch_at_start = touch_at_start;
  Result<std::unique_ptr<ScanStore>> store = ScanStore::Create(p, sink);
  REQUIRE_MESSAGE(store.ok(), store.status().ToString());
  return std::move(store.value());
}

// In-memory sink; fails the spills whose keyframe index is in `fail`.
class MemorySink final : public ScanSpillSink {
 public:
  std::map<std::uint32_t, std::vector<std::uint8_t>> scans;
  std::set<std::uint32_t> fail;
  std::vector<std::uint32_t> order;  // keyframes in the order they were offered

  Status Spill(std::uint32_t keyframe_index, Span<const std::uint8_t> encoded) override {
    order.push_back(keyframe_index);
    if (fail.count(keyframe_index)) return IoError("test sink refuses keyframe " + std::to_string(keyframe_index));
    scans[keyframe_index].assign(encoded.begin(), encoded.end());
    return Status::Ok();
  }
  Status Load(std::uint32_t keyframe_index, std::vector<std::uint8_t>* encoded) override {
    const auto it = scans.find(keyframe_index);
    if (it == scans.end()) return NotFound("test sink has no keyframe " + std::to_string(keyframe_index));
    *encoded = it->second;
    return Status::Ok();
  }
};

struct ModelRecord {
  std::uint32_t keyframe;
  std::vector<std::uint8_t> bytes;
  std::uint64_t tape_start;
  std::uint64_t size() const { return ScanStore::kRecordHeaderBytes + bytes.size(); }
};

struct Model {
  std::uint64_t capacity = 0;
  std::size_t max_scans = 0;
  ScanStorePolicy policy = ScanStorePolicy::kEvictOldest;
  std::deque<ModelRecord> live;
  std::uint64_t tape_end = 0;  // end of the newest record on the tape
  std::uint64_t used = 0, high_water = 0;
  std::uint64_t stored = 0, evicted = 0, refused = 0, spilled = 0;
  bool any = false;
  std::uint32_t newest = 0;
  std::map<std::uint32_t, std::vector<std::uint8_t>> ever_stored;
  std::set<std::uint32_t> dropped;  // evicted, spilled or lost
  std::set<std::uint32_t> lost;     // spill failed
  std::vector<std::uint32_t> drop_order;

  enum class Outcome { kStored, kRefusedFull, kRefusedTooBig, kRejectedIndex };
  struct PutOutcome {
    Outcome outcome;
    std::size_t dropped = 0;
    bool dropped_for_space = false;
  };

  PutOutcome Put(std::uint32_t keyframe, const std::vector<std::uint8_t>& bytes, const std::set<std::uint32_t>& fail) {
    if (any && keyframe <= newest) return {Outcome::kRejectedIndex};
    const std::uint64_t size = ScanStore::kRecordHeaderBytes + bytes.size();
    if (size > capacity) {
      ++refused;
      return {Outcome::kRefusedTooBig};
    }
    std::uint64_t start = tape_end;
    if (start % capacity + size > capacity) start = (start / capacity + 1) * capacity;
    const std::uint64_t end = start + size;
    auto must_drop = [&] { return live.size() == max_scans || live.front().tape_start + capacity < end; };
    PutOutcome out{Outcome::kStored};
    if (!live.empty() && must_drop()) {
      if (policy == ScanStorePolicy::kRefuseNew) {
        ++refused;
        return {Outcome::kRefusedFull};
      }
      while (!live.empty() && must_drop()) {
        if (live.size() < max_scans) out.dropped_for_space = true;
        const ModelRecord& r = live.front();
        if (policy == ScanStorePolicy::kSpillOldest && !fail.count(r.keyframe)) {
          ++spilled;
        } else {
          ++evicted;
          if (policy == ScanStorePolicy::kSpillOldest) lost.insert(r.keyframe);
        }
        dropped.insert(r.keyframe);
        drop_order.push_back(r.keyframe);
        used -= r.size();
        live.pop_front();
        ++out.dropped;
      }
    }
    live.push_back({keyframe, bytes, start});
    tape_end = end;
    used += size;
    high_water = std::max(high_water, used);
    any = true;
    newest = keyframe;
    ++stored;
    ever_stored[keyframe] = bytes;
    return out;
  }
};

void CheckAgrees(const ScanStore& store, const Model& model) {
  const ScanStoreStats s = store.stats();
  REQUIRE(s.num_scans == model.live.size());
  CHECK(s.used_bytes == model.used);
  CHECK(s.high_water_bytes == model.high_water);
  CHECK(s.num_stored == model.stored);
  CHECK(s.num_evicted == model.evicted);
  CHECK(s.num_refused == model.refused);
  CHECK(s.num_spilled == model.spilled);
  REQUIRE(s.used_bytes <= s.capacity_bytes);
  std::vector<std::uint32_t> got, want;
  for (std::size_t i = 0; i < model.live.size(); ++i) {
    got.push_back(store.KeyframeAt(i));
    want.push_back(model.live[i].keyframe);
  }
  REQUIRE(got == want);  // same scans, same (FIFO) order
}

void CheckAllContents(const ScanStore& store, const Model& model) {
  for (const ModelRecord& r : model.live) {
    const Result<Span<const std::uint8_t>> view = store.View(r.keyframe);
    REQUIRE_MESSAGE(view.ok(), view.status().ToString());
    REQUIRE(std::vector<std::uint8_t>(view->begin(), view->end()) == r.bytes);
  }
}

struct RunConfig {
  ScanStorePolicy policy;
  std::size_t capacity_bytes;
  std::size_t max_scans;
  std::uint32_t seed;
  bool failing_sink = false;
  bool touch_at_start = true;
};

void RunModelTest(const RunConfig& cfg) {
  const std::string policy_name = ScanStorePolicyName(cfg.policy);
  CAPTURE(policy_name);
  CAPTURE(cfg.capacity_bytes);
  CAPTURE(cfg.max_scans);
  CAPTURE(cfg.seed);
  MemorySink sink;
  std::unique_ptr<ScanStore> store = MakeStore(cfg.capacity_bytes, cfg.max_scans, cfg.policy, &sink, cfg.touch_at_start);
  Model model;
  model.capacity = cfg.capacity_bytes;
  model.max_scans = cfg.max_scans;
  model.policy = cfg.policy;

  std::mt19937 rng(cfg.seed);
  std::uniform_int_distribution<int> pct(0, 99);
  const std::size_t max_points = (cfg.capacity_bytes - ScanStore::kMinRecordBytes) / kEncodedPointBytes;
  std::uint32_t next_keyframe = 1;
  std::uint64_t largest_record = 0;
  std::vector<std::uint8_t> copy;
  std::vector<PointXYZI> points, expected_points;
  std::size_t evictions_for_space = 0;

  for (int step = 0; step < 2000; ++step) {
    const int r = pct(rng);
    if (r < 70) {  // Put a new scan
      std::size_t n;
      const int kind = pct(rng);
      if (kind < 2) {
        n = max_points + 1 + static_cast<std::size_t>(pct(rng));  // larger than the whole block
      } else if (kind < 5) {
        n = max_points / 2 + static_cast<std::size_t>(rng() % (max_points / 2 + 1));  // large, may be exactly full
      } else {
        n = static_cast<std::size_t>(rng() % (std::min<std::size_t>(max_points / 8, 200) + 1));
      }
      const std::uint32_t keyframe = next_keyframe;
      next_keyframe += 1 + static_cast<std::uint32_t>(rng() % 3);  // keyframe indices may skip
      const std::vector<std::uint8_t> bytes = MakeScan(keyframe, n);
      if (cfg.failing_sink && pct(rng) < 20) sink.fail.insert(keyframe);  // spilling this one later will fail
      const Model::PutOutcome expect = model.Put(keyframe, bytes, sink.fail);
      const Result<ScanPutInfo> got = store->Put(keyframe, Span<const std::uint8_t>(bytes));
      switch (expect.outcome) {
        case Model::Outcome::kStored:
          REQUIRE_MESSAGE(got.ok(), got.status().ToString());
          CHECK(got->record_bytes == ScanStore::kRecordHeaderBytes + bytes.size());
          CHECK(got->num_evicted + got->num_spilled == expect.dropped);
          CHECK(got->spill_status.ok() == (got->num_evicted == 0 || cfg.policy != ScanStorePolicy::kSpillOldest));
          if (!got->spill_status.ok()) CHECK(Contains(got->spill_status.message(), "was lost"));
          largest_record = std::max<std::uint64_t>(largest_record, got->record_bytes);
          if (expect.dropped_for_space) {
            // Eviction frees at most one partly used record and one tail gap beyond what is needed.
            ++evictions_for_space;
            CHECK(store->stats().used_bytes + 2 * largest_record > cfg.capacity_bytes);
          }
          break;
        case Model::Outcome::kRefusedFull:
          REQUIRE_FALSE(got.ok());
          CHECK(got.status().code() == StatusCode::kResourceExhausted);
          CHECK(Contains(got.status().message(), "scan store full (policy refuse-new)"));
          break;
        case Model::Outcome::kRefusedTooBig:
          REQUIRE_FALSE(got.ok());
          CHECK(got.status().code() == StatusCode::kResourceExhausted);
          CHECK(Contains(got.status().message(), "more than the whole scan store"));
          break;
        case Model::Outcome::kRejectedIndex:
          FAIL("model rejected an increasing index");
      }
    } else if (r < 73) {  // a non-increasing index is rejected and changes nothing
      if (!model.any) continue;
      const std::uint32_t keyframe =
          model.newest - static_cast<std::uint32_t>(rng() % std::min<std::uint32_t>(model.newest + 1, 3));
      const std::vector<std::uint8_t> bytes = MakeScan(keyframe, 3);
      const Result<ScanPutInfo> got = store->Put(keyframe, Span<const std::uint8_t>(bytes));
      REQUIRE_FALSE(got.ok());
      CHECK(got.status().code() == StatusCode::kInvalidArgument);
      CHECK(Contains(got.status().message(), "keyframe indices must increase"));
    } else {  // look up a random keyframe, present or not
      const std::uint32_t keyframe = static_cast<std::uint32_t>(rng() % (next_keyframe + 3));
      const auto resident = std::find_if(model.live.begin(), model.live.end(),
                                         [&](const ModelRecord& m) { return m.keyframe == keyframe; });
      const Result<Span<const std::uint8_t>> view = store->View(keyframe);
      CHECK(store->Contains(keyframe) == (resident != model.live.end()));
      const Status copied = store->CopyEncoded(keyframe, &copy);
      if (resident != model.live.end()) {
        REQUIRE_MESSAGE(view.ok(), view.status().ToString());
        CHECK(std::vector<std::uint8_t>(view->begin(), view->end()) == resident->bytes);
        REQUIRE(copied.ok());
        CHECK(copy == resident->bytes);
      } else {
        REQUIRE_FALSE(view.ok());
        CHECK(view.status().code() == StatusCode::kNotFound);
        const std::string& m = view.status().message();
        if (model.dropped.count(keyframe)) {
          CHECK(Contains(m, cfg.policy == ScanStorePolicy::kSpillOldest ? "was spilled" : "was evicted"));
        } else if (!model.ever_stored.count(keyframe)) {
          const bool explained =
              Contains(m, "never stored") || Contains(m, "was evicted") || Contains(m, "was spilled");
          CHECK_MESSAGE(explained, m);
        }
        const bool spilled_ok =
            cfg.policy == ScanStorePolicy::kSpillOldest && model.dropped.count(keyframe) && !model.lost.count(keyframe);
        if (spilled_ok) {
          REQUIRE_MESSAGE(copied.ok(), copied.ToString());
          CHECK(copy == model.ever_stored.at(keyframe));
          const Result<std::size_t> n = store->GetPoints(keyframe, &points, &copy);
          REQUIRE(n.ok());
          REQUIRE(DecodeScan(Span<const std::uint8_t>(model.ever_stored.at(keyframe)), &expected_points).ok());
          CHECK(points.size() == expected_points.size());
        } else {
          CHECK_FALSE(copied.ok());
          CHECK(copy.empty());
        }
      }
    }
    CheckAgrees(*store, model);
    if (step % 64 == 0) CheckAllContents(*store, model);
  }
  CheckAllContents(*store, model);

  // The run must have exercised the policy.
  if (cfg.policy == ScanStorePolicy::kRefuseNew) {
    CHECK(model.refused > 10);
    CHECK(model.evicted == 0);
  } else {
    CHECK(model.drop_order.size() > 50);
    if (cfg.max_scans > 100) CHECK(evictions_for_space > 10);
  }
  if (cfg.policy == ScanStorePolicy::kSpillOldest) {
    CHECK(sink.order == model.drop_order);  // same eviction order, oldest first
    // Nothing lost beyond the failed spills: every scan ever stored is retrievable.
    for (const auto& stored : model.ever_stored) {
      const auto& keyframe = stored.first;  // not a structured binding: REQUIRE_MESSAGE captures it in a lambda
      const auto& bytes = stored.second;
      if (model.lost.count(keyframe)) {
        const Status s = store->CopyEncoded(keyframe, &copy);
        CHECK(s.code() == StatusCode::kNotFound);
        CHECK(Contains(s.message(), "spill sink failed"));
        continue;
      }
      REQUIRE_MESSAGE(store->CopyEncoded(keyframe, &copy).ok(), keyframe);
      CHECK(copy == bytes);
    }
    if (cfg.failing_sink) {
      CHECK(!model.lost.empty());
    } else {
      CHECK(model.evicted == 0);
    }
  }
}

}  // namespace

// Each case: 2000 random operations (70 % puts of random sizes incl. scans larger than the block, 3 %
// non-increasing indices, the rest lookups of random keyframes), compared with the model after every one.
TEST_CASE("scan_store: model test, evict-oldest agrees with the reference model over random puts and lookups") {
  RunModelTest({ScanStorePolicy::kEvictOldest, 16 * 1024, 1000, 1});
}

TEST_CASE("scan_store: model test, a store whose block is not touched at creation (commerge run) agrees with the model") {
  RunConfig cfg{ScanStorePolicy::kEvictOldest, 16 * 1024, 1000, 4};
  cfg.touch_at_start = false;
  RunModelTest(cfg);
}

TEST_CASE("scan_store: model test, evict-oldest with an odd capacity agrees with the reference model") {
  RunModelTest({ScanStorePolicy::kEvictOldest, 3001, 1000, 2});
}

TEST_CASE("scan_store: model test, evict-oldest with an index that fills before the block agrees with the model") {
  RunModelTest({ScanStorePolicy::kEvictOldest, 64 * 1024, 7, 3});
}

TEST_CASE("scan_store: model test, refuse-new agrees with the reference model and leaves a full store unchanged") {
  RunModelTest({ScanStorePolicy::kRefuseNew, 16 * 1024, 1000, 4});
}

TEST_CASE("scan_store: model test, refuse-new with a full index agrees with the reference model") {
  RunModelTest({ScanStorePolicy::kRefuseNew, 64 * 1024, 9, 5});
}

TEST_CASE("scan_store: model test, spill-oldest hands every dropped scan to the sink and fetches it back") {
  RunModelTest({ScanStorePolicy::kSpillOldest, 16 * 1024, 1000, 6});
}

TEST_CASE("scan_store: model test, spill-oldest with a small index hands every dropped scan to the sink") {
  RunModelTest({ScanStorePolicy::kSpillOldest, 5000, 5, 7});
}

TEST_CASE("scan_store: model test, spill-oldest with a failing sink counts lost scans and reports the sink error") {
  RunModelTest({ScanStorePolicy::kSpillOldest, 16 * 1024, 1000, 8, true});
}

TEST_CASE("scan_store: refuse-new: a full store refuses with the sizes and keeps its contents byte for byte") {
  std::unique_ptr<ScanStore> store = MakeStore(1000, 100, ScanStorePolicy::kRefuseNew);
  std::vector<std::vector<std::uint8_t>> kept;
  for (std::uint32_t k = 1; k <= 3; ++k) {
    kept.push_back(MakeScan(k, 50));  // 8 + 12 + 300 = 320 B each
    REQUIRE(store->Put(k, Span<const std::uint8_t>(kept.back())).ok());
  }
  CHECK(store->stats().used_bytes == 960);
  const std::vector<std::uint8_t> next = MakeScan(4, 50);
  const Result<ScanPutInfo> r = store->Put(4, Span<const std::uint8_t>(next));
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().code() == StatusCode::kResourceExhausted);
  CHECK(Contains(r.status().message(), "keyframe 4 needs 320 B"));
  CHECK(Contains(r.status().message(), "40 B of 1000 B are free"));
  CHECK(store->stats().num_refused == 1);
  CHECK(store->stats().num_scans == 3);
  for (std::uint32_t k = 1; k <= 3; ++k) {
    const Result<Span<const std::uint8_t>> v = store->View(k);
    REQUIRE(v.ok());
    CHECK(std::vector<std::uint8_t>(v->begin(), v->end()) == kept[k - 1]);
  }
  // A smaller scan still fits in the 40 free bytes; the refused index may be retried.
  const std::vector<std::uint8_t> tiny = MakeScan(4, 3);  // 8 + 12 + 18 = 38 B
  CHECK(store->Put(4, Span<const std::uint8_t>(tiny)).ok());
  CHECK(store->stats().used_bytes == 998);
}

TEST_CASE("scan_store: a record that exactly fills the end of the block or the gap before the oldest goes there") {
  for (const ScanStorePolicy policy : {ScanStorePolicy::kRefuseNew, ScanStorePolicy::kEvictOldest}) {
    const std::string policy_name = ScanStorePolicyName(policy);
    CAPTURE(policy_name);
    std::unique_ptr<ScanStore> store = MakeStore(960, 100, policy);  // 3 records of 50 points: 3 x 320 B
    for (std::uint32_t k = 1; k <= 3; ++k) {
      const std::vector<std::uint8_t> scan = MakeScan(k, 50);
      const Result<ScanPutInfo> r = store->Put(k, Span<const std::uint8_t>(scan));
      REQUIRE(r.ok());
      CHECK(r->num_evicted == 0);
    }
    CHECK(store->stats().used_bytes == 960);
    const std::vector<std::uint8_t> next = MakeScan(4, 50);
    const Result<ScanPutInfo> r = store->Put(4, Span<const std::uint8_t>(next));
    if (policy == ScanStorePolicy::kRefuseNew) {
      CHECK_FALSE(r.ok());
      continue;
    }
    REQUIRE(r.ok());
    CHECK(r->num_evicted == 1);  // keyframe 4 takes exactly the room of keyframe 1 at offset 0
    // Ring now wrapped: keyframe 5 fits exactly between 4 and 3 once 2 is gone; then, unwrapped again,
    // keyframe 6 fits exactly between the end of 5 and the end of the block once 3 is gone.
    for (std::uint32_t k = 5; k <= 6; ++k) {
      const std::vector<std::uint8_t> scan = MakeScan(k, 50);
      const Result<ScanPutInfo> p = store->Put(k, Span<const std::uint8_t>(scan));
      REQUIRE(p.ok());
      CHECK(p->num_evicted == 1);
      CHECK(store->stats().used_bytes == 960);
    }
    CHECK(store->KeyframeAt(0) == 4);
    CHECK(store->num_scans() == 3);
  }
}

TEST_CASE("scan_store: evict-oldest: evicts in order, and a lookup of an evicted scan says so") {
  std::unique_ptr<ScanStore> store = MakeStore(1000, 100, ScanStorePolicy::kEvictOldest);
  for (std::uint32_t k = 10; k <= 13; ++k) {
    const std::vector<std::uint8_t> scan = MakeScan(k, 50);
    const Result<ScanPutInfo> r = store->Put(k, Span<const std::uint8_t>(scan));
    REQUIRE(r.ok());
    CHECK(r->num_evicted == (k == 13 ? 1u : 0u));
  }
  CHECK(store->KeyframeAt(0) == 11);
  const Result<Span<const std::uint8_t>> v = store->View(10);
  REQUIRE_FALSE(v.ok());
  CHECK(v.status().code() == StatusCode::kNotFound);
  CHECK(Contains(v.status().message(), "keyframe 10 was evicted from the full scan store"));
  CHECK(store->View(12).ok());  // resident
  CHECK(Contains(store->View(99).status().message(), "never stored (the newest scan is keyframe 13)"));
  CHECK(Contains(store->View(3).status().message(), "never stored (the first scan stored is keyframe 10)"));
  std::vector<PointXYZI> points;
  const Result<std::size_t> n = store->GetPoints(12, &points);
  REQUIRE(n.ok());
  CHECK(*n == 50);
  CHECK(points.size() == 50);
  CHECK_FALSE(store->GetPoints(10, &points).ok());
}

TEST_CASE("scan_store: A scan larger than the whole store is refused in every policy") {
  for (const ScanStorePolicy policy :
       {ScanStorePolicy::kRefuseNew, ScanStorePolicy::kEvictOldest, ScanStorePolicy::kSpillOldest}) {
    const std::string policy_name = ScanStorePolicyName(policy);
    CAPTURE(policy_name);
    MemorySink sink;
    std::unique_ptr<ScanStore> store = MakeStore(1000, 10, policy, &sink);
    const std::vector<std::uint8_t> small = MakeScan(1, 10);
    REQUIRE(store->Put(1, Span<const std::uint8_t>(small)).ok());
    const std::vector<std::uint8_t> exact = MakeScan(2, (1000 - 20) / 6);  // 8 + 12 + 978 = 998 B: fits
    const std::vector<std::uint8_t> big = MakeScan(3, 164);                // 8 + 12 + 984 = 1004 B
    const Result<ScanPutInfo> r = store->Put(3, Span<const std::uint8_t>(big));
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kResourceExhausted);
    CHECK(Contains(r.status().message(), "keyframe 3: scan of 164 points needs 1004 B"));
    CHECK(Contains(r.status().message(), "more than the whole scan store (1000 B)"));
    CHECK(store->stats().num_refused == 1);
    CHECK(store->stats().num_scans == 1);
    CHECK(sink.order.empty());
    if (policy != ScanStorePolicy::kRefuseNew) {
      REQUIRE(store->Put(4, Span<const std::uint8_t>(exact)).ok());  // evicts keyframe 1, fills the block
      CHECK(store->stats().used_bytes == 998);
      CHECK(store->KeyframeAt(0) == 4);
    }
  }
}

TEST_CASE("scan_store: Put rejects non-increasing indices, malformed scans and bytes from inside the store") {
  std::unique_ptr<ScanStore> store = MakeStore(4096, 10, ScanStorePolicy::kEvictOldest);
  const std::vector<std::uint8_t> scan = MakeScan(5, 10);
  REQUIRE(store->Put(5, Span<const std::uint8_t>(scan)).ok());
  for (const std::uint32_t k : {5u, 4u, 0u}) {
    const Result<ScanPutInfo> r = store->Put(k, Span<const std::uint8_t>(scan));
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kInvalidArgument);
    CHECK(Contains(r.status().message(),
                   "keyframe " + std::to_string(k) + " is not newer than the newest stored scan (keyframe 5)"));
  }
  std::vector<std::uint8_t> bad = scan;
  bad.pop_back();
  const Result<ScanPutInfo> r = store->Put(6, Span<const std::uint8_t>(bad));
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(Contains(r.status().message(), "keyframe 6: not a valid encoded scan: encoded scan truncated"));
  const Result<Span<const std::uint8_t>> inside = store->View(5);
  REQUIRE(inside.ok());
  CHECK(Contains(store->Put(7, *inside).status().message(), "lies inside this store"));
  const ScanStoreStats s = store->stats();
  CHECK(s.num_scans == 1);
  CHECK(s.num_stored == 1);
  CHECK(s.num_refused == 0);
}

TEST_CASE("scan_store: spill-oldest: a failing sink loses the scan, counts it as evicted and reports the error") {
  MemorySink sink;
  sink.fail = {2};
  std::unique_ptr<ScanStore> store = MakeStore(700, 100, ScanStorePolicy::kSpillOldest, &sink);
  for (std::uint32_t k = 1; k <= 4; ++k) {
    const std::vector<std::uint8_t> scan = MakeScan(k, 50);  // 320 B: two fit
    const Result<ScanPutInfo> r = store->Put(k, Span<const std::uint8_t>(scan));
    REQUIRE(r.ok());  // the new scan is stored even when the sink fails
    if (k == 4) {
      CHECK(r->num_evicted == 1);
      CHECK(r->num_spilled == 0);
      CHECK(r->spill_status.code() == StatusCode::kIoError);
      CHECK(Contains(r->spill_status.message(), "keyframe 2 was lost: the spill sink refused it: test sink refuses"));
    } else {
      CHECK(r->spill_status.ok());
    }
  }
  const ScanStoreStats s = store->stats();
  CHECK(s.num_spilled == 1);
  CHECK(s.num_evicted == 1);
  std::vector<std::uint8_t> copy;
  CHECK(store->CopyEncoded(1, &copy).ok());
  CHECK(copy == MakeScan(1, 50));
  const Status lost = store->CopyEncoded(2, &copy);
  CHECK(lost.code() == StatusCode::kNotFound);
  CHECK(Contains(lost.message(),
                 "keyframe 2 was dropped from the full scan store and loading it from the spill sink failed"));
  std::vector<PointXYZI> points;
  CHECK(store->GetPoints(1, &points).status().code() == StatusCode::kInvalidArgument);  // needs a spill buffer
  REQUIRE(store->GetPoints(1, &points, &copy).ok());
  CHECK(points.size() == 50);
  // A sink that returns corrupt bytes is caught by the codec's CRC.
  sink.scans[1][20] ^= 0x10;
  const Status corrupt = store->CopyEncoded(1, &copy);
  CHECK(corrupt.code() == StatusCode::kDataLoss);
  CHECK(Contains(corrupt.message(), "keyframe 1 loaded from the spill sink is not a valid scan"));
  CHECK(copy.empty());
}

TEST_CASE("scan_store: Create validates its parameters") {
  MemorySink sink;
  ScanStoreParams p;
  p.capacity_bytes = 19;
  p.max_scans = 1;
  CHECK(Contains(ScanStore::Create(p).status().message(), "below the smallest record (20 B"));
  p.capacity_bytes = 20;
  CHECK(ScanStore::Create(p).ok());
  p.max_scans = 0;
  CHECK(Contains(ScanStore::Create(p).status().message(), "max_scans"));
  p.max_scans = 1;
  p.policy = ScanStorePolicy::kSpillOldest;
  CHECK(Contains(ScanStore::Create(p).status().message(), "needs a spill sink"));
  CHECK(ScanStore::Create(p, &sink).ok());
  CHECK(ParseScanStorePolicy("spill-oldest").ok());
  CHECK(Contains(ParseScanStorePolicy("lru").status().message(), "refuse-new, evict-oldest, spill-oldest"));
}

TEST_CASE("scan_store: Parameters from the memory budget keep block + index within scan_store_bytes") {
  const MemoryConfig c = DefaultMemoryConfig(BoardProfile::kJetsonNano);
  const Result<ScanStoreParams> p = ScanStoreParamsFromBudget(c, ScanStorePolicy::kSpillOldest);
  REQUIRE(p.ok());
  CHECK(p->max_scans == static_cast<std::size_t>(c.max_keyframes_per_robot));
  CHECK(ScanStore::ReservedBytes(*p) == static_cast<std::size_t>(c.scan_store_bytes));
  CHECK(p->capacity_bytes + 16u * 20000u == 160u * 1024u * 1024u);
  MemoryConfig tiny = c;
  tiny.scan_store_bytes = 20000 * 16 + 49000;  // one 8192-point scan needs 49172 B
  const Result<ScanStoreParams> bad = ScanStoreParamsFromBudget(tiny, ScanStorePolicy::kEvictOldest);
  REQUIRE_FALSE(bad.ok());
  CHECK(Contains(bad.status().message(), "one scan of 8192 points (49172 B"));
}

TEST_CASE("scan_store: Steady state: records stay inside the one block and caller buffers are reused") {
  // What this asserts: across 3000 evicting puts every returned view lies in one range of capacity_bytes
  // (the block allocated by Create never moves or grows), reserved_bytes() is constant, and lookups into
  // caller vectors with enough capacity do not reallocate them. It does not count malloc calls: the store
  // has no growable member (two unique_ptr arrays) and Put's success path builds no strings.
  const std::size_t capacity = 32 * 1024;
  std::unique_ptr<ScanStore> store = MakeStore(capacity, 64, ScanStorePolicy::kEvictOldest);
  const std::size_t reserved = store->reserved_bytes();
  CHECK(reserved == capacity + 64 * ScanStore::kIndexEntryBytes);
  std::vector<std::vector<std::uint8_t>> scans;
  for (std::uint32_t k = 0; k < 16; ++k) scans.push_back(MakeScan(k, 100 + 37 * k));
  std::vector<std::uint8_t> copy;
  copy.reserve(EncodedScanBytes(2000));
  std::vector<PointXYZI> points;
  points.reserve(2000);
  const std::uint8_t* copy_data = copy.data();
  const PointXYZI* points_data = points.data();
  std::uintptr_t lo = UINTPTR_MAX, hi = 0;
  for (std::uint32_t k = 1; k <= 3000; ++k) {
    const std::vector<std::uint8_t>& scan = scans[k % scans.size()];
    REQUIRE(store->Put(k, Span<const std::uint8_t>(scan)).ok());
    const Result<Span<const std::uint8_t>> v = store->View(k);
    REQUIRE(v.ok());
    lo = std::min(lo, reinterpret_cast<std::uintptr_t>(v->data()));
    hi = std::max(hi, reinterpret_cast<std::uintptr_t>(v->data() + v->size()));
    REQUIRE(store->CopyEncoded(k, &copy).ok());
    REQUIRE(store->GetPoints(store->KeyframeAt(0), &points).ok());
  }
  CHECK(hi - lo <= capacity);
  CHECK(store->reserved_bytes() == reserved);
  CHECK(copy.data() == copy_data);
  CHECK(points.data() == points_data);
  CHECK(store->stats().num_evicted > 2000);
  CHECK(store->stats().high_water_bytes <= capacity);
}

}  // namespace commerge
