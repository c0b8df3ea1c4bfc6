// What a mesh is made of. Shared by the simulation (which integrates it) and
// the scene files (which name it). SI units: metres, kilograms, seconds.
#pragma once

#include <string>

namespace sculpt::sim {

enum class ForceModel {
  spring,  // length-based Hooke spring k(|d|-L0)·d̂ + damper along d̂: rotation-invariant
  linear,  // the original: a_i = k/m Σ((p_j-p_i)-(r_j-r_i)) + damper: exact, not rotation-invariant
};

struct Material {
  std::string name = "rubber";
  ForceModel model = ForceModel::spring;
  double mass = 0.01;         // kg per vertex
  double stiffness = 200.0;   // N/m per spring
  double damping = 0.05;      // N·s/m, damper in parallel with each spring
  double anchor = 2.0;        // N/m per vertex towards its rest position (keeps a free mesh in place)
  double anchor_damping = 0.05; // N·s/m per vertex against its own velocity: damps the rigid (anchor) mode,
                                // which the spring dampers cannot see, so a pushed mesh comes to rest
  double grab_stiffness = 50.0; // N/m per grabbed vertex: the spring that pulls it after a grabbing tool
  bool gravity = false;       // feel the scene's gravity
  bool plastic = false;       // clay: the rest shape yields and the sculpt stays
  double yield_strain = 0.02; // clay: strain beyond which the rest shape flows
};

}  // namespace sculpt::sim
