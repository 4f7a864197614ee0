#include "pipeflex/elements/ffrf_body.hpp"

#include "pipeflex/elements/hermite.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace pipeflex {

namespace {

// Rows of N (3 x 12) and of its first and second derivatives in s at xi = s / l.
void shape(double l, double xi, Eigen::Matrix<double, 3, 12>& N, Eigen::Matrix<double, 3, 12>& dN,
           Eigen::Matrix<double, 3, 12>& ddN) {
    // derivatives in s = l xi; the slope functions (2 and 4) carry the length l
    const hermite::Shape h = hermite::shape(xi);
    const double H[4] = {h.N[0], l * h.N[1], h.N[2], l * h.N[3]};
    const double dH[4] = {h.dN[0] / l, h.dN[1], h.dN[2] / l, h.dN[3]};
    const double ddH[4] = {h.ddN[0] / (l * l), h.ddN[1] / l, h.ddN[2] / (l * l), h.ddN[3] / l};
    N.setZero();
    dN.setZero();
    ddN.setZero();
    N(0, 0) = 1 - xi;
    N(0, 6) = xi;
    dN(0, 0) = -1 / l;
    dN(0, 6) = 1 / l;
    // u_y: [u_y1, theta_z1, u_y2, theta_z2]; u_z: [u_z1, -theta_y1, u_z2, -theta_y2]
    const int iy[4] = {1, 5, 7, 11}, iz[4] = {2, 4, 8, 10};
    const double sz[4] = {1, -1, 1, -1};
    for (int k = 0; k < 4; ++k) {
        N(1, iy[k]) = H[k];
        dN(1, iy[k]) = dH[k];
        ddN(1, iy[k]) = ddH[k];
        N(2, iz[k]) = sz[k] * H[k];
        dN(2, iz[k]) = sz[k] * dH[k];
        ddN(2, iz[k]) = sz[k] * ddH[k];
    }
}

}  // namespace

void beam_integrals(double l, BeamIntegrals& out) {
    if (!(l > 0.0)) throw std::invalid_argument("beam_integrals: element length must be > 0");
    out.NN.setZero();
    out.NdN.setZero();
    out.NddN.setZero();
    out.N.setZero();
    for (int k = 0; k < 3; ++k) {
        out.NSN[k].setZero();
        out.NSdN[k].setZero();
    }
    Eigen::Matrix<double, 3, 12> N, dN, ddN;
    for (int g = 0; g < hermite::n_gauss; ++g) {
        shape(l, hermite::gauss_xi[g], N, dN, ddN);
        const double w = hermite::gauss_w[g] * l;
        out.NN.noalias() += w * N.transpose() * N;
        out.NdN.noalias() += w * N.transpose() * dN;
        out.NddN.noalias() += w * N.transpose() * ddN;
        out.N.noalias() += w * N.transpose();
        for (int k = 0; k < 3; ++k) {
            const Mat3d nk = skew(Vec3d::Unit(k));
            out.NSN[k].noalias() += w * N.transpose() * nk * N;
            out.NSdN[k].noalias() += w * N.transpose() * nk * dN;
        }
    }
}

void beam_slope_integrals(double l, Mat12d& G0, Mat12d& G1) {
    if (!(l > 0.0)) throw std::invalid_argument("beam_slope_integrals: element length must be > 0");
    G0.setZero();
    G1.setZero();
    Eigen::Matrix<double, 3, 12> N, dN, ddN;
    for (int g = 0; g < hermite::n_gauss; ++g) {
        shape(l, hermite::gauss_xi[g], N, dN, ddN);
        const double w = hermite::gauss_w[g] * l;
        const Mat12d g0 = dN.row(1).transpose() * dN.row(1) + dN.row(2).transpose() * dN.row(2);
        G0 += w * g0;
        G1 += (w * l * hermite::gauss_xi[g]) * g0;
    }
}

