#include "pipeflex/solvers/transient.hpp"

#include <algorithm>
#include <cmath>

namespace pipeflex {

namespace {

double table_value(const TimeTable& f, double time) {
    const auto& t = f.t;
    const auto& value = f.value;
    if (t.empty()) return 0.0;
    if (time <= t.front()) return value.front();
    if (time >= t.back()) return value.back();
    const auto it = std::upper_bound(t.begin(), t.end(), time);
    const std::size_t k = static_cast<std::size_t>(it - t.begin());
    const double s = (time - t[k - 1]) / (t[k] - t[k - 1]);
    return value[k - 1] + s * (value[k] - value[k - 1]);
}

double table_rate(const TimeTable& f, double time) {
    const auto& t = f.t;
    if (t.size() < 2 || time < t.front() || time >= t.back()) return 0.0;
    const auto it = std::upper_bound(t.begin(), t.end(), time);
    const std::size_t k = static_cast<std::size_t>(it - t.begin());
    return (f.value[k] - f.value[k - 1]) / (t[k] - t[k - 1]);
}

}  // namespace

double TimeTable::at(double time) const {
    const double env = table_value(*this, time);
    return omega == 0.0 ? env : mean + env * std::sin(omega * time + phase);
}

double TimeTable::rate(double time) const {
    const double d = table_rate(*this, time);
    if (omega == 0.0) return d;
    const double arg = omega * time + phase;
    return d * std::sin(arg) + table_value(*this, time) * omega * std::cos(arg);
}

double gravity_potential(const Model& model, const State& s, const LoadState& load) {
    double V = 0.0;
    Vec3<double> g;
    for (int i = 0; i < 3; ++i) g[i] = load.gravity[i] * load.gravity_factor;
    for (const auto& e : model.elements) e->add_gravity_potential(s, g, &V);
    for (const auto& nm : model.masses) {
        Vec3<double> x{{s.q[6 * nm.node], s.q[6 * nm.node + 1], s.q[6 * nm.node + 2]}};
        V -= nm.mass * dot(g, x);
    }
    return V;
}

}  // namespace pipeflex
