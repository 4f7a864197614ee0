#include "pipeflex/solvers/rigid_rotation.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <stdexcept>

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

}  // namespace

RigidRotationEquations::RigidRotationEquations(const Model& model, State& state, const LoadState& load,
                                               double length_scale, int hinge_node, const Vec3<double>& axis)
    : RigidRotationEquations(model, state, load, length_scale, node_position(state, hinge_node), axis) {}

RigidRotationEquations::RigidRotationEquations(const Model& model, State& state, const LoadState& load,
                                               double length_scale, const Vec3<double>& hinge_point,
                                               const Vec3<double>& axis)
    : statics_(model, state, load, length_scale), hinge_point_(hinge_point[0], hinge_point[1], hinge_point[2]),
      axis_(axis) {
    // the rates below hold at phi = 0: every iterate is re-based
    Eigen::VectorXd v, a;
    statics_.eq.rebase(0.0, v, a);
    const Eigen::Matrix3d S = skew(axis), S2 = S * S;
    Eigen::Matrix<double, 6, 6> Bv = Eigen::Matrix<double, 6, 6>::Zero(), Ba = Bv;
    Bv.topLeftCorner<3, 3>() = S;
    Bv.bottomRightCorner<3, 3>() = 0.5 * S;   // phi_dot = T(phi)^-1 omega a, T^-1 = I - skew(phi)/2 + ...
    Ba.topLeftCorner<3, 3>() = S2;
    Ba.bottomRightCorner<3, 3>() = S2 / 6.0;  // phi_ddot = -T^-1 d/dt[T] phi_dot to first order in phi
    const int n = model.n_dofs;
    block_.assign(n, 0);
    block_end_.assign(n, 0);
    weight_.assign(n, 0);
    for (int i = 0; i < model.n_nodes(); ++i) {  // T_n^T B T_n per node
        const Eigen::MatrixXd& T = model.bases[i];
        const int f = model.first_dof[i], k = static_cast<int>(T.cols());
        const Eigen::MatrixXd bv = T.transpose() * Bv * T, ba = T.transpose() * Ba * T;
        for (int c = 0; c < k; ++c) {
            block_[f + c] = f;
            block_end_[f + c] = f + k;
            weight_[f + c] = static_cast<int>(av_.size());
            for (int j = 0; j < k; ++j) {
                av_.push_back(bv(j, c));
                aa_.push_back(ba(j, c));
            }
        }
    }
    pattern_ = tangent_pattern(model);
    const TangentPattern& P = *pattern_;
    K_.resize(P.nnz());
    C_.resize(P.nnz());
    M_.resize(P.nnz());
    // the tangent's pattern: per column, the rows of its block's columns (K's among them)
    std::vector<int> slot(n, -1), first(n + 1, 0);
    for (int c = 0; c < n; ++c) {
        first[c] = static_cast<int>(rows_.size());
        for (int j = block_[c]; j < block_end_[c]; ++j)
            for (int p = P.col_ptr[j]; p < P.col_ptr[j + 1]; ++p) {
                const int r = P.row_index[p];
                if (slot[r] >= 0) continue;
                slot[r] = static_cast<int>(rows_.size());
                rows_.push_back(r);
                cols_.push_back(c);
            }
        for (int p = first[c]; p < static_cast<int>(rows_.size()); ++p) slot[rows_[p]] = -1;
    }
    first[n] = static_cast<int>(rows_.size());
    const auto find = [&](int r, int c) {
        return static_cast<int>(std::find(rows_.begin() + first[c], rows_.begin() + first[c + 1], r) - rows_.begin());
    };
    for (int c = 0; c < n; ++c)
        for (int p = P.col_ptr[c]; p < P.col_ptr[c + 1]; ++p) target_.push_back(find(P.row_index[p], c));
    for (int c = 0; c < n; ++c)
        for (int j = block_[c]; j < block_end_[c]; ++j)
            for (int p = P.col_ptr[j]; p < P.col_ptr[j + 1]; ++p) target_.push_back(find(P.row_index[p], c));
    values_.resize(rows_.size());
}

void RigidRotationEquations::rigid_rates() {
    State& s = statics_.eq.state;
    const Eigen::Vector3d a(axis_[0], axis_[1], axis_[2]);
    const Eigen::Vector3d& xh = hinge_point_;
    for (int i = 0; i < statics_.eq.model.n_nodes(); ++i) {
        const Eigen::Vector3d r = s.q.segment<3>(6 * i) - xh;
        const Eigen::Vector3d w = omega_ * a.cross(r);
        s.v.segment<3>(6 * i) = w;
        s.v.segment<3>(6 * i + 3) = omega_ * a;
        s.a.segment<3>(6 * i) = omega_ * a.cross(w);
        s.a.segment<3>(6 * i + 3).setZero();
    }
}

void RigidRotationEquations::set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                                 const Eigen::VectorXd& lambda, double t) {
    statics_.eq.set(z, v, a, lambda, t);
    rigid_rates();
}