void beam_stiffness(double l, double EA, double GJ, double EIy, double EIz, Mat12d& out) {
    if (!(l > 0.0)) throw std::invalid_argument("beam_stiffness: element length must be > 0");
    out.setZero();
    Eigen::Matrix<double, 3, 12> N, dN, ddN;
    for (int g = 0; g < hermite::n_gauss; ++g) {
        shape(l, hermite::gauss_xi[g], N, dN, ddN);
        const double w = hermite::gauss_w[g] * l;
        out.noalias() += w * (EA * dN.row(0).transpose() * dN.row(0) + EIz * ddN.row(1).transpose() * ddN.row(1) +
                              EIy * ddN.row(2).transpose() * ddN.row(2));
    }
    const double kt = GJ / l;  // linear twist
    out(3, 3) += kt;
    out(9, 9) += kt;
    out(3, 9) -= kt;
    out(9, 3) -= kt;
}

void FfrfBodyWork::resize(Eigen::Index n) {
    b.resize(n);
    L.resize(n);
    col.resize(n);
    dQdw.resize(n, 3);
    Aw.resize(n, 3);
    dL.resize(n, 3);
    X.resize(n, n);
}

void check_ffrf_body(const FfrfBodyData& d) {
    const Eigen::Index n = d.M.rows(), m = n - 6;
    if (m < 0 || d.M.cols() != n)
        throw std::invalid_argument("FfrfBodyData: M must be square with at least 6 rows, got " +
                                    std::to_string(d.M.rows()) + " x " + std::to_string(d.M.cols()));
    auto shape = [](const char* name, const MatX& x, Eigen::Index rows, Eigen::Index cols) {
        if (x.rows() != rows || x.cols() != cols)
            throw std::invalid_argument(std::string("FfrfBodyData: ") + name + " must be " + std::to_string(rows) +
                                        " x " + std::to_string(cols) + ", got " + std::to_string(x.rows()) + " x " +
                                        std::to_string(x.cols()));
    };
    shape("K", d.K, m, m);
    shape("eta0", d.eta0, m, 1);
    for (int k = 0; k < 3; ++k) {
        shape("A[k]", d.A[k], n, 3);
        shape("Bk[k]", d.Bk[k], n, m);
        shape("GPhi[k]", d.GPhi[k], n, m);
        shape("Gx[k]", d.Gx[k], n, 1);
    }
    shape("CPhi", d.CPhi, n, m);
    shape("HPhi", d.HPhi, n, m);
    shape("Cx", d.Cx, n, 1);
    shape("Hx", d.Hx, n, 1);
    shape("Ng", d.Ng, n, 3);
    if (d.D.size() != 0) shape("D", d.D, m, m);
    if (d.Ubar.size() != 0 || d.Us.size() != 0 || d.Ue.size() != 0) {
        shape("Ubar", d.Ubar, 3, m);
        shape("Us", d.Us, 3, m);
        shape("Ue", d.Ue, 3, m);
        shape("dUs", d.dUs, 3, m);
        shape("dUe", d.dUe, 3, m);
    }
    if (d.Gs0.size() != 0 || d.Gs1.size() != 0) {
        shape("Gs0", d.Gs0, m, m);
        shape("Gs1", d.Gs1, m, m);
        shape("Ua", d.Ua, 3, m);
    }
    if (!std::isfinite(d.mu_f) || d.mu_f < 0.0)
        throw std::invalid_argument("FfrfBodyData: mu_f must be finite and >= 0, got " + std::to_string(d.mu_f));
}

