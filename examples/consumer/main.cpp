// Loads an RGL material file (.bsdf), fits a model to its measured nodes (gonio's default, GGX with
// Schlick Fresnel and a Lambert diffuse lobe, or the options given as "key=value;...", the syntax
// of a fit manifest: e.g. "model=beckmann;shadowing=v-groove"), and prints the file and the fit
// side by side in the plane of incidence (light at 30 degrees).
#include <gonio/batch/fit_request.h>
#include <gonio/brdf/analytic_brdf.h>
#include <gonio/brdf/rgl_bsdf.h>

#include <cmath>
#include <cstdio>

int main(int argc, char** argv) {
    using namespace gonio;
    batch::FitRequest request;
    if (argc < 2 || argc > 3) {
        std::fprintf(stderr, "usage: fit-rgl MATERIAL.bsdf [\"key=value;...\"]\n");
        return 2;
    }
    if (Expected<void> set = batch::set_options(request, argc == 3 ? argv[2] : ""); !set) {
        std::fprintf(stderr, "fit-rgl: %s\n", set.error().message.c_str());
        return 2;
    }
    Expected<brdf::RglBsdf> file = brdf::read_rgl_bsdf(argv[1]);
    if (!file) {
        std::fprintf(stderr, "fit-rgl: %s\n", file.error().message.c_str());
        return 1;
    }
    Expected<batch::FitRun> run = batch::run_fit(brdf::rgl_nodes_to_dataset(*file), request);
    if (!run) {
        std::fprintf(stderr, "fit-rgl: %s\n", run.error().message.c_str());
        return 1;
    }
    if (!run->result.usable()) {
        std::fprintf(stderr,
                     "fit-rgl: the model does not represent these data (not converged or a "
                     "misfit): try other options\n");
        return 1;
    }
    const brdf::AnalyticBrdf fit(run->result.model);
    const double deg = brdf::kPi / 180;
    const brdf::Vec3d wi(std::sin(30 * deg), 0, std::cos(30 * deg));
    std::printf("theta_o file_r file_g file_b fit_r fit_g fit_b\n");
    for (int theta_o = -60; theta_o <= 60; theta_o += 15) {
        const brdf::Vec3d wo(-std::sin(theta_o * deg), 0, std::cos(theta_o * deg));
        const brdf::Rgbd a = file->eval(wi, wo);
        const brdf::Rgbd b = fit.eval(wi, wo);
        std::printf(
            "%d %.6g %.6g %.6g %.6g %.6g %.6g\n", theta_o, a[0], a[1], a[2], b[0], b[1], b[2]);
    }
    return 0;
}