const Eigen::VectorXd& RigidRotationEquations::residual_at(double w) {
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(statics_.eq.n);
    const double kept = omega_;
    omega_ = w;
    set(zero, zero, zero, zero, 0.0);
    evaluate(1.0, 0.0, 0.0, r_, nullptr);
    set_omega(kept);
    return r_;
}

void RigidRotationEquations::evaluate(double wK, double, double, Eigen::VectorXd& residual, Triplets* tangent) {
    if (tangent == nullptr) {
        statics_.eq.evaluate(1.0, 0.0, 0.0, residual, nullptr);
        return;
    }
    // K, C and M in one pass on the model's pattern, under the statics' loads
    const ElementEquations& eq = statics_.eq;
    double lf;
    const LoadState l = eq.evaluated_load(&lf);
    double* values[3] = {K_.data(), C_.data(), M_.data()};
    assemble_csc(eq.model, eq.state, l, lf, {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}}, &residual, values,
                 eq.predicted ? eq.geometric_stresses.data() : nullptr);
    // K + omega C Av + omega^2 M Aa on the fixed pattern: Av and Aa are block diagonal
    const TangentPattern& P = *pattern_;
    const int n = eq.n;
    std::fill(values_.begin(), values_.end(), 0.0);
    const int* t = target_.data();
    for (std::size_t p = 0; p < P.nnz(); ++p) values_[*t++] += K_[p];
    const double w2 = omega_ * omega_;
    for (int c = 0; c < n; ++c) {
        const double *av = av_.data() + weight_[c], *aa = aa_.data() + weight_[c];
        for (int j = block_[c]; j < block_end_[c]; ++j, ++av, ++aa) {
            const double a = omega_ * *av, b = w2 * *aa;
            for (int p = P.col_ptr[j]; p < P.col_ptr[j + 1]; ++p) values_[*t++] += a * C_[p] + b * M_[p];
        }
    }
    tangent->rows = rows_;
    tangent->cols = cols_;
    tangent->values.resize(values_.size());
    for (std::size_t k = 0; k < values_.size(); ++k) tangent->values[k] = wK * values_[k];
}

double RotationRateBorder::constraint(Eigen::VectorXd* c, double* d) const {
    if (c != nullptr) {
        *c = Eigen::VectorXd::Zero(eq.n_coordinates());
        (*c)[hinge_dof] = 1.0;
        *d = 0.0;
    }
    return increment;
}

namespace {

// omega balancing the hinge moment of the state set (secant iterations from 0 and 1 rad/s)
double rigid_guess(RigidRotationEquations& eq, int hinge_dof) {
    const auto moment = [&](double w) { return eq.residual_at(w)[hinge_dof]; };
    double w0 = 0.0, w1 = 1.0, f0 = moment(w0), f1 = moment(w1);
    for (int k = 0; k < 50; ++k) {
        if (f1 == f0) break;
        const double w = w1 - f1 * (w1 - w0) / (f1 - f0);
        w0 = w1;
        f0 = f1;
        w1 = w;
        f1 = moment(w1);
        if (std::abs(w1 - w0) <= 1e-10 * std::max(1.0, std::abs(w1))) break;
    }
    return w1;
}

}  // namespace

SteadyRotationOutcome steady_rotation(const Model& model, State& state, const LoadState& load, int hinge_node,
                                      int hinge_dof, const Vec3<double>& axis, double omega_guess,
                                      double length_scale, const SteadyRotationOptions& opt) {
    if (hinge_node < 0 || hinge_node >= model.n_nodes() || hinge_dof < 0 || hinge_dof >= model.n_dofs)
        throw std::invalid_argument("steady_rotation: the hinge node or coordinate is out of range");
    if (opt.continuation_steps < 1 || opt.max_iterations < 1)
        throw std::invalid_argument("steady_rotation: continuation_steps and max_iterations must be positive");
    RigidRotationEquations eq(model, state, load, length_scale, hinge_node, axis);
    StaticNewtonOptions nopt;
    nopt.tol = opt.tol;
    nopt.max_iterations = opt.max_iterations;
    nopt.dense_below = opt.dense_below;
    SteadyRotationOutcome out;
    const int steps = opt.continuation_steps;
    eq.set_omega(omega_guess);
    Eigen::VectorXd lam;
    for (int k = 1; k <= steps; ++k) {
        out.step = k;
        out.mass_flow = load.mass_flow * k / steps;
        eq.set_mass_flow(out.mass_flow);
        if (std::isnan(eq.omega()))
            eq.set_omega(rigid_guess(eq, hinge_dof));
        else if (k > 1)
            eq.set_omega(eq.omega() * k / (k - 1));  // omega scales with the flow speed
        RotationRateBorder border(eq, hinge_dof);
        nopt.border = &border;
        const StaticNewtonResult res = static_newton(eq, 0.0, lam, nopt);
        out.iterations += res.iterations;
        out.step_iterations = res.iterations;
        out.residual = res.residual;
        out.omega = eq.omega();
        out.singular = res.singular;
        if (!res.converged) return out;
    }
    out.converged = true;
    return out;
}

}  // namespace pipeflex
