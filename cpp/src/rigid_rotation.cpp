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

// T^T B T over the nodes (B the same 6 x 6 block on every node): block diagonal in the
// reduced coordinates.
Eigen::SparseMatrix<double> reduced_blocks(const Model& model, const Eigen::Matrix<double, 6, 6>& B) {
    std::vector<Eigen::Triplet<double>> t;
    for (int i = 0; i < model.n_nodes(); ++i) {
        const Eigen::MatrixXd& T = model.bases[i];
        if (T.cols() == 0) continue;
        const Eigen::MatrixXd b = T.transpose() * B * T;
        const int f = model.first_dof[i];
        for (int c = 0; c < b.cols(); ++c)
            for (int r = 0; r < b.rows(); ++r) t.emplace_back(f + r, f + c, b(r, c));
    }
    Eigen::SparseMatrix<double> A(model.n_dofs, model.n_dofs);
    A.setFromTriplets(t.begin(), t.end());
    return A;
}

}  // namespace

RigidRotationEquations::RigidRotationEquations(const Model& model, State& state, const LoadState& load,
                                               double length_scale, int hinge_node, const Vec3<double>& axis)
    : statics_(model, state, load, length_scale), hinge_node_(hinge_node), axis_(axis) {
    // the rates below hold at phi = 0: every iterate is re-based
    Eigen::VectorXd v, a;
    statics_.eq.rebase(0.0, v, a);
    const Eigen::Matrix3d S = skew(axis), S2 = S * S;
    Eigen::Matrix<double, 6, 6> Bv = Eigen::Matrix<double, 6, 6>::Zero(), Ba = Bv;
    Bv.topLeftCorner<3, 3>() = S;
    Bv.bottomRightCorner<3, 3>() = 0.5 * S;   // phi_dot = T(phi)^-1 omega a, T^-1 = I - skew(phi)/2 + ...
    Ba.topLeftCorner<3, 3>() = S2;
    Ba.bottomRightCorner<3, 3>() = S2 / 6.0;  // phi_ddot = -T^-1 d/dt[T] phi_dot to first order in phi
    Av_ = reduced_blocks(model, Bv);
    Aa_ = reduced_blocks(model, Ba);
    pattern_ = tangent_pattern(model);
    K_.resize(pattern_->nnz());
    C_.resize(pattern_->nnz());
    M_.resize(pattern_->nnz());
}

void RigidRotationEquations::rigid_rates() {
    State& s = statics_.eq.state;
    const Eigen::Vector3d a(axis_[0], axis_[1], axis_[2]);
    const Eigen::Vector3d xh = s.q.segment<3>(6 * hinge_node_);
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
    const int n = eq.n, nnz = static_cast<int>(pattern_->nnz());
    using Map = Eigen::Map<const Sparse>;
    const Map K(n, n, nnz, pattern_->col_ptr.data(), pattern_->row_index.data(), K_.data());
    const Map C(n, n, nnz, pattern_->col_ptr.data(), pattern_->row_index.data(), C_.data());
    const Map M(n, n, nnz, pattern_->col_ptr.data(), pattern_->row_index.data(), M_.data());
    // sparse products and sums keep every structural entry: the pattern does not depend on the state
    const Sparse J = wK * (Sparse(K) + omega_ * (C * Av_) + (omega_ * omega_) * (M * Aa_));
    tangent->clear();
    for (int c = 0; c < J.outerSize(); ++c)
        for (Sparse::InnerIterator it(J, c); it; ++it) tangent->add(static_cast<int>(it.row()), c, it.value());
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
