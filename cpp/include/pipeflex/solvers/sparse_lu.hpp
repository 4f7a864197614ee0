// LU of an iteration matrix on a fixed pattern, refreshed many times: the storage (and,
// if sparse, the place of every triplet in it, the COLAMD ordering and the symbolic
// analysis) is set up once per pattern; each refresh scatters the values (triplets, or
// written into the compressed matrix()) and factorises numerically.
// Shared by the element generalised-alpha integrator (pattern from the assembler's
// triplets), the multibody integrator (block pattern of bodies and joints) and statics.
// Three storages, chosen from the pattern:
//  - dense below `dense_below` unknowns (for a few dozen unknowns a dense LU is cheaper
//    than the supernodal bookkeeping), unless `band_first` and the pattern fits the band;
//  - banded when every entry lies within a few dozen diagonals of the main one, and the
//    band holds few more entries than the pattern: a chain of elements numbered along
//    the chain (half-bandwidth 11 for 6 coordinates per node). Partial pivoting within the
//    band (LAPACK's dgbtf2 scheme): no ordering, no symbolic work, and a few times faster
//    than the sparse LU on such a pattern (docs/performance.md);
//  - sparse (Eigen SparseLU, COLAMD) otherwise, e.g. constraint rows coupling distant
//    coordinates.
#pragma once

#include <Eigen/Dense>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <Eigen/SparseLU>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace pipeflex {

// Below this many unknowns an iteration matrix is factorised densely (measured crossover
// of the dense and the sparse LU): the integrators', IDA's and the static Newton's.
constexpr int kDenseLuBelow = 100;

class FixedPatternLU {
   public:
    using Matrix = Eigen::SparseMatrix<double>;
    enum class Storage { dense, band, sparse };

    // The band is used when neither half-bandwidth exceeds this...
    static constexpr int kBandMaxHalfWidth = 32;
    // ...and the band stores at most this many times the pattern's entries.
    static constexpr int kBandMaxFill = 8;

    // band_first: a pattern that fits the band takes it even below dense_below (generalised-
    // alpha's iteration matrix of a pipe of 8 elements: factors in 5 us instead of 16-19 us).
    // Not the statics' default: the steady rotation of seed 004's two-element semicircle (a
    // coarse model: 0.11 rad/s against the finer meshes' 5.1-5.2) no longer converged with
    // the band LU's other round-off.
    explicit FixedPatternLU(int dense_below = 0, bool band_first = false)
        : dense_below_(dense_below), band_first_(band_first) {}
    // A copy holds the same analysed pattern (e.g. one LU per step on one pattern); Eigen's
    // SparseLU cannot be copied, so a sparse copy runs its symbolic analysis again.
    FixedPatternLU(const FixedPatternLU& o)
        : dense_below_(o.dense_below_), band_first_(o.band_first_), storage_(o.storage_), n_(o.n_),
          kl_(o.kl_), ku_(o.ku_), ld_(o.ld_), inv_diag_(o.inv_diag_), uw_(o.uw_), rows_(o.rows_), cols_(o.cols_), slot_(o.slot_),
          dense_A_(o.dense_A_), dense_lu_(o.dense_lu_), band_(o.band_), pivots_(o.pivots_), A_(o.A_),
          analyses_(o.analyses_) {
        if (storage_ == Storage::sparse && analyzed()) lu_.analyzePattern(A_);
    }
    FixedPatternLU& operator=(const FixedPatternLU&) = delete;

    // The pattern of the n x n matrix: the (rows[k], cols[k]) pairs (repeats merged),
    // all values zero. Chooses the storage and, if sparse, places every triplet and runs
    // the symbolic analysis. False if an entry lies outside the matrix.
    bool analyze(int n, const std::vector<int>& rows, const std::vector<int>& cols) {
        n_ = n;
        rows_.clear();
        cols_.clear();
        kl_ = ku_ = 0;
        for (std::size_t k = 0; k < rows.size(); ++k) {
            if (rows[k] < 0 || rows[k] >= n || cols[k] < 0 || cols[k] >= n) return false;
            kl_ = std::max(kl_, rows[k] - cols[k]);
            ku_ = std::max(ku_, cols[k] - rows[k]);
        }
        ++analyses_;
        std::vector<Eigen::Triplet<double>> t;
        t.reserve(rows.size());
        for (std::size_t k = 0; k < rows.size(); ++k) t.emplace_back(rows[k], cols[k], 0.0);
        A_.resize(n, n);
        A_.setFromTriplets(t.begin(), t.end());
        A_.makeCompressed();
        ld_ = 2 * kl_ + ku_ + 1;  // kl rows above the band for the fill of row exchanges
        const bool band = std::max(kl_, ku_) <= kBandMaxHalfWidth &&
                          static_cast<double>(ld_) * n <= static_cast<double>(kBandMaxFill) * A_.nonZeros();
        if (n < dense_below_ && !(band_first_ && band)) {
            storage_ = Storage::dense;
            dense_A_.resize(n, n);
            return true;
        }
        if (band) {
            storage_ = Storage::band;
            band_.resize(static_cast<std::size_t>(ld_) * n);
            pivots_.resize(n);
            inv_diag_.resize(n);
            return true;
        }
        storage_ = Storage::sparse;
        rows_ = rows;
        cols_ = cols;
        const int* inner = A_.innerIndexPtr();
        const int* outer = A_.outerIndexPtr();
        slot_.resize(rows.size());
        for (std::size_t k = 0; k < rows.size(); ++k) {
            const int* b = inner + outer[cols[k]];
            const int* e = inner + outer[cols[k] + 1];
            slot_[k] = static_cast<int>(std::lower_bound(b, e, rows[k]) - inner);
        }
        lu_.analyzePattern(A_);
        return true;
    }

