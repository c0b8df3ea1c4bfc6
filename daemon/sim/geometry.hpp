// Small closest-point routines for the narrow phase.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace sculpt::sim::geometry {

template <class S>
using V3 = std::array<S, 3>;

template <class S>
inline V3<S> sub(const V3<S>& a, const V3<S>& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
template <class S>
inline V3<S> add(const V3<S>& a, const V3<S>& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
template <class S>
inline V3<S> mul(const V3<S>& a, S s) { return {a[0] * s, a[1] * s, a[2] * s}; }
template <class S>
inline S dot(const V3<S>& a, const V3<S>& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
template <class S>
inline V3<S> cross(const V3<S>& a, const V3<S>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// Closest point to p on the segment [a, b] (a point when a == b).
template <class S>
inline V3<S> closest_on_segment(const V3<S>& p, const V3<S>& a, const V3<S>& b) {
  const V3<S> ab = sub(b, a);
  const S len2 = dot(ab, ab);
  if (!(len2 > S(0))) return a;
  const S t = std::clamp(dot(sub(p, a), ab) / len2, S(0), S(1));
  return add(a, mul(ab, t));
}

// Closest point to p on triangle (a, b, c) with its barycentric weights
// (Ericson, Real-Time Collision Detection, 5.1.5). Degenerate triangles fall
// into the edge/vertex regions and stay finite.
template <class S>
inline V3<S> closest_on_triangle(const V3<S>& p, const V3<S>& a, const V3<S>& b, const V3<S>& c, V3<S>& w) {
  const V3<S> ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const S d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return w = {1, 0, 0}, a;
  const V3<S> bp = sub(p, b);
  const S d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return w = {0, 1, 0}, b;
  const S vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const S v = d1 / (d1 - d3);
    return w = {1 - v, v, 0}, add(a, mul(ab, v));
  }
  const V3<S> cp = sub(p, c);
  const S d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return w = {0, 0, 1}, c;
  const S vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const S t = d2 / (d2 - d6);
    return w = {1 - t, 0, t}, add(a, mul(ac, t));
  }
  const S va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const S t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return w = {0, 1 - t, t}, add(b, mul(sub(c, b), t));
  }
  const S denom = va + vb + vc;
  if (!(std::abs(denom) > S(0))) return w = {1, 0, 0}, a;
  const S v = vb / denom, u = vc / denom;
  w = {1 - v - u, v, u};
  return add(a, add(mul(ab, v), mul(ac, u)));
}

// Closest pair between a segment and a triangle, by alternating projection
// (converges for convex sets; four rounds are plenty at contact scale).
template <class S>
inline V3<S> segment_point_nearest_triangle(const V3<S>& p0, const V3<S>& p1, const V3<S>& a, const V3<S>& b,
                                            const V3<S>& c) {
  if (p0 == p1) return p0;
  V3<S> w{};
  const V3<S> centroid = mul(add(add(a, b), c), S(1) / S(3));
  V3<S> q = closest_on_segment(centroid, p0, p1);
  for (int k = 0; k < 4; ++k) q = closest_on_segment(closest_on_triangle(q, a, b, c, w), p0, p1);
  return q;
}

}  // namespace sculpt::sim::geometry
