// The lower envelope of parabolas along one line (Felzenszwalb and Huttenlocher 2012, the 1-D
// squared distance transform): y(x) = min over sites q of f_q + w2 (x - q)^2 at every x in
// [0, n). Both distance maps run it along their lines: the mask's exact transform
// (distance_transform.cpp, which wants each voxel's winning site) and the sub-voxel map's
// distance to its points (subvoxel_distance.cpp, which wants the value). One implementation, so
// the two maps break ties and round alike.
//
// Header-only: it is the inner loop of both transforms and is inlined into each pass. The caller
// owns one per thread, sized for its longest line, so a pass allocates nothing per line.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace palp {

class LowerEnvelope {
 public:
  explicit LowerEnvelope(std::int64_t n = 0) { reserve(n); }

  // Room for lines of up to n sites.
  void reserve(std::int64_t n) {
    sites_.resize(static_cast<std::size_t>(n));
    heights_.resize(static_cast<std::size_t>(n));
    site_value_.resize(static_cast<std::size_t>(n));
    bounds_.resize(static_cast<std::size_t>(n) + 1);
  }
  std::int64_t capacity() const { return static_cast<std::int64_t>(sites_.size()); }

  // Builds the envelope of the sites q in [0, n): site(q, f) is false where there is none, and
  // true with f = f_q where there is one. w2 is the squared spacing along the line. Returns the
  // number of parabolas left in the envelope (0: the line has no site).
  template <class Site>
  std::size_t build(std::int64_t n, double w2, Site site) {
    return build(0, n, w2, site);
  }

  // The same over the sites q in [first, end) only, at their own positions on the line.
  template <class Site>
  std::size_t build(std::int64_t first, std::int64_t end, double w2, Site site) {
    std::size_t count = 0;
    for (std::int64_t q = first; q < end; ++q) {
      double f = 0.0;
      if (!site(q, f)) continue;
      const double dq = static_cast<double>(q);
      const double fq = f + w2 * dq * dq;
      while (count > 0) {
        const double s = (fq - site_value_[count - 1]) /
                         (2.0 * w2 * (dq - static_cast<double>(sites_[count - 1])));
        if (s > bounds_[count - 1]) {
          bounds_[count] = s;
          break;
        }
        --count;
      }
      if (count == 0) bounds_[0] = -std::numeric_limits<double>::infinity();
      sites_[count] = static_cast<std::int32_t>(q);
      heights_[count] = f;
      site_value_[count] = fq;
      ++count;
      bounds_[count] = std::numeric_limits<double>::infinity();
    }
    count_ = count;
    return count;
  }

  // After build(n, ...) found at least one site: visit(x0, x1, q, f_q) for each parabola that is
  // the lowest over [x0, x1), in order, the spans covering [0, n). Parabola s is the lowest at
  // the x with bounds[s] < x <= bounds[s + 1] (the bounds rise), so a tie goes to the left site.
  template <class Visit>
  void for_each_span(std::int64_t n, Visit visit) const {
    for_each_span(0, n, visit);
  }

  // The same over [first, n) (first >= 0).
  template <class Visit>
  void for_each_span(std::int64_t first, std::int64_t n, Visit visit) const {
    std::int64_t x = first;
    for (std::size_t segment = 0; segment < count_ && x < n; ++segment) {
      const double bound = bounds_[segment + 1];
      const std::int64_t end = bound >= static_cast<double>(n - 1) ? n
                               : bound < static_cast<double>(first)
                                   ? first
                                   : static_cast<std::int64_t>(bound) + 1;  // floor
      if (end <= x) continue;
      visit(x, end, static_cast<std::int64_t>(sites_[segment]), heights_[segment]);
      x = end;
    }
  }

 private:
  std::vector<std::int32_t> sites_;
  std::vector<double> heights_;     // f_q of each site in the envelope
  std::vector<double> site_value_;  // f_q + w2 q^2 of each site in the envelope
  std::vector<double> bounds_;      // bounds_[s]: where parabola s starts being the lowest
  std::size_t count_ = 0;
};

}  // namespace palp
