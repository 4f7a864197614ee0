// A system's tangents in compressed columns on a pattern kept across calls: what the
// linearisation (K, C, M, C_q) takes from any Equations without triplets.
#pragma once

#include "pipeflex/assembly/model.hpp"

#include <climits>
#include <functional>
#include <memory>
#include <vector>

namespace pipeflex {

// A rows x cols sparse matrix in compressed columns: col_ptr (cols + 1), row_index (rows
// ascending within each column, no repeats) and values (nnz; zeros included: the pattern
// holds whatever the sources emit).
struct CscMatrix {
    int rows = 0, cols = 0;
    std::vector<int> col_ptr, row_index;
    std::vector<double> values;
};

// The first n columns of an (n + nc) x (n + nc) tangent (Equations::evaluate's, s = 1) for
// each of several weight sets, split into the coordinate rows (n x n, `top`) and the
// constraint rows (nc x n, `bottom`), every weight set on the same pattern (the union of
// what they emit). The pattern and the place of every emitted entry in it are built from
// the entries' sources:
//  - a block assembled on a fixed CSC pattern (an element model's TangentPattern, at rows
//    and columns 0..): the slot of each entry its assembler emits, composed with the place
//    of that pattern's entries in this one, so that the assembler writes straight here;
//  - triplets (one list per weight set; they may differ: a coupling's geometric stiffness
//    appears in K only).
// A later call with the same sources (the same block pattern object, the same (row, col)
// sequence of every triplet list: compared on every call, O(entries)) only writes values;
// a change rebuilds the pattern (a coupling whose multipliers become nonzero adds its
// geometric stiffness's entries).
class TangentCsc {
   public:
    // Writes the block's values of every weight set: values[i] (top_values(i)) at
    // slot[k] for the k-th entry the assembler emits (added; the values start at zero).
    using BlockFill = std::function<void(const int* slot, double* const* values)>;

    // The tangents of nw = triplets.size() weight sets (or, without triplets, of nw block
    // weight sets) of a system of n coordinates and nc constraints from the sources: the
    // block (null: none; else fill writes it) and the triplets (empty: none).
    void assemble(int n, int nc, int nw, const std::shared_ptr<const TangentPattern>& block, const BlockFill& fill,
                  const std::vector<Triplets>& triplets);

    int n = 0, nc = 0;
    // patterns (values unused) and values per weight set
    CscMatrix top, bottom;
    std::vector<std::vector<double>> top_values, bottom_values;
    int builds = 0;  // how many times the pattern was built (kept across calls: tests)

   private:
    bool same_sources(int n_, int nc_, const std::shared_ptr<const TangentPattern>& block,
                      const std::vector<Triplets>& triplets) const;
    void build(const std::shared_ptr<const TangentPattern>& block, const std::vector<Triplets>& triplets);
    // encodes a triplet's place: >= 0 a top slot, kSkip a column >= n, else bottom slot -1 - s
    static constexpr int kSkip = INT_MIN;
    std::shared_ptr<const TangentPattern> block_;
    std::vector<int> block_slot_;  // per entry the block's assembler emits
    std::vector<std::vector<int>> rows_, cols_, slot_;  // per triplet list
};

}  // namespace pipeflex
