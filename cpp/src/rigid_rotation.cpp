#include "pipeflex/solvers/rigid_rotation.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <typeinfo>

namespace pipeflex {

namespace {

Eigen::Matrix3d skew(const Vec3<double>& a) {
    Eigen::Matrix3d S;
    S << 0.0, -a[2], a[1], a[2], 0.0, -a[0], -a[1], a[0], 0.0;
    return S;
}

// the position of a node (zero if the state has no such node: the statics' check of the
// state then throws)
Vec3<double> node_position(const State& s, int node) {
    if (node < 0 || 6 * node + 3 > s.q.size()) return {};
    return {{s.q[6 * node], s.q[6 * node + 1], s.q[6 * node + 2]}};
}

// pinv(T) = (T^T T)^-1 T^T of a basis (full column rank): T^T where its columns are
// orthonormal (coordinate selections: exactly)
Eigen::MatrixXd left_inverse(const Eigen::MatrixXd& T) {
    const Eigen::MatrixXd G = T.transpose() * T;
    if (G.isIdentity(0.0)) return T.transpose();
    return G.ldlt().solve(T.transpose());
}

// F (the model or its unconstrained variant) has the model's nodes and elements
void check_same_nodes(const Model& model, const Model& F) {
    bool same = F.n_nodes() == model.n_nodes() && F.kinds == model.kinds && F.elements.size() == model.elements.size();
    for (std::size_t k = 0; same && k < F.elements.size(); ++k)
        same = typeid(F.elements[k]) == typeid(model.elements[k]) && F.elements[k].nodes() == model.elements[k].nodes();
    if (!same)
        throw std::invalid_argument("rigid rotation: the unconstrained model has other nodes or elements than the "
                                    "model");
}

// Node i's rate operators on F's coordinates (kf of them): E = pinv(T_f) T (kf x k; the
// identity if F is the model: `free` false), Av = pinv(T_f) Bv T_f and Aa = pinv(T_f) Ba
// T_f (kf x kf), Bv and Ba the node's 6 x 6 blocks of the rates' derivatives per unit
// omega and omega^2 (S = skew(axis), S2 = S^2). With `free`, the node's supported
// increments must be F's and Bv must keep F's increments F's.
struct NodeOperators {
    Eigen::MatrixXd E, Av, Aa;
};
NodeOperators node_operators(const Model& model, const Model& F, bool free, int i, const Eigen::Matrix3d& S,
                             const Eigen::Matrix3d& S2) {
    const bool slopes = model.kinds[i] == NodeKind::ancf;
    Eigen::Matrix<double, 6, 6> Bv = Eigen::Matrix<double, 6, 6>::Zero(), Ba = Bv;
    Bv.topLeftCorner<3, 3>() = S;
    Ba.topLeftCorner<3, 3>() = S2;
    // rotation vectors: phi_dot = T(phi)^-1 omega a, T^-1 = I - skew(phi)/2 + ..., and
    // phi_ddot = -T^-1 d/dt[T] phi_dot to first order in phi
    Bv.bottomRightCorner<3, 3>() = slopes ? S : Eigen::Matrix3d(0.5 * S);
    Ba.bottomRightCorner<3, 3>() = slopes ? S2 : Eigen::Matrix3d(S2 / 6.0);
    const Eigen::MatrixXd &T = model.bases[i], &Tf = F.bases[i];
    const int k = static_cast<int>(T.cols());
    const Eigen::MatrixXd Tp = left_inverse(Tf);
    NodeOperators out;
    out.E = free ? Eigen::MatrixXd(Tp * T) : Eigen::MatrixXd::Identity(k, k);
    if ((Tf * out.E - T).lpNorm<Eigen::Infinity>() > 1e-12)
        throw std::invalid_argument("rigid rotation: a node's supported increments are not increments of the "
                                    "unconstrained model");
    if (free && (Tf * Tp * Bv * Tf - Bv * Tf).lpNorm<Eigen::Infinity>() > 1e-12)
        throw std::invalid_argument("rigid rotation: the rotation turns a node's increments out of the "
                                    "unconstrained model's (planar ANCF nodes can only turn about the z axis)");
    out.Av = Tp * Bv * Tf;
    out.Aa = Tp * Ba * Tf;
    return out;
}

// the block diagonal CSC matrix (rows x cols) of per-node blocks at (row0[i], col0[i])
CscMatrix block_diagonal(const std::vector<Eigen::MatrixXd>& blocks, const std::vector<int>& row0,
                         const std::vector<int>& col0, int rows, int cols) {
    CscMatrix X;
    X.rows = rows;
    X.cols = cols;
    X.col_ptr.assign(cols + 1, 0);
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        const Eigen::MatrixXd& b = blocks[i];
        for (int c = 0; c < b.cols(); ++c) {
            for (int r = 0; r < b.rows(); ++r)
                if (b(r, c) != 0.0) {
                    X.row_index.push_back(row0[i] + r);
                    X.values.push_back(b(r, c));
                }
            X.col_ptr[col0[i] + c + 1] = static_cast<int>(X.values.size());
        }
    }
    // columns of no block (none when the nodes' coordinates tile the matrix)
    for (int c = 0; c < cols; ++c) X.col_ptr[c + 1] = std::max(X.col_ptr[c + 1], X.col_ptr[c]);
    return X;
}

}  // namespace

