#include "pipeflex/solvers/coupled.hpp"
#include "pipeflex/assembly/model.hpp"
#include "pipeflex/solvers/linear_matrices.hpp"

#include "pipeflex/core/format.hpp"
#include "pipeflex/core/rotation.hpp"
#include "pipeflex/core/small_matrix_eigen.hpp"
#include "pipeflex/multibody/multibody_equations.hpp"
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/rotating_systems.hpp"

#include <algorithm>
#include <stdexcept>

namespace pipeflex {

namespace {

class CoupledEquations final : public Equations {
   public:
    // The parts' equations are el and mb unless el_part, mb_part stand in for them (the
    // parts in rigid rotation: rotating_systems.hpp); el and mb give the kinematics.
    CoupledEquations(ElementEquations& el, MultibodyEquations& mb, const MultibodySystemCore& core,
                     const std::vector<Coupling>& couplings, Equations* el_part = nullptr,
                     Equations* mb_part = nullptr)
        : el_(el), mb_(mb), el_eq_(el_part != nullptr ? *el_part : el), mb_eq_(mb_part != nullptr ? *mb_part : mb),
          core_(core), cp_(couplings), n1_(el.n_coordinates()), n2_(mb.n_coordinates()), nc2_(mb.n_constraints()) {
        const Model& model = el.model;
        rows_.push_back(0);
        for (const Coupling& c : cp_) {
            const int i = c.element_node;
            if (i < 0 || i >= model.n_nodes())
                throw std::invalid_argument("coupling: element node " + std::to_string(i) + " is not a node of the "
                                            "model (it has " + std::to_string(model.n_nodes()) + ")");
            if (model.kinds[i] == NodeKind::ancf && c.joint.kind != JointKind::rigid && !c.spring)
                throw std::invalid_argument("coupling: ANCF node " + std::to_string(i) +
                                            " can only be clamped (rigid) to a body node");
            if (model.kinds[i] == NodeKind::ancf && c.spring && !c.spring->accepts(NodeKind::ancf))
                throw std::invalid_argument(std::string("coupling: ANCF node ") + std::to_string(i) +
                                            " has no rotation for the " + c.spring->name() + "'s rotational part");
            if (std::find(model.hub.nodes.begin(), model.hub.nodes.end(), i) != model.hub.nodes.end())
                throw std::invalid_argument("coupling: element node " + std::to_string(i) + " is driven by the hub");
            if (c.joint.body_b < 0 || c.joint.body_b >= core.n_bodies() || c.joint.node_b < 0 ||
                c.joint.node_b >= core.n_nodes(c.joint.body_b))
                throw std::invalid_argument("coupling: no node " + std::to_string(c.joint.node_b) + " on body " +
                                            std::to_string(c.joint.body_b));
            if (c.joint.kind == JointKind::roller && !c.spring)
                throw std::invalid_argument("coupling: a roller joins a node to the ground, not to a body");
            rows_.push_back(rows_.back() + rows(c));
        }
        nc3_ = rows_.back();
    }

    const VecX& coupling_multipliers() const { return lam3_; }

    int n_coordinates() const override { return n1_ + n2_; }
    int n_constraints() const override { return nc2_ + nc3_; }
    double length_scale() const override { return std::max(el_.length_scale(), mb_.length_scale()); }
    void error_scales(VecX& s) const override {
        VecX s1, s2;
        el_eq_.error_scales(s1);
        mb_eq_.error_scales(s2);
        s.resize(n1_ + n2_);
        s << s1, s2;
    }

    double motion_size() const override { return std::max(el_eq_.motion_size(), mb_eq_.motion_size()); }

    void set(const VecX& z, const VecX& v, const VecX& a, const VecX& lam, double t) override {
        el_eq_.set(z.head(n1_), v.head(n1_), a.head(n1_), VecX(), t);
        mb_eq_.set(z.tail(n2_), v.tail(n2_), a.tail(n2_), lam.head(nc2_), t);
        lam3_ = lam.tail(nc3_);
    }

