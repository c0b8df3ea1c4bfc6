#include "lab/model.hpp"

#include <cmath>
#include <stdexcept>

namespace sculpt::lab {

Model Model::from_mesh(const sim::TriangleMesh& mesh, const sim::Material& material,
                       std::span<const std::uint32_t> pinned) {
  Model m;
  m.force_model = material.model;
  m.mass = material.mass;
  m.k = material.stiffness;
  m.c = material.damping;
  m.anchor = material.anchor;
  m.anchor_c = material.anchor_damping;
  m.grab_k = material.grab_stiffness;
  const std::size_t n = mesh.positions.size();
  m.rest.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) m.rest[3 * i + d] = mesh.positions[i][d];
  m.pinned.assign(n, 0);
  for (std::uint32_t p : pinned) {
    if (p >= n) throw std::invalid_argument("pinned vertex " + std::to_string(p) + " does not exist");
    m.pinned[p] = 1;
  }
  for (const sim::Edge& e : sim::unique_edges(mesh.triangles)) {
    if (e.a == e.b) continue;
    // Rest lengths from the float positions, as the daemon computes them.
    double l2 = 0;
    for (int d = 0; d < 3; ++d) {
      const double dd = double(mesh.positions[e.b][d]) - double(mesh.positions[e.a][d]);
      l2 += dd * dd;
    }
    m.springs.push_back({e.a, e.b, std::sqrt(l2)});
  }
  return m;
}

void Model::grab_within(const Vec3& centre, double reach) {
  grabbed.clear();
  grab_offset.clear();
  for (std::uint32_t i = 0; i < n(); ++i) {
    double d2 = 0;
    for (int d = 0; d < 3; ++d) d2 += (rest[3 * i + d] - centre[d]) * (rest[3 * i + d] - centre[d]);
    if (d2 <= reach * reach && !pinned[i]) {
      grabbed.push_back(i);
      for (int d = 0; d < 3; ++d) grab_offset.push_back(rest[3 * i + d] - centre[d]);
    }
  }
}

template <class S>
double forces(const Model& m, const S* x, const S* v, double t, S* f) {
  const std::size_t n = m.n();
  const S k = S(m.k), c = S(m.c), ka = S(m.anchor), ca = S(m.anchor_c);
  double pe = 0;
  for (std::size_t q = 0; q < 3 * n; ++q) f[q] = 0;
  for (const Spring& s : m.springs) {
    const std::size_t a = 3 * s.i, b = 3 * s.j;
    S fs[3];
    if (m.force_model == sim::ForceModel::linear) {
      for (int d = 0; d < 3; ++d) {
        const S u = (x[b + d] - x[a + d]) - S(m.rest[b + d] - m.rest[a + d]);
        fs[d] = k * u + c * (v[b + d] - v[a + d]);
        pe += 0.5 * m.k * double(u) * double(u);
      }
    } else {
      const S dx = x[b] - x[a], dy = x[b + 1] - x[a + 1], dz = x[b + 2] - x[a + 2];
      const S len = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (len > S(0)) {
        const S nx = dx / len, ny = dy / len, nz = dz / len;
        const S dvn = (v[b] - v[a]) * nx + (v[b + 1] - v[a + 1]) * ny + (v[b + 2] - v[a + 2]) * nz;
        const S mag = k * (len - S(s.rest)) + c * dvn;
        fs[0] = mag * nx, fs[1] = mag * ny, fs[2] = mag * nz;
      } else {
        fs[0] = fs[1] = fs[2] = 0;  // no direction, no force (as the daemon)
      }
      const double ext = double(len) - s.rest;
      pe += 0.5 * m.k * ext * ext;
    }
    for (int d = 0; d < 3; ++d) f[a + d] += fs[d], f[b + d] -= fs[d];
  }
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) {
      const S u = x[3 * i + d] - S(m.rest[3 * i + d]);
      f[3 * i + d] += -ka * u - ca * v[3 * i + d];
      pe += 0.5 * m.anchor * double(u) * double(u);
    }
  if (!m.grabbed.empty()) {
    const Vec3 c0 = m.tool(t);
    for (std::size_t g = 0; g < m.grabbed.size(); ++g)
      for (int d = 0; d < 3; ++d) {
        const std::size_t q = 3 * m.grabbed[g] + d;
        const S u = S(c0[d] + m.grab_offset[3 * g + d]) - x[q];
        f[q] += S(m.grab_k) * u;
        pe += 0.5 * m.grab_k * double(u) * double(u);
      }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (m.pinned[i]) f[3 * i] = f[3 * i + 1] = f[3 * i + 2] = 0;
  return pe;
}

