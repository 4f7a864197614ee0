// Fixed-size 3-vectors and 3x3 matrices on any scalar type (double or Dual).
// Kept minimal and allocation-free; Eigen is used where the scalar is double.
#pragma once

#include <array>

namespace pipeflex {

template <class S> struct Vec3 {
    std::array<S, 3> c{};
    S& operator[](int i) { return c[i]; }
    const S& operator[](int i) const { return c[i]; }
};

// Row-major 3x3 matrix.
template <class S> struct Mat3 {
    std::array<S, 9> c{};
    S& operator()(int i, int j) { return c[3 * i + j]; }
    const S& operator()(int i, int j) const { return c[3 * i + j]; }
    Vec3<S> col(int j) const { return {{c[j], c[3 + j], c[6 + j]}}; }
};

template <class S> Vec3<S> operator+(const Vec3<S>& a, const Vec3<S>& b) {
    return {{a[0] + b[0], a[1] + b[1], a[2] + b[2]}};
}
template <class S> Vec3<S> operator-(const Vec3<S>& a, const Vec3<S>& b) {
    return {{a[0] - b[0], a[1] - b[1], a[2] - b[2]}};
}
template <class S> Vec3<S> operator-(const Vec3<S>& a) { return {{-a[0], -a[1], -a[2]}}; }
template <class S, class T> Vec3<S> operator*(const T& s, const Vec3<S>& a) {
    return {{a[0] * s, a[1] * s, a[2] * s}};
}
template <class S> Vec3<S>& operator+=(Vec3<S>& a, const Vec3<S>& b) {
    for (int i = 0; i < 3; ++i) a[i] += b[i];
    return a;
}
template <class S> S dot(const Vec3<S>& a, const Vec3<S>& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class S> Vec3<S> cross(const Vec3<S>& a, const Vec3<S>& b) {
    return {{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}};
}
template <class S> Mat3<S> operator*(const Mat3<S>& a, const Mat3<S>& b) {
    Mat3<S> r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = a(i, 0) * b(0, j) + a(i, 1) * b(1, j) + a(i, 2) * b(2, j);
    return r;
}
template <class S> Vec3<S> operator*(const Mat3<S>& a, const Vec3<S>& x) {
    return {{a(0, 0) * x[0] + a(0, 1) * x[1] + a(0, 2) * x[2],
             a(1, 0) * x[0] + a(1, 1) * x[1] + a(1, 2) * x[2],
             a(2, 0) * x[0] + a(2, 1) * x[1] + a(2, 2) * x[2]}};
}
// a^T x
template <class S> Vec3<S> tmul(const Mat3<S>& a, const Vec3<S>& x) {
    return {{a(0, 0) * x[0] + a(1, 0) * x[1] + a(2, 0) * x[2],
             a(0, 1) * x[0] + a(1, 1) * x[1] + a(2, 1) * x[2],
             a(0, 2) * x[0] + a(1, 2) * x[1] + a(2, 2) * x[2]}};
}
template <class S> Mat3<S> transpose(const Mat3<S>& a) {
    Mat3<S> r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = a(j, i);
    return r;
}
// Promote a double matrix/vector to scalar type S.
template <class S> Mat3<S> promote(const Mat3<double>& a) {
    Mat3<S> r;
    for (int i = 0; i < 9; ++i) r.c[i] = S(a.c[i]);
    return r;
}
template <class S> Vec3<S> promote(const Vec3<double>& a) { return {{S(a[0]), S(a[1]), S(a[2])}}; }

}  // namespace pipeflex