void rigid_rotation_rates(const Model& model, State& s, const Vec3<double>& centre, const Vec3<double>& axis,
                          double omega) {
    const Eigen::Vector3d a(axis[0], axis[1], axis[2]);
    const Eigen::Vector3d xc(centre[0], centre[1], centre[2]);
    for (int i = 0; i < model.n_nodes(); ++i) {
        const Eigen::Vector3d r = s.q.segment<3>(6 * i) - xc;
        const Eigen::Vector3d w = omega * a.cross(r);
        s.v.segment<3>(6 * i) = w;
        s.a.segment<3>(6 * i) = omega * a.cross(w);
        if (model.kinds[i] == NodeKind::ancf) {
            const Eigen::Vector3d d = s.q.segment<3>(6 * i + 3);
            const Eigen::Vector3d wd = omega * a.cross(d);
            s.v.segment<3>(6 * i + 3) = wd;
            s.a.segment<3>(6 * i + 3) = omega * a.cross(wd);
        } else {
            s.v.segment<3>(6 * i + 3) = omega * a;
            s.a.segment<3>(6 * i + 3).setZero();
        }
    }
}

RigidRotationOperators rigid_rotation_operators(const Model& model, const Model& free, const Vec3<double>& axis) {
    check_same_nodes(model, free);
    const Eigen::Matrix3d S = skew(axis), S2 = S * S;
    const int n = model.n_nodes();
    std::vector<Eigen::MatrixXd> E(n), Av(n), Aa(n);
    for (int i = 0; i < n; ++i) {
        NodeOperators o = node_operators(model, free, true, i, S, S2);
        E[i] = std::move(o.E);
        Av[i] = std::move(o.Av);
        Aa[i] = std::move(o.Aa);
    }
    RigidRotationOperators out;
    out.T_rel = block_diagonal(E, free.first_dof, model.first_dof, free.n_dofs, model.n_dofs);
    out.A = block_diagonal(Av, free.first_dof, free.first_dof, free.n_dofs, free.n_dofs);
    out.B = block_diagonal(Aa, free.first_dof, free.first_dof, free.n_dofs, free.n_dofs);
    return out;
}

RigidRotationEquations::RigidRotationEquations(const Model& model, State& state, const LoadState& load,
                                               double length_scale, int hinge_node, const Vec3<double>& axis)
    : RigidRotationEquations(model, state, load, length_scale, node_position(state, hinge_node), axis) {}

RigidRotationEquations::RigidRotationEquations(const Model& model, State& state, const LoadState& load,
                                               double length_scale, const Vec3<double>& hinge_point,
                                               const Vec3<double>& axis, const Model* free)
    : statics_(model, state, load, length_scale), hinge_point_(hinge_point[0], hinge_point[1], hinge_point[2]),
      axis_(axis), assembled_(free != nullptr ? *free : model) {
    const Model& F = assembled_;
    if (free != nullptr) check_same_nodes(model, F);
    // the rates below hold at phi = 0: every iterate is re-based
    Eigen::VectorXd v, a;
    statics_.eq.rebase(0.0, v, a);
    const Eigen::Matrix3d S = skew(axis), S2 = S * S;
    const int n = model.n_dofs, nf = F.n_dofs;
    block_.assign(n, 0);
    block_end_.assign(n, 0);
    weight_.assign(n, 0);
    row_ptr_.assign(nf + 1, 0);
    for (int i = 0; i < model.n_nodes(); ++i) {
        // per node: E = pinv(T_f) T, and the rates' operators on E
        const NodeOperators o = node_operators(model, F, free != nullptr, i, S, S2);
        const Eigen::MatrixXd& E = o.E;
        const int f = model.first_dof[i], k = static_cast<int>(model.bases[i].cols());
        const int ff = F.first_dof[i], kf = static_cast<int>(F.bases[i].cols());
        const Eigen::MatrixXd ev = o.Av * E, ea = o.Aa * E;
        for (int c = 0; c < k; ++c) {
            block_[f + c] = ff;
            block_end_[f + c] = ff + kf;
            weight_[f + c] = static_cast<int>(ek_.size());
            for (int j = 0; j < kf; ++j) {
                ek_.push_back(E(j, c));
                av_.push_back(ev(j, c));
                aa_.push_back(ea(j, c));
            }
        }
        for (int j = 0; j < kf; ++j) {
            for (int c = 0; c < k; ++c)
                if (E(j, c) != 0.0) {
                    row_map_.push_back(f + c);
                    row_weight_.push_back(E(j, c));
                }
            row_ptr_[ff + j + 1] = static_cast<int>(row_map_.size());
        }
    }
    pattern_ = tangent_pattern(F);
    const TangentPattern& P = *pattern_;
    K_.resize(P.nnz());
    C_.resize(P.nnz());
    M_.resize(P.nnz());
    ra_.resize(nf);
    // the tangent's pattern (per column, the rows its block's columns reach through E^T)
    // and each product term's entry, in evaluate's order
    std::vector<int> slot(n, -1);
    for (int c = 0; c < n; ++c) {
        const int start = static_cast<int>(rows_.size());
        for (int j = block_[c]; j < block_end_[c]; ++j)
            for (int p = P.col_ptr[j]; p < P.col_ptr[j + 1]; ++p)
                for (int m = row_ptr_[P.row_index[p]]; m < row_ptr_[P.row_index[p] + 1]; ++m) {
                    const int r = row_map_[m];
                    if (slot[r] < 0) {
                        slot[r] = static_cast<int>(rows_.size());
                        rows_.push_back(r);
                        cols_.push_back(c);
                    }
                    target_.push_back(slot[r]);
                }
        for (int p = start; p < static_cast<int>(rows_.size()); ++p) slot[rows_[p]] = -1;
    }
    values_.resize(rows_.size());
}

