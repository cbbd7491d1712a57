// modal/ad.hpp — forward-mode automatic differentiation.
//
// Dual<T, N> carries a value and N directional derivatives. Nesting gives
// second derivatives: with S = Dual<Dual<double, N>, N>, seeding both levels
// with the same directions yields the value, the gradient and the Hessian of
// any function written once, templated on its scalar:
//
//     template <class S> S f(const S& x, const S& y) { using std::sin; return sin(x) * y; }
//     auto [v, g, H] = modal::ad::hessian<2>([](auto& x) { return f(x[0], x[1]); }, point);
//
// Models write `using std::sin; sin(x)` so that the overloads here are found by
// argument-dependent lookup, and wrap constants as S(c) or plain doubles.
// Comparisons compare values only (branches of piecewise functions follow the
// value, as in every forward-mode AD tool).
#pragma once

#include <Eigen/Core>

#include <array>
#include <cmath>
#include <complex>
#include <type_traits>

namespace modal {

template <class T, int N>
struct Dual {
  static_assert(N >= 1, "a dual number needs at least one direction");
  T v{};                 // value
  std::array<T, N> d{};  // derivatives along the N seeded directions

  Dual() = default;
  Dual(double c) : v(c) {}  // NOLINT: constants convert implicitly
  template <class U = T, std::enable_if_t<!std::is_same_v<U, double>, int> = 0>
  Dual(const T& c) : v(c) {}  // NOLINT: inner-level values convert implicitly
  // Independent variable: value x, derivative 1 along direction i.
  Dual(const T& x, int i) : v(x) { d[static_cast<std::size_t>(i)] = T(1.0); }

  Dual& operator+=(const Dual& o) { v += o.v; for (int i = 0; i < N; ++i) d[i] += o.d[i]; return *this; }
  Dual& operator-=(const Dual& o) { v -= o.v; for (int i = 0; i < N; ++i) d[i] -= o.d[i]; return *this; }
  Dual& operator*=(const Dual& o) { *this = *this * o; return *this; }
  Dual& operator/=(const Dual& o) { *this = *this / o; return *this; }
  Dual& operator+=(double c) { v += c; return *this; }
  Dual& operator-=(double c) { v -= c; return *this; }
  Dual& operator*=(double c) { v *= c; for (auto& x : d) x *= c; return *this; }
  Dual& operator/=(double c) { v /= c; for (auto& x : d) x /= c; return *this; }