    bool analyzed() const { return analyses_ > 0; }
    // Frees the matrix (its values and dense copy), keeping the factors: solve() still
    // works, factorize() needs analyze() again. For factorisations kept by the thousand
    // (the flow map's tangent-linear steps).
    void keep_factors_only() {
        A_ = Matrix();
        dense_A_ = Eigen::MatrixXd();
        rows_.clear();
        cols_.clear();
        slot_.clear();
        analyses_ = 0;
    }

    // Memory held by the storage and the factors [bytes].
    std::size_t bytes() const {
        const std::size_t d = sizeof(double), i = sizeof(int);
        std::size_t b = (d + i) * static_cast<std::size_t>(A_.nonZeros());
        switch (storage_) {
            case Storage::dense: return b + 2 * d * static_cast<std::size_t>(dense_A_.size());
            case Storage::band: return b + d * band_.size() + i * pivots_.size();
            case Storage::sparse:
                return b + (d + i) * static_cast<std::size_t>(lu_.nnzL() + lu_.nnzU());
        }
        return b;
    }
    long analyses() const { return analyses_; }
    Storage storage() const { return storage_; }

    // The analysed pattern as a compressed sparse matrix, whose values (not pattern) may
    // be written in place before factorize(). The triplet factorize() does not fill it.
    Matrix& matrix() { return A_; }

    // Values from triplets (repeats summed). The pattern is analysed again when an entry
    // falls outside the storage (dense, band) or the triplets' positions differ from the
    // last analysed ones (sparse). False if the matrix is singular or an entry lies
    // outside it.
    bool factorize(int n, const std::vector<int>& rows, const std::vector<int>& cols,
                   const std::vector<double>& values) {
        if (!analyzed() || n != n_) {
            if (!analyze(n, rows, cols)) return false;
        }
        if (!scatter(rows, cols, values)) {
            if (!analyze(n, rows, cols) || !scatter(rows, cols, values)) return false;
        }
        return factorize_storage();
    }

    // A dense matrix factorised as it is (no pattern: dense storage); false if singular.
    bool factorize_dense(const Eigen::MatrixXd& A) {
        storage_ = Storage::dense;
        n_ = static_cast<int>(A.rows());
        dense_lu_.compute(A);
        const auto d = dense_lu_.matrixLU().diagonal();
        return d.allFinite() && (d.array() != 0.0).all();
    }

    // Numeric factorisation of the values written into matrix(); false if singular.
    bool factorize() {
        if (storage_ == Storage::dense) {
            dense_A_ = A_;
        } else if (storage_ == Storage::band) {
            std::fill(band_.begin(), band_.end(), 0.0);
            const int* inner = A_.innerIndexPtr();
            const int* outer = A_.outerIndexPtr();
            const double* val = A_.valuePtr();
            for (int j = 0; j < n_; ++j)
                for (int p = outer[j]; p < outer[j + 1]; ++p) band_[band_index(inner[p], j)] = val[p];
        }
        return factorize_storage();
    }

    // x = A^-1 rhs (a vector or the columns of a matrix).
    template <class Rhs, class X>
    void solve(const Rhs& rhs, X& x) {
        switch (storage_) {
            case Storage::dense:
                x = dense_lu_.solve(rhs);
                return;
            case Storage::band:
                x = rhs;
                for (Eigen::Index c = 0; c < x.cols(); ++c) band_solve(x.col(c).data());
                return;
            case Storage::sparse:
                x = lu_.solve(rhs);
                return;
        }
    }

   private:
    // Numeric factorisation of the values in the storage; false if singular.
    bool factorize_storage() {
        switch (storage_) {
            case Storage::dense:
                return factorize_dense(dense_A_);
            case Storage::band:
                return band_factorize();
            case Storage::sparse:
                lu_.factorize(A_);
                return lu_.info() == Eigen::Success;
        }
        return false;
    }