template <class S>
double energy(const Model& m, const S* x, const S* v, double t) {
  std::vector<S> f(3 * m.n());
  double e = forces(m, x, v, t, f.data());
  for (std::size_t i = 0; i < m.n(); ++i)
    if (!m.pinned[i])
      for (int d = 0; d < 3; ++d) e += 0.5 * m.mass * double(v[3 * i + d]) * double(v[3 * i + d]);
  return e;
}

template <class S>
void jacobians(const Model& m, const S* x, Eigen::SparseMatrix<S>& K, Eigen::SparseMatrix<S>& C) {
  const Eigen::Index dof = Eigen::Index(3 * m.n());
  std::vector<Eigen::Triplet<S>> kt, ct;
  kt.reserve(m.springs.size() * 36 + 3 * m.n());
  ct.reserve(m.springs.size() * 36 + 3 * m.n());
  auto block = [](std::vector<Eigen::Triplet<S>>& out, std::uint32_t i, std::uint32_t j, const S (&e)[3][3]) {
    // Spring block e between i and j: ∂f_i/∂x_j = e, ∂f_i/∂x_i = −e (and symmetric).
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) {
        if (e[r][q] == S(0)) continue;
        out.emplace_back(3 * i + r, 3 * j + q, e[r][q]);
        out.emplace_back(3 * j + r, 3 * i + q, e[r][q]);
        out.emplace_back(3 * i + r, 3 * i + q, -e[r][q]);
        out.emplace_back(3 * j + r, 3 * j + q, -e[r][q]);
      }
  };
  for (const Spring& s : m.springs) {
    S ke[3][3] = {}, ce[3][3] = {};
    if (m.force_model == sim::ForceModel::linear) {
      for (int d = 0; d < 3; ++d) ke[d][d] = S(m.k), ce[d][d] = S(m.c);
    } else {
      S d3[3];
      S len2 = 0;
      for (int d = 0; d < 3; ++d) d3[d] = x[3 * s.j + d] - x[3 * s.i + d], len2 += d3[d] * d3[d];
      const S len = std::sqrt(len2);
      if (len <= S(0)) continue;
      const S geo = std::max(S(0), S(1) - S(s.rest) / len);
      for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) {
          const S nn = d3[r] * d3[q] / len2;
          ke[r][q] = S(m.k) * (nn + geo * ((r == q ? S(1) : S(0)) - nn));
          ce[r][q] = S(m.c) * nn;
        }
    }
    block(kt, s.i, s.j, ke);
    block(ct, s.i, s.j, ce);
  }
  for (std::size_t q = 0; q < 3 * m.n(); ++q) {
    kt.emplace_back(q, q, S(-m.anchor));
    ct.emplace_back(q, q, S(-m.anchor_c));
  }
  for (std::uint32_t g : m.grabbed)
    for (int d = 0; d < 3; ++d) kt.emplace_back(3 * g + d, 3 * g + d, S(-m.grab_k));
  K.resize(dof, dof);
  C.resize(dof, dof);
  K.setFromTriplets(kt.begin(), kt.end());
  C.setFromTriplets(ct.begin(), ct.end());
}

template double forces<float>(const Model&, const float*, const float*, double, float*);
template double forces<double>(const Model&, const double*, const double*, double, double*);
template double energy<float>(const Model&, const float*, const float*, double);
template double energy<double>(const Model&, const double*, const double*, double);
template void jacobians<float>(const Model&, const float*, Eigen::SparseMatrix<float>&, Eigen::SparseMatrix<float>&);
template void jacobians<double>(const Model&, const double*, Eigen::SparseMatrix<double>&, Eigen::SparseMatrix<double>&);

}  // namespace sculpt::lab