    void evaluate(double wK, double wC, double wM, VecX& r, Triplets* J) override {
        el_eq_.evaluate(wK, wC, wM, r1_, J ? &J1_ : nullptr);
        mb_eq_.evaluate(wK, wC, wM, r2_, J ? &J2_ : nullptr);
        r.resize(n1_ + n2_ + nc2_ + nc3_);
        r.head(n1_) = r1_;
        r.segment(n1_, n2_ + nc2_) = r2_;
        if (J) join(J1_, J2_, *J);
        couple(wK, wC, &r, J);
    }
    // the parts' tangents each in one call (an element part assembles them in one pass)
    void tangents(const std::vector<TangentWeights>& weights, std::vector<Triplets>& J) override {
        el_eq_.tangents(weights, J1s_);
        mb_eq_.tangents(weights, J2s_);
        J.resize(weights.size());
        for (std::size_t w = 0; w < weights.size(); ++w) {
            join(J1s_[w], J2s_[w], J[w]);
            couple(weights[w].wK, weights[w].wC, nullptr, &J[w]);
        }
    }

    // The element part written straight into the pattern (the model's within the system's),
    // the bodies' and the couplings' entries as triplets.
    void tangents_csc(const std::vector<TangentWeights>& weights, TangentCsc& out) override {
        // another element part (in rigid rotation) gives triplets only
        if (&el_eq_ != static_cast<Equations*>(&el_)) return Equations::tangents_csc(weights, out);
        mb_eq_.tangents(weights, J2s_);
        parts_.resize(weights.size());
        for (std::size_t w = 0; w < weights.size(); ++w) {
            Triplets& J = parts_[w];
            J.clear();
            const Triplets& J2 = J2s_[w];
            for (std::size_t k = 0; k < J2.values.size(); ++k) J.add(n1_ + J2.rows[k], n1_ + J2.cols[k], J2.values[k]);
            couple(weights[w].wK, weights[w].wC, nullptr, &J);
        }
        out.assemble(n1_ + n2_, nc2_ + nc3_, static_cast<int>(weights.size()), tangent_pattern(el_.model),
                     [&](const int* slot, double* const* values) { el_.tangents_into(weights, slot, values); }, parts_);
    }

   private:
    // The parts' tangents in the joint's coordinates [z_el; q_b] and constraint rows.
    void join(const Triplets& J1, const Triplets& J2, Triplets& J) const {
        J = J1;
        for (std::size_t k = 0; k < J2.values.size(); ++k) J.add(n1_ + J2.rows[k], n1_ + J2.cols[k], J2.values[k]);
    }
    // The couplings' equations and reactions into the residual r (if not null; the parts'
    // rows already set) and their blocks and geometric stiffness (weight wK) into J (if
    // not null).
    void couple(double wK, double wC, VecX* r, Triplets* J) {
        const int n = n1_ + n2_;
        for (std::size_t k = 0; k < cp_.size(); ++k) {
            if (cp_[k].spring) {
                spring(k, wK, wC, r, J);
                continue;
            }
            const int nr = rows(cp_[k]), R0 = n + nc2_ + rows_[k];
            equations(k, c_, Ja_, Jb_);
            const auto lam = lam3_.segment(rows_[k], nr);
            const int e0 = first_col(k), b0 = body_col(k);
            if (r) {
                r->segment(R0, nr) = c_;
                r->segment(e0, Ja_.cols()) += Ja_.transpose() * lam;
                r->segment(b0, Jb_.cols()) += Jb_.transpose() * lam;
            }
            if (!J) continue;
            for (int i = 0; i < nr; ++i) {
                for (int c = 0; c < Ja_.cols(); ++c) {
                    J->add(R0 + i, e0 + c, Ja_(i, c));
                    J->add(e0 + c, R0 + i, Ja_(i, c));
                }
                for (int c = 0; c < Jb_.cols(); ++c) {
                    J->add(R0 + i, b0 + c, Jb_(i, c));
                    J->add(b0 + c, R0 + i, Jb_(i, c));
                }
            }
            if (wK != 0.0) geometric_stiffness(k, wK, *J);
        }
    }

   public:
    int rebase(VecX& v, VecX& a) override {
        VecX v1, a1, v2, a2;
        const int k = el_eq_.rebase(v1, a1) + mb_eq_.rebase(v2, a2);
        v.head(n1_) = v1;
        a.head(n1_) = a1;
        return k;
    }

    void chart_rates(const VecX& w, VecX& zd) const override {
        VecX z1, z2;
        el_eq_.chart_rates(w.head(n1_), z1);
        mb_eq_.chart_rates(w.tail(n2_), z2);
        zd.resize(n1_ + n2_);
        zd << z1, z2;
    }
    void rate_increments(const VecX& dz, VecX& w) const override {
        VecX w1, w2;
        el_eq_.rate_increments(dz.head(n1_), w1);
        mb_eq_.rate_increments(dz.tail(n2_), w2);
        w.resize(n1_ + n2_);
        w << w1, w2;
    }
    double chart_rotation() const override { return std::max(el_eq_.chart_rotation(), mb_eq_.chart_rotation()); }
    void set_rebase_angle(double angle) override {
        el_eq_.set_rebase_angle(angle);
        mb_eq_.set_rebase_angle(angle);
    }

