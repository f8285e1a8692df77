#include "../../solver/src/sparse_cholesky.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace mimic::solver::sparse_cholesky_test {
namespace {

using detail::ColumnSpans;
using detail::kLanes;

// A system shaped like the trunk's normal equations: branches of columns (an arm, the neck)
// hanging from a tail (spine and root) that every target reaches. A target on a branch touches a
// suffix of its branch (its joint and the branch's joints above it) and the whole tail; a target
// on the tail, a suffix of the tail. Some columns no target touches (a prior alone holds them).
struct Structured {
  int n = 0;
  std::vector<std::vector<int>> targets;  // each target's columns, ascending
};

Structured random_structure(std::mt19937_64& rng) {
  std::uniform_int_distribution<int> branches(0, 3), branch_len(1, 10), tail_len(1, 16), coin(0, 1);
  Structured s;
  std::vector<std::pair<int, int>> branch_ranges;
  for (int b = branches(rng); b > 0; --b) {
    const int len = branch_len(rng);
    branch_ranges.push_back({s.n, s.n + len});
    s.n += len;
  }
  const int tail_first = s.n;
  s.n += tail_len(rng);
  for (const auto& [first, end] : branch_ranges)
    for (int t = 0; t < 2; ++t) {
      const int from = std::uniform_int_distribution<int>(first, end - 1)(rng);
      std::vector<int> cols;
      for (int c = from; c < end; ++c) cols.push_back(c);
      for (int c = tail_first; c < s.n; ++c) cols.push_back(c);
      s.targets.push_back(cols);
    }
  if (branch_ranges.empty() || coin(rng)) {
    const int from = std::uniform_int_distribution<int>(tail_first, s.n - 1)(rng);
    std::vector<int> cols;
    for (int c = from; c < s.n; ++c) cols.push_back(c);
    s.targets.push_back(cols);
  }
  return s;
}

// The least squares' spans: runs of consecutive columns, merged across gaps under a block, then
// the right-hand side's column n.
std::vector<int> spans_of(std::vector<int> cols, int n) {
  cols.push_back(n);
  std::vector<int> pairs;
  for (size_t k = 0; k < cols.size(); ++k) {
    if (k == 0 || cols[k] >= cols[k - 1] + kLanes) pairs.push_back(cols[k]), pairs.push_back(0);
    pairs.back() = cols[k] + 1;
  }
  return pairs;
}

// Dense double-precision Cholesky solve: the reference.
std::vector<double> dense_solve(std::vector<double> a, std::vector<double> b, int n) {
  for (int j = 0; j < n; ++j) {
    for (int k = 0; k < j; ++k) a[j * n + j] -= a[k * n + j] * a[k * n + j];
    a[j * n + j] = std::sqrt(a[j * n + j]);
    for (int i = j + 1; i < n; ++i) {
      for (int k = 0; k < j; ++k) a[j * n + i] -= a[k * n + j] * a[k * n + i];
      a[j * n + i] /= a[j * n + j];
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int k = 0; k < j; ++k) b[j] -= a[k * n + j] * b[k];
    b[j] /= a[j * n + j];
  }
  for (int j = n - 1; j >= 0; --j) {
    for (int k = j + 1; k < n; ++k) b[j] -= a[j * n + k] * b[k];
    b[j] /= a[j * n + j];
  }
  return b;
}

// On random SPD systems of that shape (JᵀJ + μ·I with random Jacobian rows over each target's
// columns, some rows pinned as the least squares pins a DOF at its limit), the sparse solve
// equals the dense one, and the factor's zeros outside the spans stay zero.
TEST(SparseCholesky, EqualsADenseSolveOnTreeShapedSystems) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> damping(0.01, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    const Structured s = random_structure(rng);
    const int n = s.n, stride = detail::padded_stride(n);
    std::vector<double> a(static_cast<size_t>(n) * n, 0.0), b(n, 0.0);
    for (const auto& cols : s.targets)
      for (int row = 0; row < 3; ++row) {
        std::vector<double> jr(n, 0.0);
        for (int c : cols) jr[c] = gauss(rng);
        const double r = gauss(rng);
        for (int i : cols) {
          b[i] += jr[i] * r;
          for (int k : cols) a[i * n + k] += jr[i] * jr[k];
        }
      }
    const double mu = damping(rng);
    for (int i = 0; i < n; ++i) a[i * n + i] += mu;
    if (trial % 3 == 0) {  // a DOF pinned at its limit: its row and column leave the step
      const int p = std::uniform_int_distribution<int>(0, n - 1)(rng);
      for (int k = 0; k < n; ++k) a[p * n + k] = a[k * n + p] = 0.0;
      a[p * n + p] = 1.0, b[p] = 0.0;
    }
    // Float copies, upper triangle only, padded rows; the lower triangle holds garbage that
    // must never be read.
    std::vector<float> af(static_cast<size_t>(n) * stride, 0.0f), xf(n, 0.0f);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < i; ++k) af[i * stride + k] = 1e30f;
      for (int k = i; k < n; ++k) af[i * stride + k] = static_cast<float>(a[i * n + k]);
      af[i * stride + n] = static_cast<float>(b[i]);
    }
    std::vector<int> owner(n, -1);
    std::vector<std::vector<int>> spans;
    for (size_t t = 0; t < s.targets.size(); ++t) {
      spans.push_back(spans_of(s.targets[t], n));
      for (int c : s.targets[t]) owner[c] = static_cast<int>(t);
    }
    const int rhs_alone[2] = {n, n + 1};
    auto spans_right_of = [&](int j) {
      if (owner[j] < 0) return ColumnSpans{rhs_alone, 1};
      const std::vector<int>& p = spans[owner[j]];
      int q = 0;
      while (q < static_cast<int>(p.size()) / 2 && p[2 * q + 1] <= j + 1) ++q;
      return ColumnSpans{p.data() + 2 * q, static_cast<int>(p.size()) / 2 - q};
    };
    std::vector<int> first(n), count(n), rows(static_cast<size_t>(n) * n / 2 + 1);
    detail::list_reaching_rows(n, spans_right_of, first.data(), count.data(), rows.data());
    std::vector<float> inv_diag(n);
    ASSERT_TRUE(detail::cholesky_solve(af.data(), xf.data(), n, stride, spans_right_of,
                                       detail::ReachingRows{first.data(), count.data(), rows.data()}, inv_diag.data()));
    const std::vector<double> x = dense_solve(a, b, n);
    double scale = 1e-6;
    for (double v : x) scale = std::max(scale, std::abs(v));
    for (int i = 0; i < n; ++i) EXPECT_NEAR(xf[i], x[i], 2e-3 * scale) << "trial " << trial << " column " << i;
    // Padding stays zero (blocks spill into it).
    for (int i = 0; i < n; ++i)
      for (int k = n + 1; k < stride; ++k) EXPECT_EQ(af[i * stride + k], 0.0f);
  }
}

TEST(SparseCholesky, RefusesASystemThatIsNotPositiveDefinite) {
  const int n = 3, stride = detail::padded_stride(n);
  std::vector<float> a(static_cast<size_t>(n) * stride, 0.0f), x(n, 0.0f);
  a[0] = 1.0f, a[stride + 1] = -1.0f, a[2 * stride + 2] = 1.0f;
  for (int i = 0; i < n; ++i) a[i * stride + n] = 1.0f;
  std::vector<int> first(n), count(n), rows(8);
  const int rhs_alone[2] = {n, n + 1};
  auto no_spans = [&](int) { return ColumnSpans{rhs_alone, 1}; };
  detail::list_reaching_rows(n, no_spans, first.data(), count.data(), rows.data());
  std::vector<float> inv_diag(n);
  EXPECT_FALSE(detail::cholesky_solve(a.data(), x.data(), n, stride, no_spans,
                                      detail::ReachingRows{first.data(), count.data(), rows.data()}, inv_diag.data()));
}

}  // namespace
}  // namespace mimic::solver::sparse_cholesky_test
