// Sensors recorded at every accepted step, and crossing sensors (sensors.hpp); the element
// model's sensors (sense_element).
#include "pipeflex/solvers/sensors.hpp"

#include "pipeflex/assembly/axial_spring.hpp"
#include "pipeflex/assembly/bushing.hpp"
#include "pipeflex/assembly/ground_spring.hpp"
#include "pipeflex/assembly/pipe_element.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/core/small_matrix_eigen.hpp"
#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/system.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pipeflex {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The rotation vector of R (|phi| <= pi): angle from the trace and the skew part together
// (accurate at small angles, where acos alone loses half the digits).
Vec3<double> rotation_vector(const Mat3<double>& R) {
    const Vec3<double> w{{0.5 * (R(2, 1) - R(1, 2)), 0.5 * (R(0, 2) - R(2, 0)), 0.5 * (R(1, 0) - R(0, 1))}};
    const double s = std::sqrt(dot(w, w)), c = 0.5 * (R(0, 0) + R(1, 1) + R(2, 2) - 1.0);
    const double angle = std::atan2(s, c);
    if (s < 1e-300) return Vec3<double>{{0.0, 0.0, 0.0}};
    return (angle / s) * w;
}

// A node's spatial angular velocity (as record() reports it).
Vec3<double> angular_velocity(const State& st, int i) {
    const Vec3<double> phi{{st.q[6 * i + 3], st.q[6 * i + 4], st.q[6 * i + 5]}};
    const Vec3<double> phid{{st.v[6 * i + 3], st.v[6 * i + 4], st.v[6 * i + 5]}};
    if (st.kinds[i] == NodeKind::ancf) return (1.0 / dot(phi, phi)) * cross(phi, phid);
    return rotation_jacobian(phi) * phid;
}

// The root of the cubic Hermite interpolant p of (t0, y0, d0), (t1, y1, d1) in [t0, t1],
// where y0 and y1 have opposite signs (or y1 = 0): bisection safeguarded secant steps
// (Illinois) to round-off.
double hermite_root(double t0, double y0, double d0, double t1, double y1, double d1) {
    const double h = t1 - t0;
    auto p = [&](double x) {  // x in [0, 1]
        const double x2 = x * x, x3 = x2 * x;
        return (2 * x3 - 3 * x2 + 1) * y0 + (x3 - 2 * x2 + x) * h * d0 + (-2 * x3 + 3 * x2) * y1 +
               (x3 - x2) * h * d1;
    };
    if (y1 == 0.0) return t1;
    double a = 0.0, b = 1.0, fa = y0, fb = y1;
    int side = 0;
    for (int it = 0; it < 200 && b - a > 4e-16; ++it) {
        double x = (a * fb - b * fa) / (fb - fa);
        if (!(x > a && x < b)) x = 0.5 * (a + b);
        const double fx = p(x);
        if (fx == 0.0) return t0 + x * h;
        if ((fx < 0.0) == (fa < 0.0)) {
            a = x;
            fa = fx;
            if (side == -1) fb *= 0.5;
            side = -1;
        } else {
            b = x;
            fb = fx;
            if (side == 1) fa *= 0.5;
            side = 1;
        }
    }
    return t0 + 0.5 * (a + b) * h;
}

}  // namespace

int SensorSpec::width() const {
    switch (kind) {
        case SensorKind::node_position:
        case SensorKind::node_velocity:
        case SensorKind::node_acceleration:
        case SensorKind::node_rotation:
        case SensorKind::ground_spring:
        case SensorKind::bushing:
            return 3;
        case SensorKind::energy:
        case SensorKind::strain:
        case SensorKind::section_force:
            return 4;
        case SensorKind::node_angle:
        case SensorKind::axial_spring:
            return 1;
        case SensorKind::joint_force:
        case SensorKind::custom:
            return rows;
    }
    return 0;
}