    void accept(double t, double h) override {
        el_eq_.accept(t, h);
        mb_eq_.accept(t, h);
    }
    double mass_flow(double t) const override { return el_eq_.mass_flow(t); }
    void set_static_load_factor(double f) override {
        el_eq_.set_static_load_factor(f);
        mb_eq_.set_static_load_factor(f);
    }
    void set_static_mass_flow(double mdot) override {
        el_eq_.set_static_mass_flow(mdot);
        mb_eq_.set_static_mass_flow(mdot);
    }
    void predict_stresses(const VecX* dz) override {
        if (dz == nullptr) return el_eq_.predict_stresses(nullptr);
        const VecX head = dz->head(n1_);
        el_eq_.predict_stresses(&head);
    }
    RefreshPolicy refresh_policy() const override { return mb_.refresh_policy(); }
    std::string singular_mass_hint() const override {
        return el_.singular_mass_hint() + " Or: " + mb_.singular_mass_hint() +
               ", or a coupling locks a motion the bodies' joints already lock";
    }

   private:
    // Coupling k's spring-damper (axial spring or bushing) between the element node (its
    // own coordinates; map: the node's support basis, fixed; an ANCF node's position rows
    // only) and the body node (a stand-in frame node as MbSpring's: x = p, phi = 0, frame
    // A_b A0^T, phi_dot = omega; maps Jp, Ja): its forces into r and wK dF/dq + wC dF/dv
    // into J, exact (the body node's maps turning at fixed force and moment, its velocity's
    // change with the configuration, and the second order of the stand-in's chart).
    void spring(std::size_t k, double wK, double wC, VecX* r, Triplets* J) {
        using RowMat = Eigen::Matrix<double, 12, 12, Eigen::RowMajor>;
        const Coupling& cp = cp_[k];
        const int i = cp.element_node, body = cp.joint.body_b, nd = cp.joint.node_b;
        const State& st = el_.state;
        const MbState& ms = mb_.state();
        const bool frame = el_.model.kinds[i] == NodeKind::frame;
        const Eigen::MatrixXd& T = el_.model.bases[i];
        Vec3d pb;
        core_.node(ms, body, nd, pb, Ab_, &Jpb_, &Jab_);
        const auto vb = ms.v.segment(core_.offset(body), Jpb_.cols());
        const Vec3d pd = Jpb_ * vb, wb = Jab_ * vb;
        State ss(*cp.spring_model);
        for (int c = 0; c < 3; ++c) {
            ss.q[c] = st.q[6 * i + c];
            ss.v[c] = st.v[6 * i + c];
            ss.q[3 + c] = frame ? st.q[6 * i + 3 + c] : 0.0;
            ss.v[3 + c] = frame ? st.v[6 * i + 3 + c] : 0.0;
            ss.q[6 + c] = pb[c];
            ss.v[6 + c] = pd[c];
            ss.q[9 + c] = 0.0;
            ss.v[9 + c] = wb[c];
        }
        if (frame) ss.frames[0] = st.frames[i];
        ss.frames[1] = to_mat3(Ab_ * cp.joint.C0.transpose());
        const double weights[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
        RowMat K, C;
        double res[12];
        double* Jk[2] = {K.data(), C.data()};
        ElementOutputs out;
        out.nw = J ? 2 : 0;
        out.weights = weights;
        out.r = res;
        out.J = Jk;
        const LoadState none;
        cp.spring->kernel(ElementInputs{ss, none, nullptr}, out);
        const int e0 = first_col(k), b0 = body_col(k);
        const int ne = static_cast<int>(T.cols()), nb = static_cast<int>(Jpb_.cols());
        MatX Ge = MatX::Zero(6, ne), Gb(6, nb);
        Ge.topRows(3) = T.topRows(3);
        if (frame) Ge.bottomRows(3) = T.bottomRows(3);
        Gb << Jpb_, Jab_;
        const Eigen::Map<const Eigen::Matrix<double, 6, 1>> re(res), rb(res + 6);
        if (r) {
            r->segment(e0, ne).noalias() += Ge.transpose() * re;
            r->segment(b0, nb).noalias() += Gb.transpose() * rb;
        }
        if (!J) return;
        // the stand-in's rotation rates phi_dot = T(phi)^-1 omega move by skew(omega) u / 2
        // with its rotation u = Ja dq
        K.middleCols<3>(9) += 0.5 * C.middleCols<3>(9) * skew(wb);
        core_.node_velocity_derivative(ms, body, nd, K_);
        const MatX* G[2] = {&Ge, &Gb};
        const int c0[2] = {e0, b0};
        const Vec3d fb(res[6], res[7], res[8]), mb(res[9], res[10], res[11]);
        for (int a = 0; a < 2; ++a)
            for (int b = 0; b < 2; ++b) {
                const Eigen::Matrix<double, 6, 6> Kab = K.block<6, 6>(6 * a, 6 * b), Cab = C.block<6, 6>(6 * a, 6 * b);
                MatX B = G[a]->transpose() * ((wK * Kab + wC * Cab) * *G[b]);
                if (b == 1 && wK != 0.0) B.noalias() += wK * G[a]->transpose() * (Cab * K_);
                if (a == 1 && b == 1 && wK != 0.0) {
                    // the node maps turning at fixed forces, and the stand-in's moment
                    // Ja^T T(phi)^-T m with T^-T m = m - skew(m) phi / 2 + ...
                    core_.node_stiffness(ms, body, nd, fb, mb, wK, B);
                    if (!mb.isZero(0.0)) B.noalias() -= 0.5 * wK * Jab_.transpose() * (skew(mb) * Jab_);
                }
                for (int cc = 0; cc < B.cols(); ++cc)
                    for (int rr = 0; rr < B.rows(); ++rr) J->add(c0[a] + rr, c0[b] + cc, B(rr, cc));
            }
    }

    // A clamped ANCF node (planar): its position in the plane and its slope's direction
    // (3 rows); a frame node: the joint's rows.
    int rows(const Coupling& c) const { return c.rows(el_.model.kinds[c.element_node]); }
    int first_col(std::size_t k) const { return el_.model.first_dof[cp_[k].element_node]; }
    int body_col(std::size_t k) const { return n1_ + core_.offset(cp_[k].joint.body_b); }

    // Coupling k's equations and Jacobians (element node's reduced coordinates, body's).
    void equations(std::size_t k, VecX& c, MatX& Ja, MatX& Jb) {
        const Coupling& cp = cp_[k];
        const int i = cp.element_node;
        const State& st = el_.state;
        const Eigen::MatrixXd& T = el_.model.bases[i];
        if (el_.model.kinds[i] == NodeKind::ancf) {
            ancf_clamp(cp, T, c, Ja, Jb);
            return;
        }
        const Vec3<double> phi{{st.q[6 * i + 3], st.q[6 * i + 4], st.q[6 * i + 5]}};
        const Vec3d pa(st.q[6 * i], st.q[6 * i + 1], st.q[6 * i + 2]);
        Aa_ = from_mat3(st.rotation(i));
        // dp = dx, spatial rotation d alpha = T(phi) d phi; through the node's support basis
        Jpa_ = T.topRows(3);
        Jaa_ = from_mat3(rotation_jacobian(phi)) * T.bottomRows(3);
        Vec3d pb;
        core_.node(mb_.state(), cp.joint.body_b, cp.joint.node_b, pb, Ab_, &Jpb_, &Jab_);
        const int nr = cp.joint.rows();
        c.resize(nr);
        Ja.resize(nr, T.cols());
        Jb.resize(nr, Jpb_.cols());
        joint_rows(cp.joint, pa, Aa_, Jpa_, Jaa_, pb, Ab_, &Jpb_, &Jab_, c, Ja, Jb);
    }

    // ANCF node [r, r'] clamped to a body node in the x-y plane: c = [r - p (x, y);
    // (r' x e)_z] with e = A_b d the slope's direction in the body node's frame (d, of
    // unit length, in axis_b). Variations: de = d alpha x e, so d(r' x e)_z =
    // (r' . e) d alpha_z in the plane.
    void ancf_clamp(const Coupling& cp, const Eigen::MatrixXd& T, VecX& c, MatX& Ja, MatX& Jb) {
        const int i = cp.element_node;
        const State& st = el_.state;
        Vec3d pb;
        core_.node(mb_.state(), cp.joint.body_b, cp.joint.node_b, pb, Ab_, &Jpb_, &Jab_);
        const Vec3d r(st.q[6 * i], st.q[6 * i + 1], st.q[6 * i + 2]);
        const Vec3d rs(st.q[6 * i + 3], st.q[6 * i + 4], st.q[6 * i + 5]);
        const Vec3d e = Ab_ * cp.joint.axis_b;
        c.resize(3);
        c << r[0] - pb[0], r[1] - pb[1], rs[0] * e[1] - rs[1] * e[0];
        Ja.resize(3, T.cols());
        Ja.row(0) = T.row(0);
        Ja.row(1) = T.row(1);
        Ja.row(2) = e[1] * T.row(3) - e[0] * T.row(4);
        Jb.resize(3, Jpb_.cols());
        Jb.row(0) = -Jpb_.row(0);
        Jb.row(1) = -Jpb_.row(1);
        Jb.row(2) = rs.dot(e) * Jab_.row(2);
    }

    // wK d(C^T lambda)/dq of coupling k at fixed lambda over the element node's reduced
    // coordinates and the body's, from the node maps and orientations of the equations(k)
    // just evaluated.
    void geometric_stiffness(std::size_t k, double wK, Triplets& J) {
        const Coupling& cp = cp_[k];
        const int nr = rows(cp);
        const auto lam = lam3_.segment(rows_[k], nr);
        if (lam.isZero(0.0)) return;
        const int i = cp.element_node, body = cp.joint.body_b, nd = cp.joint.node_b;
        const int e0 = first_col(k), b0 = body_col(k);
        const State& st = el_.state;
        const Eigen::MatrixXd& T = el_.model.bases[i];
        const int ne = static_cast<int>(T.cols()), nb = static_cast<int>(Jpb_.cols());
        K_.setZero(ne + nb, ne + nb);
        auto Kee = K_.topLeftCorner(ne, ne);
        auto Keb = K_.topRightCorner(ne, nb);
        auto Kbe = K_.bottomLeftCorner(nb, ne);
        auto Kbb = K_.bottomRightCorner(nb, nb);
        if (el_.model.kinds[i] == NodeKind::ancf) {
            // body node: force -(lam0, lam1, 0), moment lam2 (r' . e) e_z, e turning with it;
            // element rows lam2 (e_y T_3 - e_x T_4) turn with e (de = d alpha x e)
            const Vec3d rs(st.q[6 * i + 3], st.q[6 * i + 4], st.q[6 * i + 5]);
            const Vec3d e = Ab_ * cp.joint.axis_b;
            const double wl = wK * lam(2);
            core_.node_stiffness(mb_.state(), body, nd, Vec3d(-lam(0), -lam(1), 0.0),
                                 Vec3d(0.0, 0.0, lam(2) * rs.dot(e)), wK, Kbb);
            Kbb.noalias() += wl * Jab_.row(2).transpose() * (e.cross(rs).transpose() * Jab_);
            Kbe.noalias() += wl * Jab_.row(2).transpose() * (e.transpose() * T.middleRows(3, 3));
            const Mat3d E = skew(e);
            Keb.noalias() += wl * (T.row(4).transpose() * E.row(0) - T.row(3).transpose() * E.row(1)) * Jab_;
        } else {
            JointNodeForces F;
            F.clear();
            joint_reactions(cp.joint, Aa_, Ab_, false, lam, F);
            // the element node's rotation map T(phi) Tr turns with phi = Tr z (its position map is fixed)
            const auto Tr = T.bottomRows(3);
            Mat3<double> Tp, dT[3], Td, dTd[3];
            rotation_jacobian_derivatives(Vec3<double>{{st.q[6 * i + 3], st.q[6 * i + 4], st.q[6 * i + 5]}},
                                          Vec3<double>{}, Tp, dT, Td, dTd);
            Mat3d G;
            for (int c = 0; c < 3; ++c) G.col(c) = from_mat3(dT[c]).transpose() * F.m[0];
            Kee.noalias() += wK * Tr.transpose() * (G * Tr);
            core_.node_stiffness(mb_.state(), body, nd, F.f[1], F.m[1], wK, Kbb);
            add_turning_stiffness(F, 0, 0, Jpa_, Jaa_, Jaa_, wK, Kee);
            add_turning_stiffness(F, 0, 1, Jpa_, Jaa_, Jab_, wK, Keb);
            add_turning_stiffness(F, 1, 0, Jpb_, Jab_, Jaa_, wK, Kbe);
            add_turning_stiffness(F, 1, 1, Jpb_, Jab_, Jab_, wK, Kbb);
        }
        for (int c = 0; c < ne + nb; ++c) {
            const int cc = c < ne ? e0 + c : b0 + (c - ne);
            for (int rr = 0; rr < ne; ++rr) J.add(e0 + rr, cc, K_(rr, c));
            for (int rr = 0; rr < nb; ++rr) J.add(b0 + rr, cc, K_(ne + rr, c));
        }
    }

    ElementEquations& el_;
    MultibodyEquations& mb_;
    Equations& el_eq_;
    Equations& mb_eq_;
    const MultibodySystemCore& core_;
    const std::vector<Coupling>& cp_;
    int n1_, n2_, nc2_, nc3_ = 0;
    std::vector<int> rows_;
    VecX lam3_, r1_, r2_, c_;
    MatX Ja_, Jb_, Jpa_, Jaa_, Jpb_, Jab_, K_;
    Mat3d Aa_, Ab_;  // the node orientations of the last equations()
    Triplets J1_, J2_;
    std::vector<Triplets> J1s_, J2s_;
    std::vector<Triplets> parts_;  // tangents_csc: the bodies' and the couplings' entries
};

}  // namespace

namespace {

// The coupled system in rigid rotation: the element model's RigidRotationEquations and the
// bodies' RigidRotationBodies, joined by the couplings.
class RotatingCoupled final : public RotatingSystem {
   public:
    RotatingCoupled(const Model& model, State& state, const LoadState& load, const MultibodySystemCore& bodies,
                    MbState& body_state, VecX& coupling_lam, const std::vector<Coupling>& couplings,
                    const RotationHinge& h, double length_scale)
        : body_state_(body_state), coupling_lam_(coupling_lam), nc2_(bodies.n_constraints()),
          el_(model, state, load, length_scale, Vec3<double>{{h.point[0], h.point[1], h.point[2]}},
              Vec3<double>{{h.axis[0], h.axis[1], h.axis[2]}}),
          flow_(TimeTable::constant(load.mass_flow)),
          mb_(bodies, body_state, flow_),
          rb_(mb_, bodies, h.point, h.axis),
          eq_(el_.element_equations(), mb_, bodies, couplings, &el_, &rb_) {}
    Equations& equations() override { return eq_; }
    double omega() const override { return rb_.omega(); }
    void set_omega(double w) override {
        el_.set_omega(w);
        rb_.set_omega(w);
    }
    void set_mass_flow(double mdot) override {
        el_.set_mass_flow(mdot);
        flow_ = TimeTable::constant(mdot);
    }
    void rates(VecX& v) override {
        const ElementEquations& el = el_.element_equations();
        v.resize(el.n + mb_.n_coordinates());
        v << reduce(el.model, el.state.v), mb_.state().v;
    }
    void finish(const VecX& lam) override {
        body_state_ = mb_.state();
        body_state_.lam = lam.head(nc2_);
        coupling_lam_ = lam.tail(lam.size() - nc2_);
    }