namespace {

// The geometric stiffness of the fluid acceleration's axial force within the body (its linear
// elasticity has none of its own): N(s) = mu_f sddot (s - s0), the lateral slopes' energy
// 1/2 int N |u'|^2 relative to the frame, so only the elastic rows and columns; linear in the
// rate, so the steady flow's forces are unchanged. Called twice: for the residual (before
// the tangent is zeroed) and for the tangent.
void add_rate_geometric_stiffness(const FfrfBodyData& d, const FfrfBodyMotion& s, double wK,
                                  Eigen::Ref<VecX>* residual, Eigen::Ref<MatX>* tangent) {
    const Eigen::Index m = d.M.rows() - 6;
    const double rate = d.mu_f * s.sddot;  // dN/ds [N/m]
    if (rate == 0.0 || m == 0 || d.Gs0.rows() != m) return;
    const double c1 = rate, c0 = -rate * s.rate_force_zero;  // N = c0 + c1 s; no temporaries in a time loop
    if (residual) {
        auto r = residual->tail(m);
        r.noalias() += c1 * (d.Gs1 * s.eta);
        r.noalias() -= c1 * (d.Gs1 * d.eta0);
        r.noalias() += c0 * (d.Gs0 * s.eta);
        r.noalias() -= c0 * (d.Gs0 * d.eta0);
    }
    if (tangent && wK != 0.0) {
        tangent->block(6, 6, m, m) += (wK * c1) * d.Gs1;
        tangent->block(6, 6, m, m) += (wK * c0) * d.Gs0;
    }
}

// The moment of the fluid acceleration's axial load on the deformed lever arm u = N Phi eta,
// body components: sddot (Ua eta) x e_x into L's moment rows, and its eta derivative
// (-sddot e_x~ Ua) into the moment rows of dQe (the frame rotation's tangent then follows L).
void add_rate_lever_moment(const FfrfBodyData& d, const FfrfBodyMotion& s, VecX& L) {
    if (s.sddot == 0.0 || d.Ua.rows() != 3 || d.Ua.cols() != s.eta.size() || s.eta.size() == 0) return;
    const Vec3d u = d.Ua * s.eta;
    L.segment<3>(3) += s.sddot * u.cross(Vec3d::UnitX());
}

template <class Block>
void add_rate_lever_tangent(const FfrfBodyData& d, const FfrfBodyMotion& s, Block&& dQe) {
    if (s.sddot == 0.0 || d.Ua.rows() != 3 || d.Ua.cols() != s.eta.size() || s.eta.size() == 0) return;
    dQe.middleRows(3, 3).noalias() -= s.sddot * (skew(Vec3d::UnitX()) * d.Ua);
}

}  // namespace

