// Forward-mode automatic differentiation with a fixed number of directions.
//
// Dual<V, N> carries a value of type V and N directional derivatives of type V.
// V may itself be a Dual, which gives nested (second-order) derivatives. The kernels
// are templated on their scalar type, so one implementation yields the residual
// (double), its tangents (Dual<double, 12>) and the convective rotation terms
// (Dual<S, 1> inside).
#pragma once

#include <array>
#include <cmath>
#include <type_traits>

namespace pipeflex {

template <class V, int N>
struct Dual {
    V v{};
    std::array<V, N> d{};

    Dual() = default;
    Dual(double x) : v(x) { d.fill(V(0.0)); }  // NOLINT: implicit from constants
    template <class W = V, class = std::enable_if_t<!std::is_same_v<W, double>>>
    Dual(const V& x) : v(x) { d.fill(V(0.0)); }  // NOLINT
    Dual(const V& x, int k) : v(x) {  // seed direction k
        d.fill(V(0.0));
        d[k] = V(1.0);
    }

    Dual& operator+=(const Dual& o) {
        v += o.v;
        for (int i = 0; i < N; ++i) d[i] += o.d[i];
        return *this;
    }
    Dual& operator-=(const Dual& o) {
        v -= o.v;
        for (int i = 0; i < N; ++i) d[i] -= o.d[i];
        return *this;
    }
    Dual& operator*=(const Dual& o) {
        for (int i = 0; i < N; ++i) d[i] = d[i] * o.v + v * o.d[i];
        v *= o.v;
        return *this;
    }
    Dual& operator/=(const Dual& o) {
        const V inv = V(1.0) / o.v;
        v *= inv;
        for (int i = 0; i < N; ++i) d[i] = (d[i] - v * o.d[i]) * inv;
        return *this;
    }
    Dual operator-() const {
        Dual r;
        r.v = -v;
        for (int i = 0; i < N; ++i) r.d[i] = -d[i];
        return r;
    }
};

template <class V, int N> Dual<V, N> operator+(Dual<V, N> a, const Dual<V, N>& b) { return a += b; }
template <class V, int N> Dual<V, N> operator-(Dual<V, N> a, const Dual<V, N>& b) { return a -= b; }
template <class V, int N> Dual<V, N> operator*(Dual<V, N> a, const Dual<V, N>& b) { return a *= b; }
template <class V, int N> Dual<V, N> operator/(Dual<V, N> a, const Dual<V, N>& b) { return a /= b; }
template <class V, int N> Dual<V, N> operator+(Dual<V, N> a, double b) { a.v += b; return a; }
template <class V, int N> Dual<V, N> operator+(double b, Dual<V, N> a) { a.v += b; return a; }
template <class V, int N> Dual<V, N> operator-(Dual<V, N> a, double b) { a.v -= b; return a; }
template <class V, int N> Dual<V, N> operator-(double b, const Dual<V, N>& a) { return Dual<V, N>(b) - a; }
template <class V, int N> Dual<V, N> operator*(Dual<V, N> a, double b) {
    a.v *= b;
    for (auto& x : a.d) x *= b;
    return a;
}
template <class V, int N> Dual<V, N> operator*(double b, Dual<V, N> a) { return a * b; }
template <class V, int N> Dual<V, N> operator/(Dual<V, N> a, double b) { return a * (1.0 / b); }
template <class V, int N> Dual<V, N> operator/(double b, const Dual<V, N>& a) { return Dual<V, N>(b) / a; }

template <class V, int N> bool operator<(const Dual<V, N>& a, double b) { return a.v < b; }
template <class V, int N> bool operator>(const Dual<V, N>& a, double b) { return a.v > b; }

// Chain rule for a unary function with value f and derivative df at a.v.
template <class V, int N>
Dual<V, N> chain(const Dual<V, N>& a, const V& f, const V& df) {
    Dual<V, N> r;
    r.v = f;
    for (int i = 0; i < N; ++i) r.d[i] = df * a.d[i];
    return r;
}

template <class V, int N> Dual<V, N> sin(const Dual<V, N>& a) {
    using std::cos; using std::sin;
    return chain(a, V(sin(a.v)), V(cos(a.v)));
}
template <class V, int N> Dual<V, N> cos(const Dual<V, N>& a) {
    using std::cos; using std::sin;
    return chain(a, V(cos(a.v)), V(-sin(a.v)));
}
template <class V, int N> Dual<V, N> sqrt(const Dual<V, N>& a) {
    using std::sqrt;
    const V s = sqrt(a.v);
    return chain(a, s, V(0.5) / s);
}

// Value of a scalar, stripping all derivative parts.
inline double value_of(double x) { return x; }
template <class V, int N> double value_of(const Dual<V, N>& a) { return value_of(a.v); }

}  // namespace pipeflex
