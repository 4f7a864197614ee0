// Sparse LU of an iteration matrix on a fixed pattern: the COLAMD ordering and the
// symbolic analysis are done once per pattern, each refresh of the matrix is a numeric
// factorisation only. Shared by the element generalised-alpha integrator (pattern from
// the assembler's triplets, banded) and the multibody integrator (block pattern of
// bodies and joints). Below `dense_below` unknowns the same matrix is factorised densely:
// for a few dozen unknowns a dense LU is cheaper than the supernodal bookkeeping.
#pragma once

#include <Eigen/Dense>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <Eigen/SparseLU>

#include <algorithm>
#include <cstddef>
#include <vector>

namespace pipeflex {

class FixedPatternLU {
   public:
    using Matrix = Eigen::SparseMatrix<double>;

    explicit FixedPatternLU(int dense_below = 0) : dense_below_(dense_below) {}

    // The pattern of the n x n matrix: the (rows[k], cols[k]) pairs (repeats merged);
    // all values zero. Runs the symbolic analysis.
    void analyze(int n, const std::vector<int>& rows, const std::vector<int>& cols) {
        std::vector<Eigen::Triplet<double>> t;
        t.reserve(rows.size());
        for (std::size_t k = 0; k < rows.size(); ++k) t.emplace_back(rows[k], cols[k], 0.0);
        A_.resize(n, n);
        A_.setFromTriplets(t.begin(), t.end());
        A_.makeCompressed();
        if (!dense()) lu_.analyzePattern(A_);
        ++analyses_;
    }

    bool analyzed() const { return analyses_ > 0; }
    long analyses() const { return analyses_; }

    // The matrix, whose values (not pattern) may be written in place before factorize().
    Matrix& matrix() { return A_; }

    // Values from triplets, repeats summed in order; false (values undefined) if an entry
    // lies outside the pattern.
    bool set_values(const std::vector<int>& rows, const std::vector<int>& cols, const std::vector<double>& values) {
        double* val = A_.valuePtr();
        const int* inner = A_.innerIndexPtr();
        const int* outer = A_.outerIndexPtr();
        std::fill(val, val + A_.nonZeros(), 0.0);
        for (std::size_t k = 0; k < values.size(); ++k) {
            const int c = cols[k];
            if (c < 0 || c >= A_.cols()) return false;
            const int* b = inner + outer[c];
            const int* e = inner + outer[c + 1];
            const int* p = std::lower_bound(b, e, rows[k]);
            if (p == e || *p != rows[k]) return false;
            val[p - inner] += values[k];
        }
        return true;
    }

    // Values from triplets; the pattern (and symbolic analysis) is redone only when an
    // entry falls outside the current one. False if the matrix is singular.
    bool factorize(int n, const std::vector<int>& rows, const std::vector<int>& cols,
                   const std::vector<double>& values) {
        if (!analyzed() || A_.rows() != n || !set_values(rows, cols, values)) {
            analyze(n, rows, cols);
            set_values(rows, cols, values);
        }
        return factorize();
    }

    // Numeric factorisation of the current values; false if the matrix is singular.
    bool factorize() {
        if (dense()) {
            dense_A_ = A_;
            dense_lu_.compute(dense_A_);
            const auto d = dense_lu_.matrixLU().diagonal();
            return d.allFinite() && (d.array() != 0.0).all();
        }
        lu_.factorize(A_);
        return lu_.info() == Eigen::Success;
    }

    template <class Rhs, class X>
    void solve(const Rhs& rhs, X& x) {
        if (dense())
            x = dense_lu_.solve(rhs);
        else
            x = lu_.solve(rhs);
    }

   private:
    bool dense() const { return A_.rows() < dense_below_; }

    int dense_below_;
    Eigen::MatrixXd dense_A_;
    Eigen::PartialPivLU<Eigen::MatrixXd> dense_lu_;
    Matrix A_;
    Eigen::SparseLU<Matrix, Eigen::COLAMDOrdering<int>> lu_;
    long analyses_ = 0;
};

}  // namespace pipeflex