void RigidRotationEquations::rigid_rates() {
    const Vec3<double> centre{{hinge_point_[0], hinge_point_[1], hinge_point_[2]}};
    rigid_rotation_rates(statics_.eq.model, statics_.eq.state, centre, axis_, omega_);
}

void RigidRotationEquations::set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                                 const Eigen::VectorXd& lambda, double t) {
    statics_.eq.set(z, v, a, lambda, t);
    rigid_rates();
}

void RigidRotationEquations::evaluate(double wK, double, double, Eigen::VectorXd& residual, Triplets* tangent) {
    if (tangent == nullptr) {
        statics_.eq.evaluate(1.0, 0.0, 0.0, residual, nullptr);
        return;
    }
    // K, C and M in one pass on the pattern, under the statics' loads; the residual
    // assembled_'s (E^T of it: the model's, its supported increments being assembled_'s)
    const ElementEquations& eq = statics_.eq;
    const bool own = &assembled_ == &eq.model;
    double lf;
    const LoadState l = eq.evaluated_load(&lf);
    double* values[3] = {K_.data(), C_.data(), M_.data()};
    assemble_csc(assembled_, eq.state, l, lf, {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}},
                 own ? &residual : &ra_, values, eq.predicted ? eq.geometric_stresses.data() : nullptr);
    const int n = eq.n;
    if (!own) {
        residual.setZero(n);
        for (int ra = 0; ra < assembled_.n_dofs; ++ra)
            for (int m = row_ptr_[ra]; m < row_ptr_[ra + 1]; ++m) residual[row_map_[m]] += row_weight_[m] * ra_[ra];
    }
    // E^T (K E + omega C Av E + omega^2 M Aa E) on the fixed pattern: E, Av, Aa block diagonal
    const TangentPattern& P = *pattern_;
    std::fill(values_.begin(), values_.end(), 0.0);
    const int* t = target_.data();
    const double w2 = omega_ * omega_;
    for (int c = 0; c < n; ++c) {
        const std::size_t w = weight_[c];
        const double *ek = ek_.data() + w, *av = av_.data() + w, *aa = aa_.data() + w;
        for (int j = block_[c]; j < block_end_[c]; ++j, ++ek, ++av, ++aa) {
            const double e = *ek, a = omega_ * *av, b = w2 * *aa;
            for (int p = P.col_ptr[j]; p < P.col_ptr[j + 1]; ++p) {
                const double x = e * K_[p] + a * C_[p] + b * M_[p];
                const int ra = P.row_index[p];
                for (int m = row_ptr_[ra]; m < row_ptr_[ra + 1]; ++m) values_[*t++] += row_weight_[m] * x;
            }
        }
    }
    tangent->rows = rows_;
    tangent->cols = cols_;
    tangent->values.resize(values_.size());
    for (std::size_t k = 0; k < values_.size(); ++k) tangent->values[k] = wK * values_[k];
}

StaticNewtonResult rotating_state(const Model& model, const Model& free, State& state, const LoadState& load,
                                  const Vec3<double>& centre, const Vec3<double>& axis, double omega,
                                  double length_scale, const RotatingStateOptions& opt) {
    if (opt.max_iterations < 1 || !(opt.tol > 0.0) || !(opt.divergence > 0.0))
        throw std::invalid_argument("rotating_state: max_iterations, tol and divergence must be positive");
    RigidRotationEquations eq(model, state, load, length_scale, centre, axis, &free);
    eq.set_omega(omega);
    StaticNewtonOptions nopt;
    nopt.tol = opt.tol;
    nopt.max_iterations = opt.max_iterations;
    nopt.dense_below = opt.dense_below;
    nopt.apply_converged_correction = true;
    nopt.divergence = opt.divergence;
    nopt.divergence_from = 1;  // the rate's continuation halves its step at once
    Eigen::VectorXd lam;
    return static_newton(eq, 0.0, lam, nopt);
}

}  // namespace pipeflex
