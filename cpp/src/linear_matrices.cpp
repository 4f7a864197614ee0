#include "pipeflex/solvers/linear_matrices.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace pipeflex {

bool TangentCsc::same_sources(int n_, int nc_, const std::shared_ptr<const TangentPattern>& block,
                              const std::vector<Triplets>& triplets) const {
    if (builds == 0 || n_ != n || nc_ != nc || block.get() != block_.get() || triplets.size() != rows_.size())
        return false;
    for (std::size_t l = 0; l < triplets.size(); ++l)
        if (triplets[l].rows != rows_[l] || triplets[l].cols != cols_[l]) return false;
    return true;
}

// The union of the block's columns (sorted, no repeats) and the triplets' entries sorted
// by (column, row), merged column by column: O(entries) but for the sort of the triplets
// (a coupled system's: the bodies' and the couplings', a few hundred).
void TangentCsc::build(const std::shared_ptr<const TangentPattern>& block, const std::vector<Triplets>& triplets) {
    ++builds;
    block_ = block;
    const int nb = block ? block->n : 0;
    if (nb > n) throw std::logic_error("TangentCsc: a block of " + std::to_string(nb) + " columns in " +
                                       std::to_string(n));
    struct Entry {
        int col, row, list, k;
    };
    std::vector<Entry> ex;
    const std::size_t lists = triplets.size();
    rows_.resize(lists);
    cols_.resize(lists);
    slot_.resize(lists);
    for (std::size_t l = 0; l < lists; ++l) {
        const Triplets& t = triplets[l];
        rows_[l] = t.rows;
        cols_[l] = t.cols;
        slot_[l].assign(t.rows.size(), kSkip);
        for (std::size_t k = 0; k < t.rows.size(); ++k) {
            const int r = t.rows[k], c = t.cols[k];
            if (r < 0 || r >= n + nc || c < 0 || c >= n + nc)
                throw std::logic_error("TangentCsc: entry (" + std::to_string(r) + ", " + std::to_string(c) +
                                       ") outside the " + std::to_string(n + nc) + "-square tangent");
            if (c < n) ex.push_back({c, r, static_cast<int>(l), static_cast<int>(k)});
        }
    }
    std::sort(ex.begin(), ex.end(), [](const Entry& a, const Entry& b) {
        return a.col != b.col ? a.col < b.col : a.row < b.row;
    });
    top = CscMatrix{n, n, std::vector<int>(n + 1, 0), {}, {}};
    bottom = CscMatrix{nc, n, std::vector<int>(n + 1, 0), {}, {}};
    top.row_index.reserve((block ? block->nnz() : 0) + ex.size());
    std::vector<int> placed(block ? block->nnz() : 0);
    std::size_t e = 0;
    for (int c = 0; c < n; ++c) {
        int bi = c < nb ? block->col_ptr[c] : 0;
        const int be = c < nb ? block->col_ptr[c + 1] : 0;
        const std::size_t top0 = top.row_index.size(), bottom0 = bottom.row_index.size();
        while (bi < be || (e < ex.size() && ex[e].col == c)) {
            const bool from_block = bi < be && (e >= ex.size() || ex[e].col != c || block->row_index[bi] <= ex[e].row);
            const int r = from_block ? block->row_index[bi] : ex[e].row;
            int s;
            if (r < n) {
                if (top.row_index.size() == top0 || top.row_index.back() != r) top.row_index.push_back(r);
                s = static_cast<int>(top.row_index.size()) - 1;
            } else {
                if (bottom.row_index.size() == bottom0 || bottom.row_index.back() != r - n)
                    bottom.row_index.push_back(r - n);
                s = -static_cast<int>(bottom.row_index.size());  // -1 - slot
            }
            if (from_block) {
                placed[bi++] = s;
            } else {
                slot_[ex[e].list][ex[e].k] = s;
                ++e;
            }
        }
        top.col_ptr[c + 1] = static_cast<int>(top.row_index.size());
        bottom.col_ptr[c + 1] = static_cast<int>(bottom.row_index.size());
    }
    block_slot_.clear();
    if (block) {
        block_slot_.resize(block->slot.size());
        for (std::size_t k = 0; k < block->slot.size(); ++k) block_slot_[k] = placed[block->slot[k]];
    }
}