    // The values into the storage; false if an entry does not fit it.
    bool scatter(const std::vector<int>& rows, const std::vector<int>& cols, const std::vector<double>& values) {
        const std::size_t m = values.size();
        switch (storage_) {
            case Storage::dense: {
                dense_A_.setZero();
                double* a = dense_A_.data();
                for (std::size_t k = 0; k < m; ++k) {
                    const int i = rows[k], j = cols[k];
                    if (i < 0 || i >= n_ || j < 0 || j >= n_) return false;
                    a[static_cast<std::ptrdiff_t>(j) * n_ + i] += values[k];
                }
                return true;
            }
            case Storage::band: {
                std::fill(band_.begin(), band_.end(), 0.0);
                double* a = band_.data();
                for (std::size_t k = 0; k < m; ++k) {
                    const int i = rows[k], j = cols[k];
                    if (i - j > kl_ || j - i > ku_ || i < 0 || i >= n_ || j < 0 || j >= n_) return false;
                    a[band_index(i, j)] += values[k];
                }
                return true;
            }
            case Storage::sparse: {
                if (rows != rows_ || cols != cols_) return false;
                double* a = A_.valuePtr();
                std::fill(a, a + A_.nonZeros(), 0.0);
                for (std::size_t k = 0; k < m; ++k) a[slot_[k]] += values[k];
                return true;
            }
        }
        return false;
    }

    // Place of A(i, j) in the band: column-major, kl + ku + i - j in column j.
    std::ptrdiff_t band_index(int i, int j) const {
        return static_cast<std::ptrdiff_t>(j) * ld_ + (kl_ + ku_ + i - j);
    }

    // LU with partial pivoting inside the band (LAPACK dgbtf2): row exchanges widen U to
    // kl + ku diagonals, held in the kl rows above the band.
    bool band_factorize() {
        const int n = n_, kv = kl_ + ku_;
        double* ab = band_.data();
        int ju = 0;  // last column touched by the row exchanges so far
        uw_ = ku_;
        for (int j = 0; j < n; ++j) {
            double* col = ab + static_cast<std::ptrdiff_t>(j) * ld_ + kv;  // col[i] = A(j + i, j)
            const int km = std::min(kl_, n - 1 - j);
            int jp = 0;
            double big = std::abs(col[0]);
            for (int i = 1; i <= km; ++i)
                if (std::abs(col[i]) > big) {
                    big = std::abs(col[i]);
                    jp = i;
                }
            pivots_[j] = j + jp;
            if (!(big > 0.0) || !std::isfinite(big)) return false;
            ju = std::max(ju, std::min(j + ku_ + jp, n - 1));
            uw_ = std::max(uw_, ju - j);
            if (jp != 0)
                for (int c = j; c <= ju; ++c) std::swap(ab[band_index(j, c)], ab[band_index(j + jp, c)]);
            const double inv = 1.0 / col[0];
            inv_diag_[j] = inv;  // the solve multiplies: a division's latency per unknown in its chain
            if (km == 0) continue;
            for (int i = 1; i <= km; ++i) col[i] *= inv;
            for (int c = j + 1; c <= ju; ++c) {
                double* cc = ab + band_index(j, c);  // cc[i] = A(j + i, c)
                const double t = cc[0];
                if (t == 0.0) continue;
                for (int i = 1; i <= km; ++i) cc[i] -= t * col[i];
            }
        }
        return true;
    }

    void band_solve(double* b) const {
        const int n = n_, kv = kl_ + ku_;
        const double* ab = band_.data();
        for (int j = 0; j < n; ++j) {  // L y = P b
            const int p = pivots_[j];
            if (p != j) std::swap(b[j], b[p]);
            const int km = std::min(kl_, n - 1 - j);
            const double t = b[j];
            if (t == 0.0) continue;
            const double* col = ab + static_cast<std::ptrdiff_t>(j) * ld_ + kv;
            for (int i = 1; i <= km; ++i) b[j + i] -= t * col[i];
        }
        for (int j = n - 1; j >= 0; --j) {  // U x = y
            const double* col = ab + static_cast<std::ptrdiff_t>(j) * ld_ + kv;  // col[i] = U(j + i, j)
            b[j] *= inv_diag_[j];
            const double t = b[j];
            if (t == 0.0) continue;
            const int top = std::max(0, j - uw_);  // above U's width only the band's zeros
            for (int i = top; i < j; ++i) b[i] -= t * col[i - j];
        }
    }

    int dense_below_;
    bool band_first_;
    Storage storage_ = Storage::sparse;
    int n_ = -1, kl_ = 0, ku_ = 0, ld_ = 0;
    std::vector<double> inv_diag_;  // band: 1 / U(j, j)
    int uw_ = 0;  // band: U's upper width, ku plus the widening by row exchanges (<= kl + ku)
    std::vector<int> rows_, cols_;  // sparse: the pattern analysed, as triplets,
    std::vector<int> slot_;         // and the place of each triplet's value
    Eigen::MatrixXd dense_A_;
    Eigen::PartialPivLU<Eigen::MatrixXd> dense_lu_;
    std::vector<double> band_;
    std::vector<int> pivots_;
    Matrix A_;
    Eigen::SparseLU<Matrix, Eigen::COLAMDOrdering<int>> lu_;
    long analyses_ = 0;
};

}  // namespace pipeflex
