#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/assembly/model.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/multibody/multibody_equations.hpp"

#include <Eigen/LU>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace pipeflex {

namespace {

// The stand-in state of a spring's nodes (MbSpring): x = p, phi = 0, frame A A0^T,
// x_dot = p_dot, phi_dot = omega; the node maps Jp, Ja and angular velocities w if given.
void spring_state(const MultibodySystemCore& sys, const MbState& s, const MbSpring& sp, State& st, MatX* Jp,
                  MatX* Ja, Vec3d* w) {
    MatX jp, ja;
    for (std::size_t i = 0; i < sp.nodes.size(); ++i) {
        const MbSpringNode& nd = sp.nodes[i];
        MatX& P = Jp ? Jp[i] : jp;
        MatX& A = Ja ? Ja[i] : ja;
        Vec3d p;
        Mat3d R;
        sys.node(s, nd.body, nd.node, p, R, &P, &A);
        const int o = sys.offset(nd.body);
        const auto vb = s.v.segment(o, P.cols());
        const Vec3d pd = P * vb, om = A * vb;
        for (int k = 0; k < 3; ++k) {
            st.q[6 * i + k] = p[k];
            st.q[6 * i + 3 + k] = 0.0;
            st.v[6 * i + k] = pd[k];
            st.v[6 * i + 3 + k] = om[k];
        }
        st.frames[i] = to_mat3(R * nd.A0.transpose());
        if (w) w[i] = om;
    }
}

}  // namespace

int MbJoint::rows() const {
    switch (kind) {
        case JointKind::rigid: return 6;
        case JointKind::hinge: return 5;
        case JointKind::spherical: return 3;
        case JointKind::roller: return 1;
    }
    return 0;
}

int MultibodySystemCore::add_body(MbBody body) {
    check_ffrf_body(body.data);
    const Eigen::Index m = body.data.M.rows() - 6;
    if (body.s.size() < 2) throw std::invalid_argument("add_body: a body needs at least 2 nodes (s)");
    if (body.basis.cols() != m || body.basis.rows() != 6 * static_cast<Eigen::Index>(body.s.size()))
        throw std::invalid_argument("add_body: basis must be 6 n_nodes x m with m = (size of M) - 6");
    if (body.foundation.kL != 0.0) check_ffrf_foundation(body.foundation, m);
    if (!body.distributed.empty() && !(body.mass_per_length > 0.0 && std::isfinite(body.mass_per_length)))
        throw std::invalid_argument("add_body: a distributed load needs mass_per_length > 0");
    length_scale_ = std::max(length_scale_ * (bodies_.empty() ? 0.0 : 1.0), body.s.back() - body.s.front());
    offsets_.push_back(offsets_.back() + 6 + static_cast<int>(m));
    n_ = offsets_.back();
    bodies_.push_back(std::move(body));
    return n_bodies() - 1;
}

void MultibodySystemCore::set_length_scale(double L) {
    if (!(std::isfinite(L) && L > 0.0))
        throw std::invalid_argument("set_length_scale: the length scale must be positive and finite, got " +
                                    std::to_string(L));
    length_scale_ = std::max(L, length_scale_);
}

void MultibodySystemCore::add_joint(const MbJoint& j) {
    auto check = [&](int b, int nd) {
        if (b < 0 || b >= n_bodies() || nd < 0 || nd >= static_cast<int>(bodies_[b].s.size()))
            throw std::invalid_argument("add_joint: no node " + std::to_string(nd) + " on body " + std::to_string(b));
    };
    check(j.body_a, j.node_a);
    if (j.body_b >= 0) check(j.body_b, j.node_b);
    joints_.push_back(j);
    rows_.push_back(rows_.back() + j.rows());
    nc_ = rows_.back();
}

void MultibodySystemCore::add_load(const MbLoad& l) {
    if (l.body < 0 || l.body >= n_bodies() || l.node < 0 || l.node >= static_cast<int>(bodies_[l.body].s.size()))
        throw std::invalid_argument("add_load: no such body node");
    loads_.push_back(l);
}

