#pragma once

// The Blender picture of the HTML report (`gonio report DIR --blender`): the fit of DIR/fit.json
// exported to Blender (blender_export.h, approximations allowed and named), rendered by Blender and
// compared with gonio's own evaluation (blender_render.h), drawn as one picture beside the report's
// sphere previews: gonio's f cos(theta_i), Blender's render (one exposure for both) and the
// relative difference per pixel (black 0 %, white 5 % or more).

#include <string>

#include "gonio/base/error.h"

namespace gonio::report {

/// Writes DIR/previews/blender.png and its caption DIR/previews/blender.txt (the measured
/// difference and what the export approximates). Blender runs in a temporary folder that is
/// removed afterwards. Error when there is no fit.json, when the export refuses the model, or when
/// Blender fails (the message says which).
Expected<std::string> write_blender_preview(const std::string& dir, int size_px);

/// The caption written beside previews/blender.png; a generic one when the file is missing.
std::string blender_preview_caption(const std::string& previews_dir);

}  // namespace gonio::report
