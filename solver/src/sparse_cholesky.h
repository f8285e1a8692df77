// Cholesky solve of a small SPD system whose upper triangle is non-zero only in known spans of
// columns per row, as the trunk's least squares produces (least_squares_ik.cpp). Header-only so
// that a test can hold it against a dense factorization.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>

namespace mimic::solver::detail {

// Row operations run in whole blocks of kLanes floats, which vectorise without remainder loops.
// A block is a vector type (GCC and Clang), so that the compiler keeps a row's running sums in
// registers and never vectorises across rows instead (with gathers).
inline constexpr int kLanes = 8;
using Block = float __attribute__((vector_size(kLanes * sizeof(float))));
// By reference: a 32-byte vector passed by value would change the calling convention without AVX.
inline void load_block(Block& v, const float* p) { std::memcpy(&v, p, sizeof v); }
inline void store_block(float* p, const Block& v) { std::memcpy(p, &v, sizeof v); }
// Row stride for n unknowns and the right-hand side as column n: a multiple of kLanes with at
// least kLanes − 1 zeros after column n, so that a block starting at any column up to n stays
// inside the row.
inline int padded_stride(int n) { return (n + 2 * kLanes - 1) / kLanes * kLanes; }

// Where a row can be non-zero right of its diagonal: spans of columns, pairs (first, one past
// the last), ascending, at least kLanes apart (a block run to a span's end may spill up to
// kLanes − 1 columns past it: those are zeros of the row, or its padding, never the next span).
// Columns at or left of the diagonal are ignored.
struct ColumnSpans {
  const int* pairs = nullptr;
  int count = 0;
};

// For every column i, the earlier rows m whose spans reach it: the only rows that can be non-zero
// in column i above the diagonal. Row numbers, ascending, column i's from rows[first[i]] on,
// count[i] of them; `rows` holds up to n·(n − 1)/2.
struct ReachingRows {
  const int* first = nullptr;
  const int* count = nullptr;
  const int* rows = nullptr;
};

template <typename Spans>
void list_reaching_rows(int n, const Spans& spans, int* first, int* count, int* rows) {
  std::fill(count, count + n, 0);
  for (int m = 0; m < n; ++m) {
    const ColumnSpans sm = spans(m);
    for (int q = 0; q < sm.count; ++q)
      for (int i = std::max(sm.pairs[2 * q], m + 1); i < std::min(sm.pairs[2 * q + 1], n); ++i) ++count[i];
  }
  for (int i = 0, at = 0; i < n; ++i) first[i] = at, at += count[i], count[i] = 0;
  for (int m = 0; m < n; ++m) {
    const ColumnSpans sm = spans(m);
    for (int q = 0; q < sm.count; ++q)
      for (int i = std::max(sm.pairs[2 * q], m + 1); i < std::min(sm.pairs[2 * q + 1], n); ++i)
        rows[first[i] + count[i]++] = m;
  }
}

// In-place Cholesky solve of the SPD n×n system a·x = b, b held in column n of `a` (rows of
// `stride` floats, padded with zeros); x goes to `x` (n floats); false if not SPD. Only the upper
// triangle of `a` is read; it becomes U with UᵀU = a, and column n becomes y with Uᵀy = b.
// `spans(i)` must cover row i's non-zeros right of i and column n, closed under elimination
// (every earlier row touching column i < n is non-zero right of i only inside row i's spans: the
// least squares' elimination order guarantees it, no fill-in), and `reaching` list them by column
// (list_reaching_rows). Up-looking, row by row: row i is a_i − Σ_m u_mi·u_m over the earlier rows
// m that reach it, summed block by block in registers and stored once, over row i's spans only
// (one arm's DOFs never touch the other arm's or the neck's). The forward substitution rides in
// the factorization's blocks as column n (a separate sweep after it was a second chain of
// dependent updates, a quarter of the solve); the back substitution runs by blocks of kLanes
// unknowns (a sweep down the columns, an update per non-zero, was another third).
// `inv_diag` is scratch for n floats.
template <typename Spans>
bool cholesky_solve(float* a, float* x, int n, int stride, const Spans& spans, const ReachingRows& reaching,
                    float* inv_diag) {
  for (int i = 0; i < n; ++i) {
    float* __restrict ai = a + static_cast<ptrdiff_t>(i) * stride;
    const int* rows = reaching.rows + reaching.first[i];
    const int n_rows = reaching.count[i];
    const ColumnSpans si = spans(i);
    // The diagonal's block, then the spans right of it.
    for (int q = -1; q < si.count; ++q) {
      const int first = q < 0 ? i : std::max(si.pairs[2 * q], i + kLanes);
      const int last = q < 0 ? i + 1 : si.pairs[2 * q + 1];
      for (int k = first; k < last; k += kLanes) {
        // Four running sums: one would wait on each multiply-add in turn.
        Block acc[4] = {}, v;
        load_block(acc[0], ai + k);
        int t = 0;
        for (; t + 4 <= n_rows; t += 4)
          for (int r = 0; r < 4; ++r) {
            const float* am = a + static_cast<ptrdiff_t>(rows[t + r]) * stride;
            load_block(v, am + k);
            acc[r] -= am[i] * v;
          }
        for (; t < n_rows; ++t) {
          const float* am = a + static_cast<ptrdiff_t>(rows[t]) * stride;
          load_block(v, am + k);
          acc[0] -= am[i] * v;
        }
        acc[0] = (acc[0] + acc[1]) + (acc[2] + acc[3]);
        store_block(ai + k, acc[0]);
      }
    }
    if (!(ai[i] > 1e-12f)) return false;
    const float d = std::sqrt(ai[i]);
    ai[i] = d;
    const float inv_d = 1.0f / d;
    inv_diag[i] = inv_d;
    // In blocks: past a span's end the row holds zeros (or padding), which stay zeros.
    for (int q = 0; q < si.count; ++q)
      for (int k = std::max(si.pairs[2 * q], i + 1); k < si.pairs[2 * q + 1]; k += kLanes) {
        Block v;
        load_block(v, ai + k);
        v *= inv_d;
        store_block(ai + k, v);
      }
  }
  for (int j = 0; j < n; ++j) x[j] = a[static_cast<ptrdiff_t>(j) * stride + n];
  // U·x = y by blocks of kLanes unknowns from the last: each block's own triangle with its
  // unknowns in registers (the sum ending on the unknown just found, so that each waits on one
  // multiply-add), then every row above takes the block's share as one block product.
  for (int first = (n - 1) / kLanes * kLanes; first >= 0; first -= kLanes) {
    const int count = std::min(kLanes, n - first);
    float xs[kLanes];
#pragma GCC unroll 8
    for (int l = kLanes - 1; l >= 0; --l) {
      if (l >= count) {
        xs[l] = 0.0f;
        continue;
      }
      const float* row = a + static_cast<ptrdiff_t>(first + l) * stride + first;
      float s = x[first + l];
#pragma GCC unroll 8
      for (int k = kLanes - 1; k > l; --k) s -= row[k] * xs[k];
      xs[l] = s * inv_diag[first + l];
    }
    for (int l = 0; l < count; ++l) x[first + l] = xs[l];
    Block xb, u;
    std::memcpy(&xb, xs, sizeof xb);
    for (int m = 0; m < first; ++m) {
      load_block(u, a + static_cast<ptrdiff_t>(m) * stride + first);
      u *= xb;
      float sum = 0;
      for (int l = 0; l < kLanes; ++l) sum += u[l];
      x[m] -= sum;
    }
  }
  return true;
}

}  // namespace mimic::solver::detail