void ffrf_body_forces(const FfrfBodyData& d, const FfrfBodyMotion& s, double wK, double wC, double wM,
                      FfrfBodyWork& work, Eigen::Ref<VecX> residual, Eigen::Ref<MatX> tangent, bool with_tangent) {
    const Eigen::Index n = d.M.rows(), m = n - 6;
    if (m < 0 || d.M.cols() != n || d.K.rows() != m || d.eta0.size() != m || s.a.size() != n ||
        s.eta.size() != m || s.eta_dot.size() != m || residual.size() != n ||
        (with_tangent && (tangent.rows() != n || tangent.cols() != n)))
        throw std::invalid_argument("ffrf_body_forces: inconsistent sizes (body has " + std::to_string(n) +
                                    " coordinates)");
    if (work.X.rows() != n) work.resize(n);
    const Mat3d& R = s.R;
    const Vec3d w = R.transpose() * s.omega;
    const Vec3d gl = R.transpose() * s.gravity;
    VecX& b = work.b;
    b.head<3>() = R.transpose() * s.a.head<3>();
    b.segment<3>(3) = R.transpose() * s.a.segment<3>(3);
    b.tail(m) = s.a.tail(m);

    // Q_v and its partial derivatives in body components.
    const double sd = s.sdot, sdd = s.sddot;
    VecX& L = work.L;
    L.noalias() = d.M * b;
    L.noalias() -= d.Ng * gl;
    L += sd * sd * d.Hx + sdd * d.Cx;
    L.noalias() += (sd * sd) * (d.HPhi * s.eta);
    L.noalias() += sdd * (d.CPhi * s.eta);
    L.noalias() += (2.0 * sd) * (d.CPhi * s.eta_dot);
    auto& dQdw = work.dQdw;
    auto& Aw = work.Aw;
    Aw.setZero();
    for (int k = 0; k < 3; ++k) {
        VecX& col = work.col;
        col.noalias() = d.A[k] * w;
        col.noalias() += 2.0 * (d.Bk[k] * s.eta_dot);
        col += (2.0 * sd) * d.Gx[k];
        col.noalias() += (2.0 * sd) * (d.GPhi[k] * s.eta);
        dQdw.col(k) = col;
        L += w[k] * col;
        Aw += w[k] * d.A[k];
    }
    dQdw += Aw;
    // Q_u (header): the Coriolis forces' moment on the lever arm u; Du its eta derivative
    // (the K block; zero at rest), Ge the eta_dot derivative (the C block)
    const bool lever = d.Ubar.cols() == m && m > 0 && sd != 0.0;
    Mat3d Dw = Mat3d::Zero();
    MatX Du, Ge;
    if (lever) {
        const Vec3d ub = d.Ubar * s.eta, ue = d.Ue * s.eta, us = d.Us * s.eta;
        const Vec3d ex = Vec3d::UnitX();
        Dw = ub.x() * Mat3d::Identity() - ex * ub.transpose();
        Du.noalias() = w * d.Ubar.row(0) - ex * (w.transpose() * d.Ubar);
        Vec3d centrifugal = Vec3d::Zero();  // [u x u'] mu_f
        MatX Dc = MatX::Zero(3, m);         // its eta derivative
        auto end = [&](const Vec3d& u, const MatX& P, const MatX& dP, double sign) {
            const double c = sign * d.mu_f;
            Dw += (0.5 * c) * (u.squaredNorm() * Mat3d::Identity() - u * u.transpose());
            Du.noalias() += c * (w * (u.transpose() * P) - 0.5 * u.dot(w) * P - 0.5 * u * (w.transpose() * P));
            const Vec3d du = dP * s.eta;
            centrifugal += c * u.cross(du);
            Dc.noalias() += c * (skew(u) * dP - skew(du) * P);
        };
        end(ue, d.Ue, d.dUe, 1.0);
        end(us, d.Us, d.dUs, -1.0);
        Dw *= 2.0 * sd;
        Du *= 2.0 * sd;
        Du += (sd * sd) * Dc;
        L.segment<3>(3) += (sd * sd) * centrifugal;
        Ge.resize(3, m);
        Vec3d c, q;  // q = int u x u' mu_f: the skew part of int u x (w x u') is -q x w / 2
        MatX dq(3, m);
        for (int k = 0; k < 3; ++k) {
            const auto Gk = d.GPhi[k].bottomRows(m);
            Ge.row(k).noalias() = (-2.0 * sd) * (Gk.transpose() * s.eta).transpose();
            Du.row(k).noalias() -= (2.0 * sd) * (Gk * s.eta_dot).transpose();
            c[k] = Ge.row(k).dot(s.eta_dot);
            q[k] = -s.eta.dot(Gk * s.eta);
            dq.row(k).noalias() = -((Gk + Gk.transpose()) * s.eta).transpose();
        }
        Dw -= sd * skew(q);
        Du.noalias() += sd * (skew(w) * dq);
        L.segment<3>(3) += Dw * w + c;
        dQdw.middleRows(3, 3) += Dw;
    }

    add_rate_lever_moment(d, s, L);
    residual.head<3>() = R * L.head<3>();
    residual.segment<3>(3) = R * L.segment<3>(3);
    residual.tail(m) = L.tail(m);
    residual.tail(m).noalias() += d.K * (s.eta - d.eta0);
    const bool damped = d.D.size() != 0;
    if (damped) residual.tail(m).noalias() += d.D * s.eta_dot;
    add_rate_geometric_stiffness(d, s, wK, &residual, nullptr);
    if (!with_tangent) return;

    tangent.setZero();
    auto rot_rows = [&](const auto& X, Eigen::Index c0, double weight) {  // tangent += weight R^ X
        const Eigen::Index nc = X.cols();
        tangent.block(0, c0, 3, nc).noalias() += weight * R * X.topRows(3);
        tangent.block(3, c0, 3, nc).noalias() += weight * R * X.middleRows(3, 3);
        tangent.block(6, c0, m, nc) += weight * X.bottomRows(m);
    };
    MatX& X = work.X;
    if (wM != 0.0) {
        X = d.M;  // M R^T (columns)
        X.leftCols(3).noalias() = d.M.leftCols(3) * R.transpose();
        X.middleCols(3, 3).noalias() = d.M.middleCols(3, 3) * R.transpose();
        rot_rows(X, 0, wM);
    }
    if (wC != 0.0) {
        X.leftCols(3).setZero();
        X.middleCols(3, 3).noalias() = dQdw * R.transpose();
        auto dQde = X.rightCols(m);
        dQde = (2.0 * sd) * d.CPhi;
        for (int k = 0; k < 3; ++k) dQde += (2.0 * w[k]) * d.Bk[k];
        if (lever) dQde.middleRows(3, 3) += Ge;
        rot_rows(X, 0, wC);
    }
    if (wK != 0.0) {
        // rotation: R <- exp(dpi~) R; d(R^T x) = R^T x~ dpi, d(R y) = -(R y)~ dpi
        auto& dL = work.dL;
        dL.noalias() = d.M.leftCols(3) * (R.transpose() * skew(s.a.head<3>()));
        dL.noalias() += d.M.middleCols(3, 3) * (R.transpose() * skew(s.a.segment<3>(3)));
        dL.noalias() += dQdw * (R.transpose() * skew(s.omega));
        dL.noalias() -= d.Ng * (R.transpose() * skew(s.gravity));
        rot_rows(dL, 3, wK);
        tangent.block(0, 3, 3, 3) -= wK * skew(R * L.head<3>());
        tangent.block(3, 3, 3, 3) -= wK * skew(R * L.segment<3>(3));
        auto dQe = X.rightCols(m);
        dQe = sd * sd * d.HPhi + sdd * d.CPhi;
        for (int k = 0; k < 3; ++k) dQe += (2.0 * sd * w[k]) * d.GPhi[k];
        if (lever) dQe.middleRows(3, 3) += Du;
        add_rate_lever_tangent(d, s, dQe);
        rot_rows(dQe, 6, wK);
        tangent.block(6, 6, m, m) += wK * d.K;
    }
    if (damped && wC != 0.0) tangent.block(6, 6, m, m) += wC * d.D;
    add_rate_geometric_stiffness(d, s, wK, nullptr, &tangent);
}

}  // namespace pipeflex