  // Chain rule for a unary function with value fv and derivative fd at v.
  static Dual chain(const T& fv, const T& fd, const Dual& x) {
    Dual r;
    r.v = fv;
    for (int i = 0; i < N; ++i) r.d[i] = fd * x.d[i];
    return r;
  }
};

template <class S> struct is_dual : std::false_type {};
template <class T, int N> struct is_dual<Dual<T, N>> : std::true_type {};

// The double inside any (nested) scalar.
inline double value(double x) { return x; }
template <class T, int N> double value(const Dual<T, N>& x) { return value(x.v); }

// --- arithmetic -------------------------------------------------------------
template <class T, int N> Dual<T, N> operator+(const Dual<T, N>& a) { return a; }
template <class T, int N> Dual<T, N> operator-(const Dual<T, N>& a) {
  Dual<T, N> r; r.v = -a.v; for (int i = 0; i < N; ++i) r.d[i] = -a.d[i]; return r;
}
template <class T, int N> Dual<T, N> operator+(Dual<T, N> a, const Dual<T, N>& b) { return a += b; }
template <class T, int N> Dual<T, N> operator-(Dual<T, N> a, const Dual<T, N>& b) { return a -= b; }
template <class T, int N> Dual<T, N> operator*(const Dual<T, N>& a, const Dual<T, N>& b) {
  Dual<T, N> r; r.v = a.v * b.v;
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
  return r;
}
template <class T, int N> Dual<T, N> operator/(const Dual<T, N>& a, const Dual<T, N>& b) {
  Dual<T, N> r; r.v = a.v / b.v;
  const T inv = T(1.0) / b.v;
  for (int i = 0; i < N; ++i) r.d[i] = (a.d[i] - r.v * b.d[i]) * inv;
  return r;
}
template <class T, int N> Dual<T, N> operator+(Dual<T, N> a, double c) { return a += c; }
template <class T, int N> Dual<T, N> operator+(double c, Dual<T, N> a) { return a += c; }
template <class T, int N> Dual<T, N> operator-(Dual<T, N> a, double c) { return a -= c; }
template <class T, int N> Dual<T, N> operator-(double c, const Dual<T, N>& a) { Dual<T, N> r = -a; r.v += c; return r; }
template <class T, int N> Dual<T, N> operator*(Dual<T, N> a, double c) { return a *= c; }
template <class T, int N> Dual<T, N> operator*(double c, Dual<T, N> a) { return a *= c; }
template <class T, int N> Dual<T, N> operator/(Dual<T, N> a, double c) { return a /= c; }
template <class T, int N> Dual<T, N> operator/(double c, const Dual<T, N>& a) { return Dual<T, N>(c) / a; }

// Comparisons look at values only.
#define MODAL_DUAL_COMPARE(op)                                                                   \
  template <class T, int N> bool operator op(const Dual<T, N>& a, const Dual<T, N>& b) { return value(a) op value(b); } \
  template <class T, int N> bool operator op(const Dual<T, N>& a, double b) { return value(a) op b; }                   \
  template <class T, int N> bool operator op(double a, const Dual<T, N>& b) { return a op value(b); }
MODAL_DUAL_COMPARE(<)
MODAL_DUAL_COMPARE(<=)
MODAL_DUAL_COMPARE(>)
MODAL_DUAL_COMPARE(>=)
MODAL_DUAL_COMPARE(==)
MODAL_DUAL_COMPARE(!=)
#undef MODAL_DUAL_COMPARE

// --- elementary functions (found by argument-dependent lookup) --------------
template <class T, int N> Dual<T, N> sin(const Dual<T, N>& x) { using std::sin, std::cos; return Dual<T, N>::chain(sin(x.v), cos(x.v), x); }
template <class T, int N> Dual<T, N> cos(const Dual<T, N>& x) { using std::sin, std::cos; return Dual<T, N>::chain(cos(x.v), -sin(x.v), x); }
template <class T, int N> Dual<T, N> tan(const Dual<T, N>& x) {
  using std::tan; const T t = tan(x.v); return Dual<T, N>::chain(t, T(1.0) + t * t, x);
}
template <class T, int N> Dual<T, N> asin(const Dual<T, N>& x) {
  using std::asin, std::sqrt; return Dual<T, N>::chain(asin(x.v), T(1.0) / sqrt(T(1.0) - x.v * x.v), x);
}
template <class T, int N> Dual<T, N> acos(const Dual<T, N>& x) {
  using std::acos, std::sqrt; return Dual<T, N>::chain(acos(x.v), T(-1.0) / sqrt(T(1.0) - x.v * x.v), x);
}
template <class T, int N> Dual<T, N> atan(const Dual<T, N>& x) {
  using std::atan; return Dual<T, N>::chain(atan(x.v), T(1.0) / (T(1.0) + x.v * x.v), x);
}
template <class T, int N> Dual<T, N> atan2(const Dual<T, N>& y, const Dual<T, N>& x) {
  using std::atan2;
  Dual<T, N> r; r.v = atan2(y.v, x.v);
  const T inv = T(1.0) / (x.v * x.v + y.v * y.v);
  for (int i = 0; i < N; ++i) r.d[i] = (x.v * y.d[i] - y.v * x.d[i]) * inv;
  return r;
}
template <class T, int N> Dual<T, N> sinh(const Dual<T, N>& x) { using std::sinh, std::cosh; return Dual<T, N>::chain(sinh(x.v), cosh(x.v), x); }
template <class T, int N> Dual<T, N> cosh(const Dual<T, N>& x) { using std::sinh, std::cosh; return Dual<T, N>::chain(cosh(x.v), sinh(x.v), x); }
template <class T, int N> Dual<T, N> tanh(const Dual<T, N>& x) {
  using std::tanh; const T t = tanh(x.v); return Dual<T, N>::chain(t, T(1.0) - t * t, x);
}
template <class T, int N> Dual<T, N> exp(const Dual<T, N>& x) { using std::exp; const T e = exp(x.v); return Dual<T, N>::chain(e, e, x); }
template <class T, int N> Dual<T, N> log(const Dual<T, N>& x) { using std::log; return Dual<T, N>::chain(log(x.v), T(1.0) / x.v, x); }
template <class T, int N> Dual<T, N> sqrt(const Dual<T, N>& x) {
  using std::sqrt; const T s = sqrt(x.v); return Dual<T, N>::chain(s, T(0.5) / s, x);
}
template <class T, int N> Dual<T, N> abs(const Dual<T, N>& x) { return value(x) < 0 ? -x : x; }
template <class T, int N> Dual<T, N> fabs(const Dual<T, N>& x) { return abs(x); }
template <class T, int N> Dual<T, N> pow(const Dual<T, N>& x, double p) {
  using std::pow;
  if (p == 0.0) return Dual<T, N>(1.0);
  return Dual<T, N>::chain(pow(x.v, p), T(p) * pow(x.v, p - 1.0), x);
}
template <class T, int N> Dual<T, N> pow(const Dual<T, N>& x, const Dual<T, N>& p) {
  // Integer-valued constant exponents keep negative bases differentiable.
  bool constant_exponent = true;
  for (int i = 0; i < N; ++i) constant_exponent = constant_exponent && value(p.d[i]) == 0.0;
  if (constant_exponent && value(p) == std::round(value(p))) return pow(x, value(p));
  return exp(p * log(x));
}
template <class T, int N> Dual<T, N> pow(double b, const Dual<T, N>& p) { using std::log; return exp(p * log(b)); }
template <class T, int N> Dual<T, N> hypot(const Dual<T, N>& a, const Dual<T, N>& b) { return sqrt(a * a + b * b); }
template <class T, int N> bool isfinite(const Dual<T, N>& x) {
  using std::isfinite; if (!isfinite(x.v)) return false;
  for (const auto& di : x.d) if (!isfinite(di)) return false;
  return true;
}

// --- complex numbers for the complex-step derivative -------------------------
// f'(x) = Im f(x + ih)/h + O(h²) with no cancellation, so h can be 1e-20 and
// the result is exact to rounding (Squire & Trapp 1998; Martins, Sturdza &
// Alonso 2003). Complex is a scalar that Eigen treats as real (NumTraits
// below): squaredNorm() is Σ z², dot() has no conjugate, so the templated
// model evaluates the analytic continuation of its functions, which is what
// the method needs (std::complex would give |z|² and conjugated products).
// Comparisons and branches use the real part, and abs(z) = ±z by its sign,
// as in every complex-step implementation. Functions without a convenient
// analytic form (atan2) are continued to first order in the imaginary part,
// which is all the method uses (its O(h²) remainder is below 1e-40).
struct Complex {
  double re = 0, im = 0;
  Complex() = default;
  Complex(double r) : re(r) {}  // NOLINT: real constants convert implicitly
  Complex(double r, double i) : re(r), im(i) {}
  explicit Complex(const std::complex<double>& z) : re(z.real()), im(z.imag()) {}
  std::complex<double> std() const { return {re, im}; }

