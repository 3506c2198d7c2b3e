// SPDX-License-Identifier: BSD-3-Clause
// commerge: a 3-D k-d tree over a point span (nanoflann underneath), for ICP, normals and registration.
// Non-owning: the points must outlive the tree and stay unchanged until the next Build().
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"

namespace commerge {

class KdTree3 {
 public:
  KdTree3();
  ~KdTree3();
  KdTree3(const KdTree3&) = delete;
  KdTree3& operator=(const KdTree3&) = delete;

  /// Indexes `points` (x, y, z; all must be finite). Rebuilding reuses the tree object.
  void Build(Span<const PointXYZI> points);

  std::size_t size() const noexcept { return points_.size(); }
  /// Bytes the index holds (nanoflann's node pool and index array; 0 before the first non-empty Build()).
  std::size_t memory_bytes() const;

  /// Nearest point to (x, y, z): false when the tree is empty.
  bool Nearest(float x, float y, float z, std::uint32_t* index, float* distance_sq_m2) const;

  /// Up to `k` nearest points, closest first, into caller arrays of length >= k; returns how many.
  std::size_t Knn(float x, float y, float z, std::size_t k, std::uint32_t* indices, float* distances_sq_m2) const;

 private:
  struct Adaptor;
  struct Index;
  Span<const PointXYZI> points_;
  std::unique_ptr<Adaptor> adaptor_;
  std::unique_ptr<Index> index_;
};

}  // namespace commerge
