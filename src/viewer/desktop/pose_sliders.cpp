#include "volcast/viewer/pose_sliders.hpp"

#include "volcast/io/site_config.hpp"

namespace volcast {

RigidTransform apply_sliders(const RigidTransform& received, const PoseSliders& sliders) {
  return {rotation_from_degrees(sliders.rotation_deg.cast<double>()) * received.rotation,
          received.translation + sliders.translation_mm.cast<double>() / 1000.0};
}

}  // namespace volcast