void TangentCsc::assemble(int n_, int nc_, int nw, const std::shared_ptr<const TangentPattern>& block,
                          const BlockFill& fill, const std::vector<Triplets>& triplets) {
    if (!triplets.empty() && static_cast<int>(triplets.size()) != nw)
        throw std::logic_error("TangentCsc: " + std::to_string(triplets.size()) + " triplet lists for " +
                               std::to_string(nw) + " weight sets");
    if (!same_sources(n_, nc_, block, triplets)) {
        n = n_;
        nc = nc_;
        build(block, triplets);
    }
    top_values.resize(nw);
    bottom_values.resize(nw);
    std::vector<double*> ptr(nw);
    for (int w = 0; w < nw; ++w) {
        top_values[w].assign(top.row_index.size(), 0.0);
        bottom_values[w].assign(bottom.row_index.size(), 0.0);
        ptr[w] = top_values[w].data();
    }
    if (block) fill(block_slot_.data(), ptr.data());
    for (std::size_t l = 0; l < triplets.size(); ++l) {
        const std::vector<double>& v = triplets[l].values;
        const int* s = slot_[l].data();
        double* tv = top_values[l].data();
        double* bv = bottom_values[l].data();
        for (std::size_t k = 0; k < v.size(); ++k) {
            const int sk = s[k];
            if (sk >= 0)
                tv[sk] += v[k];
            else if (sk != kSkip)
                bv[-1 - sk] += v[k];
        }
    }
}

namespace {
// The pattern's copy with values (moved out of the TangentCsc: it keeps the pattern only)
CscMatrix with_values(const CscMatrix& pattern, std::vector<double>& values) {
    CscMatrix m;
    m.rows = pattern.rows;
    m.cols = pattern.cols;
    m.col_ptr = pattern.col_ptr;
    m.row_index = pattern.row_index;
    m.values = std::move(values);
    return m;
}
}  // namespace

LinearMatrices linear_matrices(Equations& eq, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                               const Eigen::VectorXd& lam, double t, double differences_step, TangentCsc* pattern) {
    LinearMatrices out;
    out.n = eq.n_coordinates();
    out.nc = eq.n_constraints();
    eq.set_static_load_factor(1.0);
    eq.set(Eigen::VectorXd::Zero(out.n), v, a, lam, t);
    TangentCsc local;
    TangentCsc& tc = pattern != nullptr ? *pattern : local;
    eq.tangents_csc({{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}}, tc);
    if (tc.n != out.n || tc.nc != out.nc || tc.top_values.size() != 3)
        throw std::logic_error("linear_matrices: the equations' tangents_csc gave another size");
    out.K = with_values(tc.top, tc.top_values[0]);
    out.C = with_values(tc.top, tc.top_values[1]);
    out.M = with_values(tc.top, tc.top_values[2]);
    out.Cq = with_values(tc.bottom, tc.bottom_values[0]);  // the constraint rows of K's tangent
    if (differences_step > 0.0) out.differences = residual_differences(eq, v, a, lam, t, differences_step);
    return out;
}

Eigen::MatrixXd residual_differences(Equations& eq, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                                     const Eigen::VectorXd& lam, double t, double h) {
    const int n = eq.n_coordinates(), nc = eq.n_constraints();
    eq.set_static_load_factor(1.0);
    Eigen::MatrixXd D(n + nc, n);
    Eigen::VectorXd z = Eigen::VectorXd::Zero(n), rp, rm;
    for (int j = 0; j < n; ++j) {
        z[j] = h;
        eq.set(z, v, a, lam, t);
        eq.evaluate(1.0, 0.0, 0.0, rp, nullptr);
        z[j] = -h;
        eq.set(z, v, a, lam, t);
        eq.evaluate(1.0, 0.0, 0.0, rm, nullptr);
        z[j] = 0.0;
        D.col(j) = (rp - rm) / (2.0 * h);
    }
    eq.set(z, v, a, lam, t);
    return D;
}

}  // namespace pipeflex