void SensorLog::reset() {
    for (const auto& c : crossings) {
        if (c.sensor < 0 || c.sensor >= static_cast<int>(sensors.size()))
            throw std::invalid_argument("crossing: sensor " + std::to_string(c.sensor) + " is not in the list of " +
                                        std::to_string(sensors.size()));
        if (c.component < 0 || c.component >= sensors[c.sensor].width())
            throw std::invalid_argument("crossing: component " + std::to_string(c.component) + " out of range");
    }
    t.clear();
    values.assign(sensors.size(), {});
    crossing_times.assign(crossings.size(), {});
    crossing_signs.assign(crossings.size(), {});
    stopped = false;
    stop_time = 0.0;
}

SensorRecorder::SensorRecorder(Run& run, SensorLog& log) : run_(run), log_(log) {
    log_.reset();
    rate_.resize(log_.sensors.size());
    last_rate_.resize(log_.sensors.size());
}

void SensorRecorder::step(double t) {
    const std::size_t k = log_.t.size();  // this sample's index
    log_.t.push_back(t);
    for (std::size_t i = 0; i < log_.sensors.size(); ++i) {
        const SensorSpec& s = log_.sensors[i];
        const int w = s.width();
        buf_.assign(w, 0.0);
        rate_buf_.assign(w, kNaN);
        run_.sense(s, t, buf_.data(), rate_buf_.data());
        auto& v = log_.values[i];
        if (s.kind == SensorKind::node_angle && k > 0) {  // unwrapped: the 2 pi branch nearest the last step
            const double last = v[k - 1];
            buf_[0] += 2.0 * M_PI * std::round((last - buf_[0]) / (2.0 * M_PI));
        }
        v.insert(v.end(), buf_.begin(), buf_.end());
        last_rate_[i].swap(rate_[i]);
        rate_[i] = rate_buf_;
    }
    if (k == 0) return;
    bool terminal = false;
    double stop = 0.0;
    for (std::size_t j = 0; j < log_.crossings.size(); ++j) {
        const CrossingSpec& c = log_.crossings[j];
        const int w = log_.sensors[c.sensor].width();
        const auto& v = log_.values[c.sensor];
        const double y0 = v[(k - 1) * w + c.component] - c.level, y1 = v[k * w + c.component] - c.level;
        const int sign = y0 < 0.0 && y1 >= 0.0 ? 1 : (y0 > 0.0 && y1 <= 0.0 ? -1 : 0);
        if (sign == 0 || (c.direction != 0 && c.direction != sign)) continue;
        const double t0 = log_.t[k - 1], t1 = t;
        double d0 = last_rate_[c.sensor].empty() ? kNaN : last_rate_[c.sensor][c.component];
        double d1 = rate_[c.sensor][c.component];
        if (!std::isfinite(d0) || !std::isfinite(d1)) {
            // the rates of the parabola through the last three values, or the secant
            const double secant = (y1 - y0) / (t1 - t0);
            d0 = d1 = secant;
            if (k >= 2) {
                const double tm = log_.t[k - 2], ym = v[(k - 2) * w + c.component] - c.level;
                const double s0 = (y0 - ym) / (t0 - tm);
                const double curv = (secant - s0) / (t1 - tm);  // half the second derivative
                d0 = secant - curv * (t1 - t0);
                d1 = secant + curv * (t1 - t0);
            }
        }
        const double tc = hermite_root(t0, y0, d0, t1, y1, d1);
        log_.crossing_times[j].push_back(tc);
        log_.crossing_signs[j].push_back(sign);
        if (c.terminal && (!terminal || tc < stop)) {
            terminal = true;
            stop = tc;
        }
    }
    if (terminal) {
        log_.stopped = true;
        log_.stop_time = stop;
        throw TerminalEvent{stop};
    }
}