   private:
    MbState& body_state_;
    VecX& coupling_lam_;
    int nc2_;
    RigidRotationEquations el_;
    TimeTable flow_;
    MultibodyEquations mb_;
    RigidRotationBodies rb_;
    CoupledEquations eq_;
};

}  // namespace

namespace {

// A run of a coupled system: the element model's and the bodies' equations joined by the
// couplings. The element part runs as in dynamics for statics too (hub frame applied,
// loads and gravity times the static load factor).
class CoupledRun final : public Run {
   public:
    CoupledRun(const Model& model, State& state, const LoadState& load, const MultibodySystemCore& bodies,
               MbState& body_state, const std::vector<Coupling>& couplings, VecX& coupling_lam, const Drive& drive,
               System::Mode mode)
        : bodies_(bodies), body_state_(body_state), coupling_lam_(coupling_lam), couplings_(couplings),
          drive_(drive), functions_{drive_.mass_flow, drive_.load_factor}, statics_(mode == System::Mode::statics),
          el_(model, state, load, functions_, drive_.options), mb_(bodies, body_state, functions_.mass_flow, &functions_.load_factor),
          eq_(el_, mb_, bodies, couplings) {
        VecX v1 = reduce(model, state.v), a1 = reduce(model, state.a);
        if (mode != System::Mode::fixed_chart) el_.rebase(0.0, v1, a1);  // the chart of the state's frames: z = 0
        const int n = eq_.n_coordinates(), nc2 = bodies.n_constraints(), nc3 = eq_.n_constraints() - nc2;
        t0 = body_state.t;
        v.resize(n);
        a.resize(n);
        lam.resize(eq_.n_constraints());
        v << v1, body_state.v;
        a << a1, body_state.a;
        lam << body_state.lam, (coupling_lam.size() == nc3 ? coupling_lam : VecX::Zero(nc3));
        // the flow map re-bases the bodies' frames; the element nodes stay in their chart
        const int n1 = model.n_dofs;
        for (int j = 0; j < bodies.n_bodies(); ++j) frame_rotations.push_back(n1 + bodies.offset(j) + 3);
        frames_begin = n1;
        frames_end = n;
    }
    Equations& equations() override { return eq_; }
    void rebase_frames() override {
        VecX unused;  // the bodies' rates are spatial: re-basing keeps them
        mb_.rebase(unused, unused);
    }
    void begin(double t) override { el_.start_work(t); }
    void record(double t, Record& out) override {
        record_element(el_, t, out);
        append_body_outputs(bodies_, mb_.state(), functions_.mass_flow, t, ev_, out, "body_");
        const VecX& lc = eq_.coupling_multipliers();
        auto& series = out("coupling_multipliers", {static_cast<long>(lc.size())});
        series.data.insert(series.data.end(), lc.data(), lc.data() + lc.size());
    }
    // the element part's sensors, the bodies', the couplings' multipliers
    void sense(const SensorSpec& s, double t, double* value, double* rate) override {
        if (s.kind == SensorKind::custom) {
            sense_custom(s, t, SensorState{&el_.state, &mb_.state(), &eq_.coupling_multipliers()}, value);
        } else if (s.kind == SensorKind::energy) {  // the parts' energies together
            double parts[4];
            sense_element(el_, s, t, value, rate);
            sense_bodies(bodies_, mb_.state(), s, t, parts, rate);
            for (int k = 0; k < 4; ++k) value[k] += parts[k];
        } else if (s.part == SensorPart::couplings &&
                   (s.kind == SensorKind::axial_spring || s.kind == SensorKind::bushing)) {
            // a coupling spring: its stand-in nodes at the element node and the body node
            // (CoupledEquations::spring)
            if (s.index < 0 || s.index >= static_cast<int>(couplings_.size()) || !couplings_[s.index].spring)
                throw std::invalid_argument("spring_force sensor: coupling " + std::to_string(s.index) +
                                            " is not a spring");
            const Coupling& cp = couplings_[static_cast<std::size_t>(s.index)];
            const MbState& ms = mb_.state();
            Vec3d pb;
            Mat3d A;
            MatX Jp;
            bodies_.node(ms, cp.joint.body_b, cp.joint.node_b, pb, A, &Jp, nullptr);
            const Vec3d pd = Jp * ms.v.segment(bodies_.offset(cp.joint.body_b), Jp.cols());
            State ss(*cp.spring_model);
            for (int c = 0; c < 3; ++c) {
                ss.q[c] = el_.state.q[6 * cp.element_node + c];
                ss.v[c] = el_.state.v[6 * cp.element_node + c];
                ss.q[6 + c] = pb[c];
                ss.v[6 + c] = pd[c];
            }
            sense_spring(*cp.spring, ss, LoadState{}, s, value);
        } else if (s.part == SensorPart::couplings) {
            const VecX& lc = eq_.coupling_multipliers();
            if (s.kind != SensorKind::joint_force || s.index < 0 || s.index + s.rows > lc.size())
                throw std::invalid_argument("a coupling's sensor is joint_force of its rows (" +
                                            std::to_string(lc.size()) + " coupling rows)");
            for (int k = 0; k < s.rows; ++k) value[k] = lc[s.index + k];
        } else if (s.part == SensorPart::bodies) {
            sense_bodies(bodies_, mb_.state(), s, t, value, rate);
        } else {
            sense_element(el_, s, t, value, rate);
        }
    }
    void finish() override {
        const int nc2 = bodies_.n_constraints();
        body_state_ = mb_.state();
        if (!statics_) {
            coupling_lam_ = eq_.coupling_multipliers();
            return;
        }
        body_state_.lam = lam.head(nc2);
        body_state_.v.setZero();
        body_state_.a.setZero();
        el_.state.v.setZero();
        el_.state.a.setZero();
        coupling_lam_ = lam.tail(eq_.n_constraints() - nc2);
    }

