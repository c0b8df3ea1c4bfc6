#include "sim/grab.hpp"

#include <algorithm>

namespace sculpt::sim {

template <class S>
void GrabSprings<S>::begin(Body<S>& b, std::span<ToolTrack<S>> tracks, double alpha0, int substeps) {
  body_ = &b;
  stiffness_ = static_cast<S>(b.material.grab_stiffness);
  inv_mass_ = static_cast<S>(1.0 / b.material.mass);
  substeps_ = substeps;
  any_ = false;
  for (std::size_t t = 0; t < track_.size(); ++t) {
    track_[t] = b.tools[t].grabbing ? &tracks[t] : nullptr;
    if (!track_[t]) continue;
    centre_[t] = tracks[t].centre(alpha0);
    any_ = true;
  }
}

template <class S>
void GrabSprings<S>::pull_tools() {
  for (std::size_t t = 0; t < track_.size(); ++t) {
    ToolTrack<S>* tr = track_[t];
    if (!tr) continue;
    const ToolContact<S>& tc = body_->tools[t];
    for (std::uint32_t g = 0; g < tc.grab_count; ++g) {
      const geometry::V3<S> f = force(centre_[t], tc.grabs[g]);
      tr->force[0] -= double(f[0]) / substeps_, tr->force[1] -= double(f[1]) / substeps_,
          tr->force[2] -= double(f[2]) / substeps_;
    }
    tr->contacts = std::max(tr->contacts, tc.grab_count);
  }
}

template <class S>
void GrabSprings<S>::accelerate(std::uint32_t blk, kernel::ForceArgs<S>& a) const {
  const std::uint32_t b0 = body_->begin_of(blk), b1 = body_->end_of(blk);
  for (std::size_t t = 0; t < track_.size(); ++t) {
    if (!track_[t]) continue;
    const ToolContact<S>& tc = body_->tools[t];
    const Grab<S>* first = tc.grabs.data();
    const Grab<S>* g =
        std::lower_bound(first, first + tc.grab_count, b0, [](const Grab<S>& gr, std::uint32_t v) { return gr.i < v; });
    for (; g != first + tc.grab_count && g->i < b1; ++g) {
      const geometry::V3<S> f = force(centre_[t], *g);
      const std::uint32_t k = g->i - a.acc_origin;
      a.ax[k] += f[0] * inv_mass_, a.ay[k] += f[1] * inv_mass_, a.az[k] += f[2] * inv_mass_;
    }
  }
}

template <class S>
void GrabSprings<S>::mark_blocks(bool on) {
  for (const ToolContact<S>& tc : body_->tools)
    for (std::uint32_t g = 0; g < tc.grab_count; ++g) body_->block[tc.grabs[g].i / kernel::kBlock].grabbed = on;
}

template class GrabSprings<float>;
template class GrabSprings<double>;

}  // namespace sculpt::sim