void sense_element(const ElementEquations& eq, const SensorSpec& s, double t, double* value, double* rate) {
    const Model& md = eq.model;
    const State& st = eq.state;
    const int N = md.n_nodes();
    auto node = [&](const char* what) {
        if (s.index < 0 || s.index >= N)
            throw std::invalid_argument(std::string(what) + " sensor: node " + std::to_string(s.index) +
                                        " out of range (the model has " + std::to_string(N) + " nodes)");
        return s.index;
    };
    auto element = [&](const char* what) -> const Element& {
        if (s.index < 0 || s.index >= static_cast<int>(md.elements.size()))
            throw std::invalid_argument(std::string(what) + " sensor: element " + std::to_string(s.index) +
                                        " out of range");
        return md.elements[static_cast<std::size_t>(s.index)];
    };
    switch (s.kind) {
        case SensorKind::node_position: {
            const int i = node("node_position");
            for (int k = 0; k < 3; ++k) {
                value[k] = st.q[6 * i + k];
                rate[k] = st.v[6 * i + k];
            }
            return;
        }
        case SensorKind::node_velocity: {
            const int i = node("node_velocity");
            for (int k = 0; k < 3; ++k) {
                value[k] = st.v[6 * i + k];
                rate[k] = st.a[6 * i + k];
            }
            return;
        }
        case SensorKind::node_acceleration: {
            const int i = node("node_acceleration");
            for (int k = 0; k < 3; ++k) value[k] = st.a[6 * i + k];
            return;
        }
        case SensorKind::node_rotation:
        case SensorKind::node_angle: {
            const int i = node("node_rotation");
            const Vec3<double> phi = rotation_vector(st.rotation(i));
            if (s.kind == SensorKind::node_rotation) {
                for (int k = 0; k < 3; ++k) value[k] = phi[k];
                return;
            }
            const Vec3<double> axis{{s.axis[0], s.axis[1], s.axis[2]}};
            value[0] = dot(axis, phi);
            rate[0] = dot(axis, angular_velocity(st, i));
            return;
        }
        case SensorKind::energy: {
            double T, U;
            energies(md, st, &T, &U);
            const double V = gravity_potential(md, st, eq.load_at(t));
            value[0] = T;
            value[1] = U;
            value[2] = V;
            value[3] = T + U + V;
            return;
        }
        case SensorKind::strain:
        case SensorKind::section_force: {
            const char* what = s.kind == SensorKind::strain ? "strain" : "section_force";
            const auto* pipe = dynamic_cast<const PipeElement*>(&element(what));
            if (pipe == nullptr)
                throw std::invalid_argument(std::string(what) + " sensor: element " + std::to_string(s.index) +
                                            " is not a pipe element");
            double q12[12], e[6];
            pipe->gather(st.q, q12);
            const NodeFrames fr{st.frames[pipe->p()], st.frames[pipe->q()]};
            pipe_strains(pipe->data, fr, q12, e);
            const PipeElementData& d = pipe->data;
            const double l = d.l0, x = s.s;
            // the Hermite centre line's curvature between the end bending deformations
            // (eps_3, eps_4 about local y; eps_5, eps_6 about local z: l0 times the end
            // rotations from the chord), linear in s: 2 e / l0^2 for a uniform bend
            const double wp = (4.0 - 6.0 * x) / (l * l), wq = (6.0 * x - 2.0) / (l * l);
            if (s.kind == SensorKind::strain) {
                value[0] = e[0] / l;
                value[1] = e[1] / (l * l);
                value[2] = wp * e[2] + wq * e[3];
                value[3] = wp * e[4] + wq * e[5];
                return;
            }
            // the generalised stresses (eqs. 6-7: the element's law, shear flexibility
            // included); the end moments l0 sigma, the moment linear between them
            const double l3 = l * l * l;
            const double ky = d.EIy / ((1.0 + d.Phi_z) * l3), kz = d.EIz / ((1.0 + d.Phi_y) * l3);
            const double s2 = ky * ((4.0 + d.Phi_z) * e[2] + (-2.0 + d.Phi_z) * e[3]);
            const double s3 = ky * ((-2.0 + d.Phi_z) * e[2] + (4.0 + d.Phi_z) * e[3]);
            const double s4 = kz * ((4.0 + d.Phi_y) * e[4] + (-2.0 + d.Phi_y) * e[5]);
            const double s5 = kz * ((-2.0 + d.Phi_y) * e[4] + (4.0 + d.Phi_y) * e[5]);
            value[0] = (d.EA / l) * e[0];
            value[1] = (d.GJ / l3) * e[1] * l;
            value[2] = l * ((1.0 - x) * s2 + x * s3);
            value[3] = l * ((1.0 - x) * s4 + x * s5);
            return;
        }
        case SensorKind::axial_spring:
        case SensorKind::ground_spring:
        case SensorKind::bushing:
            sense_spring(element("spring_force"), st, eq.load_at(t), s, value);
            return;
        case SensorKind::custom:
            sense_custom(s, t, SensorState{&st, nullptr, nullptr}, value);
            return;
        case SensorKind::joint_force:
            break;
    }
    throw std::invalid_argument("sensor of kind " + std::to_string(static_cast<int>(s.kind)) +
                                " is not available on an element model");
}