   private:
    const MultibodySystemCore& bodies_;
    MbState& body_state_;
    VecX& coupling_lam_;
    const std::vector<Coupling>& couplings_;
    Drive drive_;
    TimeFunctions functions_;
    bool statics_;
    ElementEquations el_;
    MultibodyEquations mb_;
    CoupledEquations eq_;
    MbEvaluation ev_;
};

class CoupledSystem final : public System {
   public:
    CoupledSystem(const Model& model, State& state, const LoadState& load, const MultibodySystemCore& bodies,
                  const MbState& body_state, std::vector<Coupling> couplings, VecX coupling_lam)
        : model_(model), state_(state), load_(load), bodies_(bodies), body_state_(body_state),
          couplings_(std::move(couplings)), coupling_lam_(std::move(coupling_lam)) {
        check();
    }
    std::unique_ptr<Run> start(const Drive& drive, Mode mode) override {
        check();
        Drive d = drive;
        d.options.length_scale = model_length_scale(model_);
        return std::make_unique<CoupledRun>(model_, state_, load_, bodies_, body_state_, couplings_, coupling_lam_, d,
                                            mode);
    }
    double length_scale() const override { return std::max(model_length_scale(model_), bodies_.length_scale()); }
    int n_coordinates() const override { return model_.n_dofs + bodies_.n_coordinates(); }
    Eigen::VectorXd length_coordinates() const override {
        Eigen::VectorXd out(n_coordinates());
        out << element_length_coordinates(model_), body_length_coordinates(bodies_);
        return out;
    }
    int n_constraints() const override {
        int rows = bodies_.n_constraints();
        for (const Coupling& c : couplings_)  // CoupledEquations::rows
            rows += c.rows(model_.kinds[c.element_node]);
        return rows;
    }
    double record_size() const override {
        return 18.0 * model_.n_nodes() + 5.0 + 12.0 * bodies_.n_bodies() + 3.0 * bodies_.n_coordinates() +
               n_constraints() + 1.0;
    }
    MbState* body_state() override { return &body_state_; }
    const State* element_state() const override { return &state_; }
    const MultibodySystemCore* bodies() const override { return &bodies_; }
    VecX* coupling_multipliers() override { return &coupling_lam_; }
    std::unique_ptr<RotatingSystem> rotating(const RotationHinge& hinge, double mdot, VecX& pin, VecX& lam) override {
        check();
        for (int i = 0; i < model_.n_nodes(); ++i)
            if (model_.kinds[i] == NodeKind::ancf)
                throw std::invalid_argument("steady_rotation: ANCF node " + std::to_string(i) +
                                            ": the rigid rotation's rates are those of frame nodes");
        const int n1 = model_.n_dofs;
        if (hinge.body < 0 ? hinge.element_dof < 0 || hinge.element_dof >= n1 : hinge.body >= bodies_.n_bodies())
            throw std::invalid_argument("steady_rotation: the hinge's body or element coordinate is out of range");
        LoadState load = load_;
        load.mass_flow = mdot;
        auto rot = std::make_unique<RotatingCoupled>(model_, state_, load, bodies_, body_state_, coupling_lam_,
                                                     couplings_, hinge, model_length_scale(model_));
        const int n = rot->equations().n_coordinates(), nc = rot->equations().n_constraints();
        pin = VecX::Zero(n);
        if (hinge.body >= 0)
            pin.segment<3>(n1 + bodies_.offset(hinge.body) + 3) = hinge.axis;
        else
            pin[hinge.element_dof] = 1.0;
        const int nc2 = bodies_.n_constraints(), nc3 = nc - nc2;
        lam.resize(nc);
        lam << body_state_.lam, (coupling_lam_.size() == nc3 ? coupling_lam_ : VecX::Zero(nc3));
        return rot;
    }

   private:
    void check() const {
        check_state(model_, state_);
        bodies_.check_state(body_state_);
        for (const Coupling& c : couplings_)
            if (c.element_node < 0 || c.element_node >= model_.n_nodes())
                throw std::invalid_argument("coupling: element node " + std::to_string(c.element_node) +
                                            " is not a node of the model (it has " +
                                            std::to_string(model_.n_nodes()) + ")");
    }
    const Model& model_;
    State& state_;
    LoadState load_;
    const MultibodySystemCore& bodies_;
    MbState body_state_;
    std::vector<Coupling> couplings_;
    VecX coupling_lam_;
};

}  // namespace

std::unique_ptr<System> coupled_system(const Model& model, State& state, const LoadState& load,
                                       const MultibodySystemCore& bodies, const MbState& body_state,
                                       std::vector<Coupling> couplings, Eigen::VectorXd coupling_lam) {
    return std::make_unique<CoupledSystem>(model, state, load, bodies, body_state, std::move(couplings),
                                           std::move(coupling_lam));
}


}  // namespace pipeflex
