#pragma once

// The embedded virtual rig of `gonio acquire`: the simulator (sim::SimRig) behind the acquisition
// library's EmbeddedRig seam. Glue only: the campaign rules live in gonio::acquisition, the
// simulated devices in gonio::sim. Built as the small library gonio_embedded_rig so that the
// tests start the same rig the command starts.

#include "gonio/acquisition/image/camera_model.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/sim/sim_rig.h"
#include "gonio/sim/sphere_imaging.h"

namespace gonio::tools {

/// The simulator's camera for a calibrated camera model: same intrinsics (distortion included)
/// and pose.
sim::SphereCamera to_sphere_camera(const acquisition::CameraModel& camera);

/// The simulator serving an image rig (null when the rig's devices are served elsewhere), for
/// tests that inject faults into it.
sim::SimRig* simulator(const acquisition::ImageRig& rig);

/// Starts sim::SimRig for a rig description (its "sim" section), with the sphere of the ground
/// truth when options.sphere_camera is set.
acquisition::EmbeddedRigStarter embedded_rig_starter();

}  // namespace gonio::tools