// ---- Winkler foundation (ffrf_body.hpp, FfrfFoundation) ----------------------------------

namespace pipeflex {

namespace {

// ax(T)_i = eps_ijk T_jk: int a x b ds from T = int a b^T ds
Vec3d axial_vector(const Mat3d& T) { return Vec3d(T(1, 2) - T(2, 1), T(2, 0) - T(0, 2), T(0, 1) - T(1, 0)); }

}  // namespace

void check_ffrf_foundation(const FfrfFoundation& f, Eigen::Index m) {
    if (!std::isfinite(f.kL) || f.kL < 0.0)
        throw std::invalid_argument("FfrfFoundation: kL must be finite and >= 0, got " + std::to_string(f.kL));
    auto shape = [](const char* name, const MatX& x, Eigen::Index rows, Eigen::Index cols) {
        if (x.rows() != rows || x.cols() != cols)
            throw std::invalid_argument(std::string("FfrfFoundation: ") + name + " must be " + std::to_string(rows) +
                                        " x " + std::to_string(cols) + ", got " + std::to_string(x.rows()) + " x " +
                                        std::to_string(x.cols()));
    };
    shape("XPhi", f.XPhi, 3, m);
    shape("K", f.K, m, m);
    shape("x", f.x, m, 1);
    shape("C", f.C, m, 9);
    if (!f.X.allFinite() || !f.X0.allFinite() || !f.W0.allFinite() || !f.XPhi.allFinite() || !f.K.allFinite() ||
        !f.x.allFinite() || !f.C.allFinite())
        throw std::invalid_argument("FfrfFoundation: the constants must be finite");
}

void ffrf_foundation_forces(const FfrfFoundation& f, const Vec3d& r, const Mat3d& R, const Vec3d& r_ref,
                            const Mat3d& R_ref, const Eigen::Ref<const VecX>& eta, double wK,
                            Eigen::Ref<VecX> residual, Eigen::Ref<MatX> tangent, bool with_tangent) {
    const Eigen::Index m = eta.size(), n = 6 + m;
    if (f.K.rows() != m || f.XPhi.cols() != m || f.C.rows() != m || residual.size() != n ||
        (with_tangent && (tangent.rows() != n || tangent.cols() != n)))
        throw std::invalid_argument("ffrf_foundation_forces: inconsistent sizes (body has " + std::to_string(n) +
                                    " coordinates)");
    const Vec3d p = R.transpose() * (r - r_ref);
    const Mat3d Q = R.transpose() * R_ref;
    const Vec3d Xi = f.X + f.XPhi * eta;
    const Vec3d QX0 = Q * f.X0;
    const VecX Ce = f.C.transpose() * eta;
    Mat3d W = f.W0;
    for (int j = 0; j < 3; ++j)
        for (int l = 0; l < 3; ++l) W(j, l) += Ce[3 * j + l];
    const Mat3d WQ = W * Q.transpose();
    const Vec3d Lx = f.kL * p + Xi - QX0;
    const Vec3d Lr = Xi.cross(p) - axial_vector(WQ);
    residual.head<3>() += R * Lx;
    residual.segment<3>(3) += R * Lr;
    auto Le = residual.tail(m);
    Le.noalias() += f.XPhi.transpose() * p;
    Le.noalias() += f.K * eta;
    Le += f.x;
    for (int j = 0; j < 3; ++j)
        for (int l = 0; l < 3; ++l) Le -= Q(j, l) * f.C.col(3 * j + l);
    if (!with_tangent || wK == 0.0) return;

    // body-component derivatives in [R^T dr, R^T dpi, deta]: dp = R^T dr + p~ R^T dpi,
    // dQ = -(R^T dpi)~ Q; Jf: all rows, the frame's 6 columns; Je: frame rows, eta columns
    const Mat3d P = skew(p), Xs = skew(Xi);
    MatX Jf(n, 6), Je(6, m);
    Jf.block<3, 3>(0, 0) = f.kL * Mat3d::Identity();
    Jf.block<3, 3>(0, 3) = f.kL * P - skew(QX0);
    Jf.block<3, 3>(3, 0) = Xs;
    Mat3d Jr;
    for (int k = 0; k < 3; ++k) Jr.col(k) = axial_vector(WQ * skew(Vec3d::Unit(k)));
    Jf.block<3, 3>(3, 3) = Xs * P - Jr;
    Jf.block(6, 0, m, 3) = f.XPhi.transpose();
    Jf.block(6, 3, m, 3).noalias() = f.XPhi.transpose() * P;
    for (int k = 0; k < 3; ++k) {
        const Mat3d dQ = skew(Vec3d::Unit(k)) * Q;  // -dQ per unit rotation about k
        for (int j = 0; j < 3; ++j)
            for (int l = 0; l < 3; ++l) Jf.block(6, 3 + k, m, 1) += dQ(j, l) * f.C.col(3 * j + l);
    }
    Je.topRows(3) = f.XPhi;
    Je.bottomRows(3).noalias() = -P * f.XPhi;
    for (Eigen::Index i = 0; i < m; ++i) {
        Mat3d Ci;
        for (int j = 0; j < 3; ++j)
            for (int l = 0; l < 3; ++l) Ci(j, l) = f.C(i, 3 * j + l);
        Je.block<3, 1>(3, i) -= axial_vector(Ci * Q.transpose());
    }
    // global: frame rows R (.), frame columns (.) R^T; the outer R's turn -(R L)~ dpi
    Jf.leftCols(3) = Jf.leftCols(3) * R.transpose();
    Jf.rightCols(3) = Jf.rightCols(3) * R.transpose();
    tangent.block(0, 0, 3, 6).noalias() += wK * R * Jf.topRows(3);
    tangent.block(3, 0, 3, 6).noalias() += wK * R * Jf.middleRows(3, 3);
    tangent.block(6, 0, m, 6) += wK * Jf.bottomRows(m);
    tangent.block(0, 6, 3, m).noalias() += wK * R * Je.topRows(3);
    tangent.block(3, 6, 3, m).noalias() += wK * R * Je.bottomRows(3);
    tangent.block(6, 6, m, m) += wK * f.K;
    tangent.block(0, 3, 3, 3) -= wK * skew(R * Lx);
    tangent.block(3, 3, 3, 3) -= wK * skew(R * Lr);
}

}  // namespace pipeflex