  Complex& operator+=(const Complex& o) { re += o.re; im += o.im; return *this; }
  Complex& operator-=(const Complex& o) { re -= o.re; im -= o.im; return *this; }
  Complex& operator*=(const Complex& o) { *this = Complex(re * o.re - im * o.im, re * o.im + im * o.re); return *this; }
  Complex& operator/=(const Complex& o) { *this = Complex(std() / o.std()); return *this; }
};

inline double value(const Complex& z) { return z.re; }
inline Complex operator+(const Complex& a) { return a; }
inline Complex operator-(const Complex& a) { return {-a.re, -a.im}; }
inline Complex operator+(Complex a, const Complex& b) { return a += b; }
inline Complex operator-(Complex a, const Complex& b) { return a -= b; }
inline Complex operator*(Complex a, const Complex& b) { return a *= b; }
inline Complex operator/(Complex a, const Complex& b) { return a /= b; }
inline Complex operator+(Complex a, double c) { a.re += c; return a; }
inline Complex operator+(double c, Complex a) { a.re += c; return a; }
inline Complex operator-(Complex a, double c) { a.re -= c; return a; }
inline Complex operator-(double c, const Complex& a) { return {c - a.re, -a.im}; }
inline Complex operator*(const Complex& a, double c) { return {a.re * c, a.im * c}; }
inline Complex operator*(double c, const Complex& a) { return {a.re * c, a.im * c}; }
inline Complex operator/(const Complex& a, double c) { return {a.re / c, a.im / c}; }
inline Complex operator/(double c, const Complex& a) { return Complex(c) / a; }
#define MODAL_COMPLEX_COMPARE(op)                                                              \
  inline bool operator op(const Complex& a, const Complex& b) { return a.re op b.re; }          \
  inline bool operator op(const Complex& a, double b) { return a.re op b; }                     \
  inline bool operator op(double a, const Complex& b) { return a op b.re; }
MODAL_COMPLEX_COMPARE(<)
MODAL_COMPLEX_COMPARE(<=)
MODAL_COMPLEX_COMPARE(>)
MODAL_COMPLEX_COMPARE(>=)
MODAL_COMPLEX_COMPARE(==)
MODAL_COMPLEX_COMPARE(!=)
#undef MODAL_COMPLEX_COMPARE

#define MODAL_COMPLEX_FUNCTION(f) \
  inline Complex f(const Complex& z) { return Complex(std::f(z.std())); }
MODAL_COMPLEX_FUNCTION(sin)
MODAL_COMPLEX_FUNCTION(cos)
MODAL_COMPLEX_FUNCTION(tan)
MODAL_COMPLEX_FUNCTION(asin)
MODAL_COMPLEX_FUNCTION(acos)
MODAL_COMPLEX_FUNCTION(atan)
MODAL_COMPLEX_FUNCTION(sinh)
MODAL_COMPLEX_FUNCTION(cosh)
MODAL_COMPLEX_FUNCTION(tanh)
MODAL_COMPLEX_FUNCTION(exp)
MODAL_COMPLEX_FUNCTION(log)
MODAL_COMPLEX_FUNCTION(sqrt)
#undef MODAL_COMPLEX_FUNCTION
inline Complex abs(const Complex& z) { return z.re < 0 ? -z : z; }
inline Complex fabs(const Complex& z) { return abs(z); }
inline Complex atan2(const Complex& y, const Complex& x) {
  const double r2 = x.re * x.re + y.re * y.re;
  return {std::atan2(y.re, x.re), r2 > 0 ? (x.re * y.im - y.re * x.im) / r2 : 0.0};
}
inline Complex pow(const Complex& z, double p) {
  if (p == 0.0) return Complex(1.0);
  if (p == std::round(p) && std::abs(p) <= 64) {  // integer powers by products: exact at z.re ≤ 0 too
    Complex r(1.0), b = p > 0 ? z : Complex(1.0) / z;
    for (long k = std::lround(std::abs(p)); k > 0; k >>= 1, b *= b)
      if (k & 1) r *= b;
    return r;
  }
  return Complex(std::pow(z.std(), p));
}
inline Complex pow(const Complex& z, const Complex& p) {
  if (p.im == 0.0) return pow(z, p.re);
  return exp(p * log(z));
}
inline Complex pow(double b, const Complex& p) { return Complex(std::pow(std::complex<double>(b, 0.0), p.std())); }
inline Complex hypot(const Complex& a, const Complex& b) { return sqrt(a * a + b * b); }
inline bool isfinite(const Complex& z) { return std::isfinite(z.re) && std::isfinite(z.im); }

namespace ad {

// Value, gradient and Hessian of f: R^N -> R at x, f templated on its scalar.
// f receives a std::array<S, N>& with S = Dual<Dual<double, N>, N>.
template <int N>
struct SecondOrder {
  double value;
  Eigen::Matrix<double, N, 1> gradient;
  Eigen::Matrix<double, N, N> hessian;
};

template <int N, class F>
SecondOrder<N> hessian(F&& f, const Eigen::Matrix<double, N, 1>& x) {
  using Inner = Dual<double, N>;
  using S = Dual<Inner, N>;
  std::array<S, N> xs;
  for (int i = 0; i < N; ++i) {
    S s(Inner(x[i], i), i);
    xs[static_cast<std::size_t>(i)] = s;
  }
  const S y = f(xs);
  SecondOrder<N> r;
  r.value = y.v.v;
  for (int i = 0; i < N; ++i) {
    r.gradient[i] = y.v.d[static_cast<std::size_t>(i)];
    for (int j = 0; j < N; ++j) r.hessian(i, j) = y.d[static_cast<std::size_t>(i)].d[static_cast<std::size_t>(j)];
  }
  return r;
}

// Value and gradient of f: R^N -> R at x (first-order forward mode). T is
// the scalar of x: double, or Complex for the gradient at a complex point.
template <int N, class T = double>
struct FirstOrder {
  T value;
  Eigen::Matrix<T, N, 1> gradient;
};

template <int N, class F, class T>
FirstOrder<N, T> gradient(F&& f, const Eigen::Matrix<T, N, 1>& x) {
  using S = Dual<T, N>;
  std::array<S, N> xs;
  for (int i = 0; i < N; ++i) xs[static_cast<std::size_t>(i)] = S(x[i], i);
  const S y = f(xs);
  FirstOrder<N, T> r;
  r.value = y.v;
  for (int i = 0; i < N; ++i) r.gradient[i] = y.d[static_cast<std::size_t>(i)];
  return r;
}

}  // namespace ad
}  // namespace modal

