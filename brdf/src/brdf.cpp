// The Brdf interface's default evaluation of many pairs (brdf.h).

#include "gonio/brdf/brdf.h"

namespace gonio::brdf {

void Brdf::eval_many(std::size_t n, const DirectionPairs& dirs, double* const out[3]) const {
    for (std::size_t k = 0; k < n; ++k) {
        const Rgbd f = eval(Vec3d(dirs.wi_x[k], dirs.wi_y[k], dirs.wi_z[k]),
                            Vec3d(dirs.wo_x[k], dirs.wo_y[k], dirs.wo_z[k]));
        for (int c = 0; c < 3; ++c) {
            out[c][k] = f[c];
        }
    }
}

}  // namespace gonio::brdf
