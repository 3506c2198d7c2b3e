// SPDX-License-Identifier: BSD-3-Clause
#include "core/cloud/kd_tree.hpp"

#include <nanoflann.hpp>

namespace commerge {

struct KdTree3::Adaptor {
  Span<const PointXYZI> points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const {
    const PointXYZI& p = points[i];
    return dim == 0 ? p.x : (dim == 1 ? p.y : p.z);
  }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};

struct KdTree3::Index {
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Adaptor>, Adaptor, 3,
                                                   std::uint32_t>;
  Tree tree;
  explicit Index(const Adaptor& adaptor) : tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}
};

KdTree3::KdTree3() : adaptor_(std::make_unique<Adaptor>()) {}
KdTree3::~KdTree3() = default;

void KdTree3::Build(Span<const PointXYZI> points) {
  points_ = points;
  adaptor_->points = points;
  if (points.empty()) return;  // queries check size(); nanoflann is not asked to index nothing
  if (!index_) {
    index_ = std::make_unique<Index>(*adaptor_);  // the constructor builds the index
  } else {
    index_->tree.buildIndex();
  }
}

std::size_t KdTree3::memory_bytes() const { return index_ ? index_->tree.usedMemory(index_->tree) : 0; }

bool KdTree3::Nearest(float x, float y, float z, std::uint32_t* index, float* distance_sq_m2) const {
  return Knn(x, y, z, 1, index, distance_sq_m2) == 1;
}

std::size_t KdTree3::Knn(float x, float y, float z, std::size_t k, std::uint32_t* indices,
                         float* distances_sq_m2) const {
  if (!index_ || points_.empty() || k == 0) return 0;
  const float query[3] = {x, y, z};
  nanoflann::KNNResultSet<float, std::uint32_t> result(static_cast<std::uint32_t>(k));
  result.init(indices, distances_sq_m2);
  index_->tree.findNeighbors(result, query, nanoflann::SearchParams());
  return result.size();
}

}  // namespace commerge
