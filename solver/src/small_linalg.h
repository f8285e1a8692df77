// Dense linear algebra for the few tiny systems the functional calibration solves (n ≤ 6).
#pragma once

#include <array>
#include <cmath>
#include <utility>

namespace mimic::solver::detail {

template <int N>
using SquareMatrix = std::array<std::array<double, N>, N>;
template <int N>
using Vector = std::array<double, N>;

// Solves m·x = b by Gaussian elimination with partial pivoting; false if singular.
template <int N>
bool solve_linear(SquareMatrix<N> m, Vector<N> b, Vector<N>& x) {
  for (int c = 0; c < N; ++c) {
    int piv = c;
    for (int r = c + 1; r < N; ++r)
      if (std::abs(m[r][c]) > std::abs(m[piv][c])) piv = r;
    if (!(std::abs(m[piv][c]) > 1e-15)) return false;
    std::swap(m[c], m[piv]);
    std::swap(b[c], b[piv]);
    for (int r = c + 1; r < N; ++r) {
      const double f = m[r][c] / m[c][c];
      for (int k = c; k < N; ++k) m[r][k] -= f * m[c][k];
      b[r] -= f * b[c];
    }
  }
  for (int c = N - 1; c >= 0; --c) {
    double s = b[c];
    for (int k = c + 1; k < N; ++k) s -= m[c][k] * x[k];
    x[c] = s / m[c][c];
    if (!std::isfinite(x[c])) return false;
  }
  return true;
}

// Eigen-decomposition of a symmetric matrix by cyclic Jacobi rotations: eigenvalues descending
// in `w`, eigenvectors in the columns of `v`.
template <int N>
void symmetric_eigen(SquareMatrix<N> a, Vector<N>& w, SquareMatrix<N>& v) {
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) v[i][j] = i == j ? 1.0 : 0.0;
  for (int sweep = 0; sweep < 50; ++sweep) {
    double off = 0;
    for (int p = 0; p < N; ++p)
      for (int q = p + 1; q < N; ++q) off += a[p][q] * a[p][q];
    if (off < 1e-30) break;
    for (int p = 0; p < N - 1; ++p)
      for (int q = p + 1; q < N; ++q) {
        if (std::abs(a[p][q]) < 1e-300) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < N; ++k) {  // a ← a·J
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < N; ++k) {  // a ← Jᵀ·a
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < N; ++k) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  for (int i = 0; i < N; ++i) w[i] = a[i][i];
  for (int i = 0; i < N - 1; ++i)
    for (int j = i + 1; j < N; ++j)
      if (w[j] > w[i]) {
        std::swap(w[i], w[j]);
        for (int k = 0; k < N; ++k) std::swap(v[k][i], v[k][j]);
      }
}

}  // namespace mimic::solver::detail
