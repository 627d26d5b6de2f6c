// The Volcast lattice target's dimensions: docs/calibration-target.md and calibration-target.svg.
#include "volcast/calibrate/target.hpp"

namespace volcast {

TargetModel lattice_target() {
  // Five 150 mm polystyrene balls on 20 mm arms of one 20 mm post standing on a base. The centres
  // were chosen so that the ten pairwise distances (316 to 1014 mm) differ by >= 51 mm (any 3
  // balls name themselves), span 0.9 x 0.6 x 0.3 m, and no ball hides another from most views.
  TargetModel m;
  m.name = "volcast-lattice-5x150";
  m.sphere_radius_m = 0.075;
  m.rod_radius_m = 0.010;
  m.centres_m = {{0.180, 1.490, 0.080},
                 {-0.450, 1.340, 0.040},
                 {0.450, 1.490, -0.220},
                 {-0.310, 0.900, 0.100},
                 {-0.130, 0.910, -0.160}};
  // The post, then an arm from the post to each centre; arms meeting the post at nearly the same
  // height as another leave it 50 mm apart and slope to their ball (balls 0 and 4).
  const double arm_start_m[] = {1.440, 1.340, 1.490, 0.900, 0.960};
  m.rods_m.push_back({{0, 0, 0}, {0, 1.49, 0}});
  for (size_t i = 0; i < m.centres_m.size(); ++i)
    m.rods_m.push_back({{0, arm_start_m[i], 0}, m.centres_m[i]});
  return m;
}

}  // namespace volcast
