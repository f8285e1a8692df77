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
// row[0..kLanes) −= u·src[0..kLanes)
inline void sub_scaled_block(float* row, float u, const float* src) {
  Block r, x;
  load_block(r, row);
  load_block(x, src);
  r -= u * x;
  store_block(row, r);
}

// Row stride for n unknowns: a multiple of kLanes with at least kLanes − 1 zeros after each row,
// so that a block starting at any column before n stays inside the row.
inline int padded_stride(int n) { return (n + 2 * kLanes - 2) / kLanes * kLanes; }

// Where a row can be non-zero right of its diagonal: spans of columns, pairs (first, one past
// the last), ascending, at least kLanes apart (a block run to a span's end may spill up to
// kLanes − 1 columns past it: those are zeros of the row, or its padding, never the next span).
// Columns at or left of the diagonal are ignored.
struct ColumnSpans {
  const int* pairs = nullptr;
  int count = 0;
};

// row[k] −= u·src[k] for k from `from` to the end of span q, then every later span, in blocks.
inline void axpy_spans(float* __restrict row, const float* __restrict src, float u, int from, const int* pairs, int q,
                       int count) {
  for (; q < count; ++q) {
    for (int k = std::max(from, pairs[2 * q]); k < pairs[2 * q + 1]; k += kLanes) sub_scaled_block(row + k, u, src + k);
  }
}

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

// In-place Cholesky solve of the SPD n×n system a·x = b (x overwrites b; rows of `stride` floats,
// padded with zeros, b too); false if not SPD. Only the upper triangle of `a` is read; it becomes
// U with UᵀU = a. `spans(i)` must cover row i's non-zeros right of i, closed under elimination
// (every earlier row touching column i is non-zero right of i only inside row i's spans: the
// least squares' elimination order guarantees it, no fill-in), and `reaching` list them by
// column (list_reaching_rows). Up-looking, row by row: row i is a_i − Σ_m u_mi·u_m over the
// earlier rows m that reach it, summed block by block in registers and stored once, over row
// i's spans only (one arm's DOFs never touch the other arm's or the neck's). The back
// substitution runs down the columns (an update per non-zero) rather than by dot products,
// whose sums would each wait on the unknown just found. `inv_diag` is scratch for n floats.
template <typename Spans>
bool cholesky_solve(float* a, float* b, int n, int stride, const Spans& spans, const ReachingRows& reaching,
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
        Block acc[4] = {}, x;
        load_block(acc[0], ai + k);
        int t = 0;
        for (; t + 4 <= n_rows; t += 4)
          for (int r = 0; r < 4; ++r) {
            const float* am = a + static_cast<ptrdiff_t>(rows[t + r]) * stride;
            load_block(x, am + k);
            acc[r] -= am[i] * x;
          }
        for (; t < n_rows; ++t) {
          const float* am = a + static_cast<ptrdiff_t>(rows[t]) * stride;
          load_block(x, am + k);
          acc[0] -= am[i] * x;
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
    for (int q = 0; q < si.count; ++q)
      for (int k = std::max(si.pairs[2 * q], i + 1); k < si.pairs[2 * q + 1]; ++k) ai[k] *= inv_d;
  }
  for (int j = 0; j < n; ++j) {  // Uᵀ·y = b
    const float* __restrict aj = a + static_cast<ptrdiff_t>(j) * stride;
    const float y = b[j] * inv_diag[j];
    b[j] = y;
    const ColumnSpans sj = spans(j);
    if (y != 0.0f && sj.count > 0) axpy_spans(b, aj, y, j + 1, sj.pairs, 0, sj.count);
  }
  for (int j = n - 1; j >= 0; --j) {  // U·x = y
    const float x = b[j] * inv_diag[j];
    b[j] = x;
    const int* rows = reaching.rows + reaching.first[j];
    for (int t = 0; t < reaching.count[j]; ++t) b[rows[t]] -= a[static_cast<ptrdiff_t>(rows[t]) * stride + j] * x;
  }
  return true;
}

}  // namespace mimic::solver::detail