// A spring element's force at the state st: an axial spring's tension, a ground spring's
// force on its node (s.kind says which; std::invalid_argument if the element is not one).
void sense_spring(const Element& el, const State& st, const LoadState& load, const SensorSpec& s, double* value) {
    const bool axial = s.kind == SensorKind::axial_spring, bushing = s.kind == SensorKind::bushing;
    const bool is = axial     ? dynamic_cast<const AxialSpring*>(&el) != nullptr
                    : bushing ? dynamic_cast<const Bushing*>(&el) != nullptr
                              : dynamic_cast<const GroundSpring*>(&el) != nullptr;
    if (!is)
        throw std::invalid_argument("spring_force sensor: spring " + std::to_string(s.index) + " is not " +
                                    (axial ? "an axial spring" : bushing ? "a bushing" : "a ground spring"));
    std::vector<double> r(static_cast<std::size_t>(6 * el.n_nodes()), 0.0);
    ElementOutputs out;
    out.r = r.data();
    el.kernel(ElementInputs{st, load, nullptr}, out);
    if (axial) {  // r = [-T e, 0, T e, 0]
        const int a = el.nodes()[0], b = el.nodes()[1];
        Vec3<double> dx;
        for (int k = 0; k < 3; ++k) dx[k] = st.q[6 * b + k] - st.q[6 * a + k];
        const double len = std::sqrt(dot(dx, dx));
        value[0] = (r[6] * dx[0] + r[7] * dx[1] + r[8] * dx[2]) / len;
    } else if (bushing) {
        for (int k = 0; k < 3; ++k) value[k] = -r[6 + k];  // the force on node b
    } else {
        for (int k = 0; k < 3; ++k) value[k] = -r[k];  // the force on the node
    }
}

bool sense_custom(const SensorSpec& s, double t, const SensorState& state, double* value) {
    if (s.kind != SensorKind::custom) return false;
    if (!s.custom) throw std::invalid_argument("custom sensor without a function");
    (*s.custom)(t, state, value);
    return true;
}