void MultibodySystemCore::add_spring(std::unique_ptr<Element> element, const std::vector<MbSpringNode>& nodes) {
    if (!element) throw std::invalid_argument("add_spring: no element");
    if (element->n_nodes() != static_cast<int>(nodes.size()))
        throw std::invalid_argument(std::string("add_spring: the ") + element->name() + " connects " +
                                    std::to_string(element->n_nodes()) + " nodes, got " +
                                    std::to_string(nodes.size()) + " body nodes");
    if (!element->accepts(NodeKind::frame))
        throw std::invalid_argument(std::string("add_spring: a ") + element->name() + " cannot act on a body node");
    auto model = std::make_shared<Model>();
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        const MbSpringNode& nd = nodes[i];
        if (nd.body < 0 || nd.body >= n_bodies() || nd.node < 0 || nd.node >= n_nodes(nd.body))
            throw std::invalid_argument("add_spring: no node " + std::to_string(nd.node) + " on body " +
                                        std::to_string(nd.body));
        if (!(nd.p0.allFinite() && nd.A0.allFinite()))
            throw std::invalid_argument("add_spring: the reference position and orientation must be finite");
        if (element->nodes()[i] != static_cast<int>(i))
            throw std::invalid_argument("add_spring: the element's nodes must be 0, 1, ... (the body nodes' order)");
        model->positions.push_back(to_vec3(nd.p0));
        model->kinds.push_back(NodeKind::frame);
    }
    element->finalize(*model);
    springs_.push_back(MbSpring{std::shared_ptr<const Element>(std::move(element)), std::move(model), nodes});
}

double MultibodySystemCore::spring_energy(const MbState& s) const {
    double U = 0.0;
    for (const MbSpring& sp : springs_) {
        State st(*sp.model);
        spring_state(*this, s, sp, st, nullptr, nullptr, nullptr);
        double T = 0.0, u = 0.0;
        sp.element->energies(st, &T, &u);
        U += u;
    }
    return U;
}

State MultibodySystemCore::spring_nodes_state(const MbState& s, int k) const {
    const MbSpring& sp = springs_.at(static_cast<std::size_t>(k));
    State st(*sp.model);
    pipeflex::spring_state(*this, s, sp, st, nullptr, nullptr, nullptr);
    return st;
}

double MultibodySystemCore::spring_damping_power(const MbState& s) const {
    double P = 0.0;
    for (const MbSpring& sp : springs_) {
        if (!sp.element->damped()) continue;
        State st(*sp.model);
        spring_state(*this, s, sp, st, nullptr, nullptr, nullptr);
        sp.element->add_damping_power(st, &P);
    }
    return P;
}

void MultibodySystemCore::node_velocity_derivative(const MbState& s, int body, int nd, MatX& W) const {
    // p_dot = r_dot + omega x y + R Pu eta_dot, y = R (s e_x + Pu eta); omega_node = omega +
    // R T(th) Pt eta_dot, th = Pt eta. R <- exp(skew(d pi)) R turns y, R Pu eta_dot and
    // R T Pt eta_dot by d pi x (.); eta moves y by R Pu d eta and T(th) by its derivatives.
    const MbBody& b = bodies_.at(body);
    const Eigen::Index m = b.basis.cols();
    const int o = offsets_[body];
    const auto eta = s.eta.segment(o + 6, m);
    const auto ed = s.v.segment(o + 6, m);
    const Vec3d om = s.v.segment<3>(o + 3);
    const auto Pu = b.basis.middleRows(6 * nd, 3);
    const auto Pt = b.basis.middleRows(6 * nd + 3, 3);
    const Mat3d& R = s.R[body];
    const Vec3d y = R * (Vec3d(b.s[nd], 0.0, 0.0) + Pu * eta);
    W.setZero(6, 6 + m);
    const Mat3d Om = skew(om);
    const Vec3d ue = R * (Pu * ed);
    W.block<3, 3>(0, 3) = -Om * skew(y) - skew(ue);
    if (m == 0) return;
    W.block(0, 6, 3, m).noalias() = Om * R * Pu;
    Mat3<double> T, dT[3], Td, dTd[3];
    rotation_jacobian_derivatives(to_vec3(Vec3d(Pt * eta)), Vec3<double>{}, T, dT, Td, dTd);
    const Vec3d we = Pt * ed;
    W.block<3, 3>(3, 3) = -skew(Vec3d(R * (from_mat3(T) * we)));
    Mat3d Dw;  // column k: dT/dth_k we
    for (int k = 0; k < 3; ++k) Dw.col(k) = from_mat3(dT[k]) * we;
    W.block(3, 6, 3, m).noalias() = R * Dw * Pt;
}