// Eigen needs to know that Dual is a real scalar so that fixed-size matrices of
// duals (rotations, positions) work in templated models.
namespace Eigen {
template <class T, int N>
struct NumTraits<modal::Dual<T, N>> : NumTraits<double> {
  using Real = modal::Dual<T, N>;
  using NonInteger = modal::Dual<T, N>;
  using Nested = modal::Dual<T, N>;
  using Literal = modal::Dual<T, N>;
  enum {
    IsComplex = 0, IsInteger = 0, IsSigned = 1, RequireInitialization = 1,
    ReadCost = 1, AddCost = 1 + N, MulCost = 1 + 2 * N
  };
  static inline Real epsilon() { return Real(std::numeric_limits<double>::epsilon()); }
  static inline Real dummy_precision() { return Real(1e-12); }
  static inline int digits10() { return NumTraits<double>::digits10(); }
};
template <>
struct NumTraits<modal::Complex> : NumTraits<double> {
  using Real = modal::Complex;
  using NonInteger = modal::Complex;
  using Nested = modal::Complex;
  using Literal = modal::Complex;
  enum {
    IsComplex = 0, IsInteger = 0, IsSigned = 1, RequireInitialization = 1,
    ReadCost = 1, AddCost = 2, MulCost = 6
  };
  static inline Real epsilon() { return Real(std::numeric_limits<double>::epsilon()); }
  static inline Real dummy_precision() { return Real(1e-12); }
  static inline int digits10() { return NumTraits<double>::digits10(); }
};
template <typename Op>
struct ScalarBinaryOpTraits<modal::Complex, double, Op> { using ReturnType = modal::Complex; };
template <typename Op>
struct ScalarBinaryOpTraits<double, modal::Complex, Op> { using ReturnType = modal::Complex; };
template <class T, int N, typename Op>
struct ScalarBinaryOpTraits<modal::Dual<T, N>, double, Op> { using ReturnType = modal::Dual<T, N>; };
template <class T, int N, typename Op>
struct ScalarBinaryOpTraits<double, modal::Dual<T, N>, Op> { using ReturnType = modal::Dual<T, N>; };
}  // namespace Eigen