void sense_bodies(const MultibodySystemCore& sys, const MbState& st, const SensorSpec& s, double t, double* value,
                  double* rate) {
    (void)t;
    switch (s.kind) {
        case SensorKind::node_position:
        case SensorKind::node_velocity:
        case SensorKind::node_acceleration:
        case SensorKind::node_rotation:
        case SensorKind::node_angle: {
            Vec3d p;
            Mat3d A;
            MatX Jp, Ja;
            sys.node(st, s.body, s.index, p, A, &Jp, &Ja);  // checks the body and node
            const auto vb = st.v.segment(sys.offset(s.body), Jp.cols());
            const auto ab = st.a.segment(sys.offset(s.body), Jp.cols());
            if (s.kind == SensorKind::node_rotation || s.kind == SensorKind::node_angle) {
                const Mat3d A0 = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(s.frame.data());
                const Vec3<double> phi = rotation_vector(to_mat3(A * A0.transpose()));
                if (s.kind == SensorKind::node_rotation) {
                    for (int k = 0; k < 3; ++k) value[k] = phi[k];
                    return;
                }
                const Vec3d omega = Ja * vb;  // the node's spatial angular velocity
                value[0] = s.axis[0] * phi[0] + s.axis[1] * phi[1] + s.axis[2] * phi[2];
                rate[0] = s.axis[0] * omega[0] + s.axis[1] * omega[1] + s.axis[2] * omega[2];
                return;
            }
            // p_dot = Jp v; p_ddot = Jp a + W v (W: the map's change along the motion)
            const Vec3d pd = Jp * vb;
            Vec3d pdd = Vec3d::Zero();
            if (s.kind != SensorKind::node_position) {
                MatX W;
                sys.node_velocity_derivative(st, s.body, s.index, W);
                pdd = Jp * ab + W.topRows(3) * vb;
            }
            for (int k = 0; k < 3; ++k) {
                if (s.kind == SensorKind::node_position) {
                    value[k] = p[k];
                    rate[k] = pd[k];
                } else if (s.kind == SensorKind::node_velocity) {
                    value[k] = pd[k];
                    rate[k] = pdd[k];
                } else {
                    value[k] = pdd[k];
                }
            }
            return;
        }
        case SensorKind::energy: {
            // per body: (1/2) v_l^T M v_l (local velocities), (1/2) (eta - eta0)^T K (eta - eta0),
            // -m g.r - (R^T g).(Ng_eta^T eta); the springs' elastic energy
            double T = 0.0, U = sys.spring_energy(st), V = 0.0;
            const Vec3d& g = sys.gravity();
            for (int j = 0; j < sys.n_bodies(); ++j) {
                const FfrfBodyData& d = sys.body(j).data;
                const int o = sys.offset(j), n = static_cast<int>(d.M.rows()), m = n - 6;
                const Mat3d& R = st.R[j];
                VecX vl(n);
                vl << R.transpose() * st.v.segment<3>(o), R.transpose() * st.v.segment<3>(o + 3),
                    st.v.segment(o + 6, m);
                T += 0.5 * vl.dot(d.M * vl);
                const VecX e = st.eta.segment(o + 6, m) - d.eta0;
                U += 0.5 * e.dot(d.K * e);
                const Vec3d Ng_eta = d.Ng.bottomRows(m).transpose() * st.eta.segment(o + 6, m);
                V -= d.M(0, 0) * g.dot(st.r[j]) + (R.transpose() * g).dot(Ng_eta);
            }
            value[0] = T;
            value[1] = U;
            value[2] = V;
            value[3] = T + U + V;
            return;
        }
        case SensorKind::axial_spring:
        case SensorKind::ground_spring:
        case SensorKind::bushing: {
            if (s.index < 0 || s.index >= sys.n_springs())
                throw std::invalid_argument("spring_force sensor: spring " + std::to_string(s.index) +
                                            " is not one of the bodies' " + std::to_string(sys.n_springs()));
            sense_spring(sys.spring_element(s.index), sys.spring_nodes_state(st, s.index), LoadState{}, s, value);
            return;
        }
        case SensorKind::joint_force:
            if (s.index < 0 || s.index + s.rows > st.lam.size())
                throw std::invalid_argument("joint_force sensor: rows " + std::to_string(s.index) + ".." +
                                            std::to_string(s.index + s.rows - 1) + " are not the joints' (" +
                                            std::to_string(st.lam.size()) + " rows)");
            for (int k = 0; k < s.rows; ++k) value[k] = st.lam[s.index + k];
            return;
        case SensorKind::custom:
            sense_custom(s, t, SensorState{nullptr, &st, nullptr}, value);
            return;
        default:
            break;
    }
    throw std::invalid_argument("sensor of kind " + std::to_string(static_cast<int>(s.kind)) +
                                " is not available on floating-frame bodies");
}

}  // namespace pipeflex