void MultibodySystemCore::spring_forces(const MbState& s, double wK, double wC, bool with_tangent,
                                        MbEvaluation& out) const {
    using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const LoadState load;
    const double weights[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
    for (const MbSpring& sp : springs_) {
        const int n = static_cast<int>(sp.nodes.size()), d = 6 * n;
        State st(*sp.model);
        std::vector<MatX> Jp(n), Ja(n);
        std::vector<Vec3d> w(n);
        spring_state(*this, s, sp, st, Jp.data(), Ja.data(), w.data());
        VecX r(d);
        RowMat K(d, d), C(d, d);
        double* J[2] = {K.data(), C.data()};
        ElementOutputs eo;
        eo.nw = with_tangent ? 2 : 0;
        eo.weights = weights;
        eo.r = r.data();
        eo.J = J;
        sp.element->kernel(ElementInputs{st, load, nullptr}, eo);
        for (int i = 0; i < n; ++i) {
            const int o = offsets_[sp.nodes[i].body];
            out.F.segment(o, Jp[i].cols()).noalias() += Jp[i].transpose() * r.segment<3>(6 * i);
            out.F.segment(o, Ja[i].cols()).noalias() += Ja[i].transpose() * r.segment<3>(6 * i + 3);
        }
        if (!with_tangent) continue;
        // the stand-in's rotation rates phi_dot = T(phi)^-1 omega, T = I + skew(phi) / 2 + ...,
        // move by skew(omega) u / 2 with its rotation u = Ja dq
        for (int j = 0; j < n; ++j) K.middleCols(6 * j + 3, 3) += 0.5 * C.middleCols(6 * j + 3, 3) * skew(w[j]);
        std::vector<MatX> G(n), W(n);
        for (int i = 0; i < n; ++i) {
            G[i].resize(6, Jp[i].cols());
            G[i] << Jp[i], Ja[i];
            node_velocity_derivative(s, sp.nodes[i].body, sp.nodes[i].node, W[i]);
        }
        for (int i = 0; i < n; ++i) {
            const int bi = sp.nodes[i].body;
            for (int j = 0; j < n; ++j) {
                MatX& S = out.S[tangent_block(bi, sp.nodes[j].body)];
                const auto Kij = K.block(6 * i, 6 * j, 6, 6);
                const auto Cij = C.block(6 * i, 6 * j, 6, 6);
                const MatX B = wK * Kij + wC * Cij;
                S.noalias() += G[i].transpose() * (B * G[j]);
                if (wK != 0.0) S.noalias() += wK * G[i].transpose() * (Cij * W[j]);
            }
            if (wK == 0.0) continue;
            // the node maps turning at fixed forces, and the stand-in's moment Ja^T T(phi)^-T m
            // with T^-T m = m - skew(m) phi / 2 + ...
            MatX& S = out.S[tangent_block(bi, bi)];
            const Vec3d f = r.segment<3>(6 * i), mo = r.segment<3>(6 * i + 3);
            node_stiffness(s, bi, sp.nodes[i].node, f, mo, wK, S);
            if (!mo.isZero(0.0)) S.noalias() -= 0.5 * wK * Ja[i].transpose() * (skew(mo) * Ja[i]);
        }
    }
}

void MultibodySystemCore::finalize() {
    n_ = offsets_.back();
    nc_ = rows_.back();
    pairs_.clear();
    pair_index_.clear();
    auto add = [&](int a, int b) {
        if (pair_index_.emplace(std::make_pair(a, b), static_cast<int>(pairs_.size())).second) pairs_.emplace_back(a, b);
    };
    for (int b = 0; b < n_bodies(); ++b) add(b, b);
    for (const MbJoint& j : joints_)
        if (j.body_b >= 0) {
            add(j.body_a, j.body_b);
            add(j.body_b, j.body_a);
        }
    for (const MbSpring& sp : springs_)
        for (const MbSpringNode& a : sp.nodes)
            for (const MbSpringNode& b : sp.nodes) add(a.body, b.body);
}

int MultibodySystemCore::tangent_block(int a, int b) const {
    const auto it = pair_index_.find(std::make_pair(a, b));
    return it == pair_index_.end() ? -1 : it->second;
}

MatX MultibodySystemCore::dense_tangent(const MbEvaluation& ev) const {
    MatX S = MatX::Zero(n_, n_);
    for (std::size_t k = 0; k < pairs_.size() && k < ev.S.size(); ++k) {
        const auto [a, b] = pairs_[k];
        S.block(offsets_[a], offsets_[b], ev.S[k].rows(), ev.S[k].cols()) = ev.S[k];
    }
    return S;
}

void MultibodySystemCore::check_state(const MbState& s) const {
    const int nb = n_bodies();
    if (static_cast<int>(s.r.size()) != nb || static_cast<int>(s.R.size()) != nb)
        throw std::invalid_argument("state: r and R must hold one frame per body (" + std::to_string(nb) + "), got " +
                                    std::to_string(s.r.size()) + " and " + std::to_string(s.R.size()));
    if (s.eta.size() != n_ || s.v.size() != n_ || s.a.size() != n_ || s.lam.size() != nc_)
        throw std::invalid_argument("state: eta, v and a must have " + std::to_string(n_) +
                                    " entries (n_coordinates) and lam " + std::to_string(nc_) + " (n_constraints)");
    bool finite = std::isfinite(s.t) && s.eta.allFinite() && s.v.allFinite() && s.a.allFinite() && s.lam.allFinite();
    for (int j = 0; j < nb; ++j) finite = finite && s.r[j].allFinite() && s.R[j].allFinite();
    if (!finite) throw std::invalid_argument("state: all its numbers must be finite");
}

void MultibodySystemCore::node(const MbState& s, int body, int nd, Vec3d& p, Mat3d& A, MatX* Jp, MatX* Ja) const {
    if (body < 0 || body >= n_bodies() || nd < 0 || nd >= n_nodes(body))
        throw std::invalid_argument("no node " + std::to_string(nd) + " on body " + std::to_string(body));
    if (s.eta.size() != n_ || static_cast<int>(s.r.size()) != n_bodies() || static_cast<int>(s.R.size()) != n_bodies())
        throw std::invalid_argument("state: eta must have n_coordinates = " + std::to_string(n_) +
                                    " entries and r, R one frame per body");
    const MbBody& b = bodies_[body];
    const Eigen::Index m = b.basis.cols();
    const int o = offsets_[body];
    const auto eta = s.eta.segment(o + 6, m);
    const auto Pu = b.basis.middleRows(6 * nd, 3);
    const auto Pt = b.basis.middleRows(6 * nd + 3, 3);
    const Mat3d& R = s.R[body];
    const Vec3d y = R * (Vec3d(b.s[nd], 0.0, 0.0) + Pu * eta);
    const Vec3d th = Pt * eta;
    p = s.r[body] + y;
    A = R * rotation_exp(th);
    if (Jp) {
        Jp->setZero(3, 6 + m);
        Jp->leftCols(3).setIdentity();
        Jp->middleCols(3, 3) = -skew(y);
        Jp->rightCols(m) = R * Pu;
    }
    if (Ja) {
        Ja->setZero(3, 6 + m);
        Ja->middleCols(3, 3).setIdentity();
        Ja->rightCols(m) = R * rotation_jacobian(th) * Pt;
    }
}

void MultibodySystemCore::increment(MbState& s, const VecX& dq) const {
    if (dq.size() != n_ || s.eta.size() != n_ || static_cast<int>(s.r.size()) != n_bodies() ||
        static_cast<int>(s.R.size()) != n_bodies())
        throw std::invalid_argument("increment: dq and the state's eta must have n_coordinates = " +
                                    std::to_string(n_) + " entries, got " + std::to_string(dq.size()) + " and " +
                                    std::to_string(s.eta.size()));
    for (int j = 0; j < n_bodies(); ++j) {
        const int o = offsets_[j], m = offsets_[j + 1] - o - 6;
        s.r[j] += dq.segment<3>(o);
        s.R[j] = rotation_exp(dq.segment<3>(o + 3)) * s.R[j];
        s.eta.segment(o + 6, m) += dq.segment(o + 6, m);
    }
}

void MultibodySystemCore::joint_equations(const MbState& s, const MbJoint& j, Eigen::Ref<VecX> c,
                                          Eigen::Ref<MatX> Ja, Eigen::Ref<MatX> Jb, MbJointWork& w) const {
    Vec3d pa, pb;
    Mat3d Aa, Ab;
    node(s, j.body_a, j.node_a, pa, Aa, &w.Jpa, &w.Jaa);
    const bool ground = j.body_b < 0;
    if (ground) {
        pb = j.p_ground;
        Ab = j.A_ground;
    } else {
        node(s, j.body_b, j.node_b, pb, Ab, &w.Jpb, &w.Jab);
    }
    joint_rows(j, pa, Aa, w.Jpa, w.Jaa, pb, Ab, ground ? nullptr : &w.Jpb, ground ? nullptr : &w.Jab, c, Ja, Jb);
}

void joint_rows(const MbJoint& j, const Vec3d& pa, const Mat3d& Aa, const MatX& Jpa, const MatX& Jaa,
                const Vec3d& pb, const Mat3d& Ab, const MatX* Jpb, const MatX* Jab, Eigen::Ref<VecX> c,
                Eigen::Ref<MatX> Ja, Eigen::Ref<MatX> Jb) {
    const bool ground = Jpb == nullptr;
    Ja.setZero();
    if (!ground) Jb.setZero();
    if (j.kind == JointKind::roller) {
        c(0) = j.direction.dot(pa - j.p0);
        Ja.row(0) = j.direction.transpose() * Jpa;
        return;
    }
    c.head<3>() = pa - pb;
    Ja.topRows(3) = Jpa;
    if (!ground) Jb.topRows(3) = -*Jpb;
    if (j.kind == JointKind::rigid) {
        const Mat3d D = Aa.transpose() * Ab * j.C0.transpose();
        c.segment<3>(3) = vee_skew(D);
        Mat3d JD;
        for (int k = 0; k < 3; ++k) JD.col(k) = vee_skew(skew(Vec3d::Unit(k)) * D);
        JD = JD * Aa.transpose();
        Ja.middleRows(3, 3) = -JD * Jaa;
        if (!ground) Jb.middleRows(3, 3) = JD * *Jab;
    } else if (j.kind == JointKind::hinge) {
        const Vec3d axb = Ab * j.axis_b;
        for (int k = 0; k < 2; ++k) {
            const Vec3d ea = Aa * j.perp_a[k];
            c(3 + k) = ea.dot(axb);
            Ja.row(3 + k) = ea.cross(axb).transpose() * Jaa;
            if (!ground) Jb.row(3 + k) = axb.cross(ea).transpose() * *Jab;
        }
    }
}

void JointNodeForces::clear() {
    for (int i = 0; i < 2; ++i) {
        f[i].setZero();
        m[i].setZero();
        for (int k = 0; k < 2; ++k) {
            df[i][k].setZero();
            dm[i][k].setZero();
        }
    }
}

void joint_reactions(const MbJoint& j, const Mat3d& Aa, const Mat3d& Ab, bool ground,
                     const Eigen::Ref<const VecX>& lam, JointNodeForces& F) {
    if (j.kind == JointKind::roller) {
        F.f[0] += lam(0) * j.direction;
        return;
    }
    F.f[0] += lam.head<3>();
    F.f[1] -= lam.head<3>();
    if (j.kind == JointKind::rigid) {
        // joint_rows' rotation rows -JD Ja_a, JD Ja_b with JD = M Aa^T, M e_k = vee_skew(e_k~ D):
        // moments -Aa g on a and Aa g on b, g_k = lam . vee_skew(e_k~ D). D = Aa^T Ab C0^T moves by
        // u~ D, u = Aa^T (d alpha_b - d alpha_a), so g by H u, H_kl = lam . vee_skew(e_k~ e_l~ D).
        const Mat3d D = Aa.transpose() * Ab * j.C0.transpose();
        const auto l = lam.segment<3>(3);
        Vec3d g;
        Mat3d H;
        for (int k = 0; k < 3; ++k) {
            const Mat3d Ek = skew(Vec3d::Unit(k));
            g[k] = l.dot(vee_skew(Ek * D));
            for (int n = 0; n < 3; ++n) H(k, n) = l.dot(vee_skew(Ek * skew(Vec3d::Unit(n)) * D));
        }
        const Vec3d mb = Aa * g;
        const Mat3d Hs = Aa * H * Aa.transpose();
        F.m[0] -= mb;
        F.m[1] += mb;
        F.dm[0][0] += skew(mb) + Hs;
        F.dm[1][0] -= skew(mb) + Hs;
        if (!ground) {
            F.dm[0][1] -= Hs;
            F.dm[1][1] += Hs;
        }
    } else if (j.kind == JointKind::hinge) {
        // moments lam_k ea_k x axb on a, the opposite on b; d(ea x axb) = axb~ ea~ d alpha_a - ea~ axb~ d alpha_b
        const Vec3d axb = Ab * j.axis_b;
        const Mat3d X = skew(axb);
        for (int k = 0; k < 2; ++k) {
            const Vec3d ea = Aa * j.perp_a[k];
            const Mat3d E = skew(ea);
            const Vec3d mk = lam(3 + k) * ea.cross(axb);
            F.m[0] += mk;
            F.m[1] -= mk;
            const Mat3d da = lam(3 + k) * (X * E);
            F.dm[0][0] += da;
            F.dm[1][0] -= da;
            if (!ground) {
                const Mat3d db = lam(3 + k) * (E * X);
                F.dm[0][1] -= db;
                F.dm[1][1] += db;
            }
        }
    }
}

void add_turning_stiffness(const JointNodeForces& F, int i, int k, const MatX& Jpi, const MatX& Jai,
                           const MatX& Jak, double w, Eigen::Ref<MatX> K) {
    if (F.df[i][k].isZero(0.0) && F.dm[i][k].isZero(0.0)) return;
    K.noalias() += w * (Jpi.transpose() * (F.df[i][k] * Jak) + Jai.transpose() * (F.dm[i][k] * Jak));
}

double MultibodySystemCore::junction_pressure(int body, double mdot) const {
    const MbBody& b = bodies_[body];
    return b.fluid_mass > 0.0 ? b.flow_factor * b.flow_factor * mdot * mdot / b.fluid_mass : 0.0;
}

void MultibodySystemCore::joint_loads(const MbState& s, const MbJoint& j, double mdot, double load_factor,
                                      const Mat3d& Aa, const Mat3d& Ab, JointNodeForces& F) const {
    const bool ground = j.body_b < 0;
    if (j.actuated) {
        // +T on a, -T on b, turning with the axis on b: dT = d alpha_b x T
        const Vec3d T = load_factor * j.torque.at(s.t) * (Ab * j.axis_b);
        F.m[0] -= T;
        F.m[1] += T;
        if (!ground) {
            const Mat3d dT = skew(T);
            F.dm[0][1] += dT;
            F.dm[1][1] -= dT;
        }
    }
    if (j.junction && !ground) {
        // P t on each pipe end, t = A e_x along the flow turning with its node
        auto along_flow = [&](int i, int body, const Mat3d& A, double sign) {
            const double c = sign * j.upstream * junction_pressure(body, mdot) *
                             (bodies_[body].flow_factor >= 0.0 ? 1.0 : -1.0);
            const Vec3d t = A.col(0);
            F.f[i] -= c * t;
            F.df[i][i] += c * skew(t);
        };
        along_flow(0, j.body_a, Aa, 1.0);
        along_flow(1, j.body_b, Ab, -1.0);
    }
}

bool MultibodySystemCore::joint_forces(const MbState& s, const MbJoint& j, double mdot, double load_factor,
                                       MbJointWork& w) const {
    if (!j.actuated && !j.junction) return false;
    Vec3d p;
    Mat3d Aa, Ab;
    node(s, j.body_a, j.node_a, p, Aa, &w.Jpa, &w.Jaa);
    const bool ground = j.body_b < 0;
    if (!ground) node(s, j.body_b, j.node_b, p, Ab, &w.Jpb, &w.Jab);
    else Ab = j.A_ground;
    JointNodeForces F;
    F.clear();
    joint_loads(s, j, mdot, load_factor, Aa, Ab, F);
    w.fa.noalias() = -w.Jpa.transpose() * F.f[0];
    w.fa.noalias() -= w.Jaa.transpose() * F.m[0];
    if (ground) {
        w.fb.resize(0);
    } else {
        w.fb.noalias() = -w.Jpb.transpose() * F.f[1];
        w.fb.noalias() -= w.Jab.transpose() * F.m[1];
    }
    return true;
}

void MultibodySystemCore::node_stiffness(const MbState& s, int body, int nd, const Vec3d& f, const Vec3d& mo,
                                         double w, Eigen::Ref<MatX> K) const {
    // Q = Jp^T f + Ja^T m = [f; y x f + m; Pu^T R^T f + Pt^T T(th)^T R^T m], y = R (s e_x + Pu eta),
    // th = Pt eta; R <- exp(skew(d pi)) R moves y by d pi x y and R^T v by R^T (v x d pi).
    const MbBody& b = bodies_[body];
    const Eigen::Index m = b.basis.cols();
    const auto eta = s.eta.segment(offsets_[body] + 6, m);
    const auto Pu = b.basis.middleRows(6 * nd, 3);
    const auto Pt = b.basis.middleRows(6 * nd + 3, 3);
    const Mat3d& R = s.R[body];
    const Vec3d y = R * (Vec3d(b.s[nd], 0.0, 0.0) + Pu * eta);
    const Mat3d F = skew(f);
    K.block<3, 3>(3, 3) += w * (F * skew(y));
    if (m == 0) return;
    const Vec3d mb = R.transpose() * mo;
    Mat3<double> T, dT[3], Td, dTd[3];
    rotation_jacobian_derivatives(to_vec3(Vec3d(Pt * eta)), Vec3<double>{}, T, dT, Td, dTd);
    Mat3d G;  // d(T(th)^T mb)/dth
    for (int k = 0; k < 3; ++k) G.col(k) = from_mat3(dT[k]).transpose() * mb;
    K.block(3, 6, 3, m).noalias() -= w * (F * R) * Pu;
    K.block(6, 3, m, 3).noalias() += w * Pu.transpose() * (R.transpose() * F);
    K.block(6, 3, m, 3).noalias() += w * Pt.transpose() * (from_mat3(T).transpose() * R.transpose() * skew(mo));
    K.block(6, 6, m, m).noalias() += w * Pt.transpose() * (G * Pt);
}

void MultibodySystemCore::geometric_stiffness(const MbState& s, double mdot, double load_factor, std::vector<MatX>& S,
                                              double w) const {
    // joints: reactions C_q^T lambda at fixed lambda; driving torques turning with the hinge
    // axis, junction forces with the pipes
    MatX Jpa, Jaa, Jpb, Jab;
    Vec3d pa, pb;
    Mat3d Aa, Ab;
    JointNodeForces F;
    for (size_t k = 0; k < joints_.size(); ++k) {
        const MbJoint& j = joints_[k];
        const auto lam = s.lam.segment(rows_[k], j.rows());
        const bool reacts = !lam.isZero(0.0);
        if (!reacts && !j.actuated && !j.junction) continue;
        const bool ground = j.body_b < 0;
        node(s, j.body_a, j.node_a, pa, Aa, &Jpa, &Jaa);
        if (ground) Ab = j.A_ground;
        else node(s, j.body_b, j.node_b, pb, Ab, &Jpb, &Jab);
        F.clear();
        if (reacts) joint_reactions(j, Aa, Ab, ground, lam, F);
        joint_loads(s, j, mdot, load_factor, Aa, Ab, F);
        const int aa = tangent_block(j.body_a, j.body_a);
        node_stiffness(s, j.body_a, j.node_a, F.f[0], F.m[0], w, S[aa]);
        add_turning_stiffness(F, 0, 0, Jpa, Jaa, Jaa, w, S[aa]);
        if (ground) continue;
        const int bb = tangent_block(j.body_b, j.body_b);
        node_stiffness(s, j.body_b, j.node_b, F.f[1], F.m[1], w, S[bb]);
        add_turning_stiffness(F, 1, 1, Jpb, Jab, Jab, w, S[bb]);
        add_turning_stiffness(F, 0, 1, Jpa, Jaa, Jab, w, S[tangent_block(j.body_a, j.body_b)]);
        add_turning_stiffness(F, 1, 0, Jpb, Jab, Jaa, w, S[tangent_block(j.body_b, j.body_a)]);
    }
    // dead nodal loads: -(Jp^T f + Ja^T m) with f, m fixed in space
    for (const MbLoad& l : loads_) {
        Vec3d fo, mo;
        for (int i = 0; i < 3; ++i) {
            fo[i] = load_factor * l.force[i].at(s.t);
            mo[i] = load_factor * l.moment[i].at(s.t);
        }
        if (fo.isZero(0.0) && mo.isZero(0.0)) continue;
        node_stiffness(s, l.body, l.node, -fo, -mo, w, S[tangent_block(l.body, l.body)]);
    }
}

void MultibodySystemCore::evaluate(const MbState& s, double mdot, double mdot_rate, double load_factor,
                                   double gravity_factor, double wK, double wC, double wM, bool with_tangent,
                                   MbEvaluation& out) const {
    if (s.eta.size() != n_ || s.v.size() != n_ || s.a.size() != n_ || s.lam.size() != nc_ ||
        static_cast<int>(s.r.size()) != n_bodies() || static_cast<int>(s.R.size()) != n_bodies())
        check_state(s);  // throws, naming the sizes
    out.F.setZero(n_);
    out.c.setZero(nc_);
    if (with_tangent) {
        out.S.resize(pairs_.size());
        for (std::size_t k = 0; k < pairs_.size(); ++k) {
            const auto [a, b] = pairs_[k];
            out.S[k].setZero(offsets_[a + 1] - offsets_[a], offsets_[b + 1] - offsets_[b]);
        }
    }
    MatX dummy(0, 0);
    out.work.resize(bodies_.size());
    out.motion.resize(bodies_.size());
    for (int j = 0; j < n_bodies(); ++j) {
        poll_interrupt();
        const MbBody& b = bodies_[j];
        const int o = offsets_[j], n = offsets_[j + 1] - o, m = n - 6;
        FfrfBodyMotion& mo = out.motion[j];
        mo.gravity = gravity_factor * gravity_;
        for (const auto& [q, f] : b.distributed)  // the weight term's load with g -> q / mu
            mo.gravity += (load_factor * f.at(s.t) / b.mass_per_length) * q;
        mo.R = s.R[j];
        mo.omega = s.v.segment<3>(o + 3);
        mo.a = s.a.segment(o, n);
        mo.eta = s.eta.segment(o + 6, m);
        mo.eta_dot = s.v.segment(o + 6, m);
        const double f = b.fluid_mass > 0.0 ? b.flow_factor / b.fluid_mass : 0.0;
        mo.sdot = f * mdot;
        mo.sddot = f * mdot_rate;
        mo.rate_force_zero = b.rate_force_zero;
        if (with_tangent)
            ffrf_body_forces(b.data, mo, wK, wC, wM, out.work[j], out.F.segment(o, n), out.S[tangent_block(j, j)], true);
        else
            ffrf_body_forces(b.data, mo, wK, wC, wM, out.work[j], out.F.segment(o, n), dummy, false);
        if (b.foundation.kL != 0.0) {
            if (with_tangent)
                ffrf_foundation_forces(b.foundation, s.r[j], s.R[j], b.r_ref, b.R_ref, mo.eta, wK, out.F.segment(o, n),
                                       out.S[tangent_block(j, j)], true);
            else
                ffrf_foundation_forces(b.foundation, s.r[j], s.R[j], b.r_ref, b.R_ref, mo.eta, wK, out.F.segment(o, n),
                                       dummy, false);
        }
    }
    MatX Jp, Ja;
    Vec3d p;
    Mat3d A;
    for (const MbLoad& l : loads_) {
        node(s, l.body, l.node, p, A, &Jp, &Ja);
        Vec3d fo, mo2;
        for (int i = 0; i < 3; ++i) {
            fo[i] = l.force[i].at(s.t);
            mo2[i] = l.moment[i].at(s.t);
        }
        const int o = offsets_[l.body];
        out.F.segment(o, Jp.cols()) -= load_factor * (Jp.transpose() * fo + Ja.transpose() * mo2);
    }
    out.joint_work.resize(joints_.size());
    for (size_t k = 0; k < joints_.size(); ++k) {
        const MbJoint& j = joints_[k];
        MbJointWork& w = out.joint_work[k];
        const int r0 = rows_[k], nr = j.rows();
        const int oa = offsets_[j.body_a], na = offsets_[j.body_a + 1] - oa;
        const int ob = j.body_b < 0 ? 0 : offsets_[j.body_b], nb = j.body_b < 0 ? 0 : offsets_[j.body_b + 1] - ob;
        w.Ja.resize(nr, na);
        w.Jb.resize(nr, nb);
        joint_equations(s, j, out.c.segment(r0, nr), w.Ja, w.Jb, w);
        // reactions C_q^T lambda, joint by joint (C_q is sparse: a joint touches its bodies)
        out.F.segment(oa, na).noalias() += w.Ja.transpose() * s.lam.segment(r0, nr);
        if (nb) out.F.segment(ob, nb).noalias() += w.Jb.transpose() * s.lam.segment(r0, nr);
        if (joint_forces(s, j, mdot, load_factor, w)) {
            out.F.segment(oa, na) -= w.fa;
            if (nb) out.F.segment(ob, nb) -= w.fb;
        }
    }
    if (!springs_.empty()) spring_forces(s, wK, wC, with_tangent, out);
    if (with_tangent && wK != 0.0) geometric_stiffness(s, mdot, load_factor, out.S, wK);
}

Eigen::SparseMatrix<double> MultibodySystemCore::sparse_constraint_jacobian(const MbEvaluation& ev) const {
    std::vector<Eigen::Triplet<double>> t;
    auto put = [&](int r0, int c0, const MatX& B) {
        for (Eigen::Index c = 0; c < B.cols(); ++c)
            for (Eigen::Index i = 0; i < B.rows(); ++i)
                if (B(i, c) != 0.0) t.emplace_back(r0 + static_cast<int>(i), c0 + static_cast<int>(c), B(i, c));
    };
    for (size_t k = 0; k < joints_.size() && k < ev.joint_work.size(); ++k) {
        const MbJoint& j = joints_[k];
        const MbJointWork& w = ev.joint_work[k];
        put(rows_[k], offsets_[j.body_a], w.Ja);
        if (j.body_b >= 0) put(rows_[k], offsets_[j.body_b], w.Jb);
    }
    Eigen::SparseMatrix<double> J(nc_, n_);
    J.setFromTriplets(t.begin(), t.end());
    return J;
}

MatX MultibodySystemCore::constraint_jacobian(const MbEvaluation& ev) const {
    return MatX(sparse_constraint_jacobian(ev));
}

double MultibodySystemCore::velocity_drift(const MbState& s, const MbEvaluation& ev) const {
    double drift = 0.0;
    for (size_t k = 0; k < joints_.size() && k < ev.joint_work.size(); ++k) {
        const MbJoint& j = joints_[k];
        const MbJointWork& w = ev.joint_work[k];
        VecX cv = w.Ja * s.v.segment(offsets_[j.body_a], w.Ja.cols());
        if (j.body_b >= 0) cv += w.Jb * s.v.segment(offsets_[j.body_b], w.Jb.cols());
        drift = std::max(drift, cv.cwiseAbs().maxCoeff());
    }
    return drift;
}

VecX multibody_frame_shift(const MultibodySystemCore& sys) {
    VecX w = VecX::Zero(sys.n_coordinates());
    for (int j = 0; j < sys.n_bodies(); ++j) w.segment<6>(sys.offset(j)).setConstant(kMechanismShift);
    return w;
}

FreeMotions multibody_free_motions(const MultibodySystemCore& sys, const MbState& s, double mdot) {
    sys.check_state(s);
    const TimeTable flow = TimeTable::constant(mdot);
    MultibodyEquations eq(sys, s, flow);
    return free_motions(eq, s.t, s.lam, multibody_frame_shift(sys));
}

}  // namespace pipeflex
