#include "gonio/report/blender_render.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "gonio/base/atomic_file.h"

extern char** environ;

namespace gonio::report {

namespace {

using brdf::Rgbd;
using brdf::Vec3d;

const char* const kScene =
    R"PY(# gonio: the comparison scene for an exported material (report/blender_render.h).
# Run after the material's script:
#   blender -b --factory-startup --python material.py --python scene.py -- \
#       NAME OUT SIZE SAMPLES LX LY LZ [LX LY LZ ...]
# writes OUT_0.exr, OUT_1.exr, ...: one picture per direction toward the sun.
import math
import sys

import bpy
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:]
name, out_prefix = argv[0], argv[1]
size, samples = int(argv[2]), int(argv[3])
lights = [Vector([float(v) for v in argv[k:k + 3]]).normalized() for k in range(4, len(argv), 3)]
scene = bpy.context.scene
for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj, do_unlink=True)

# The sphere, poles along y (up in the picture), with the material.
bpy.ops.mesh.primitive_uv_sphere_add(segments=128, ring_count=64, radius=1.0,
                                     location=(0.0, 0.0, 0.0), rotation=(math.pi / 2, 0.0, 0.0))
sphere = bpy.context.active_object
bpy.ops.object.shade_smooth()
material = bpy.data.materials[name]
sphere.data.materials.append(material)

# The tangent of the active UV map, as the anisotropic closures see it, into a colour AOV.
tree = material.node_tree
aov = tree.nodes.new("ShaderNodeOutputAOV")
aov.name = "tangent"
tangent = tree.nodes.new("ShaderNodeTangent")
tangent.direction_type = "UV_MAP"
tree.links.new(tangent.outputs["Tangent"], aov.inputs["Color"])
layer = scene.view_layers[0]
layer_aov = layer.aovs.add()
layer_aov.name = "tangent"
layer_aov.type = "COLOR"
layer.use_pass_normal = True

camera_data = bpy.data.cameras.new("gonio_camera")
camera_data.type = "ORTHO"
camera_data.ortho_scale = 2.1
camera = bpy.data.objects.new("gonio_camera", camera_data)
camera.location = (0.0, 0.0, 5.0)
scene.collection.objects.link(camera)
scene.camera = camera

sun_data = bpy.data.lights.new("gonio_sun", type="SUN")
sun_data.energy = 1.0
sun_data.angle = 0.0
sun = bpy.data.objects.new("gonio_sun", sun_data)
scene.collection.objects.link(sun)

world = bpy.data.worlds.new("gonio_black")
world.use_nodes = False
world.color = (0.0, 0.0, 0.0)
scene.world = world

scene.render.engine = "CYCLES"
cycles = scene.cycles
cycles.device = "CPU"
cycles.samples = samples
cycles.use_denoising = False
cycles.use_adaptive_sampling = False
cycles.filter_width = 0.01
cycles.max_bounces = 0
cycles.sample_clamp_direct = 0.0
cycles.sample_clamp_indirect = 0.0
cycles.blur_glossy = 0.0
cycles.light_sampling_threshold = 0.0
scene.render.film_transparent = True
scene.render.resolution_x = size
scene.render.resolution_y = size
scene.render.resolution_percentage = 100
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
settings = scene.render.image_settings
settings.file_format = "OPEN_EXR_MULTILAYER"
settings.color_depth = "32"
settings.exr_codec = "ZIP"
for index, light in enumerate(lights):
    sun.rotation_euler = light.to_track_quat("Z", "Y").to_euler()
    scene.render.filepath = "%s_%d.exr" % (out_prefix, index)
    bpy.ops.render.render(write_still=True)
)PY";

std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

bool is_executable(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
           ::access(path.c_str(), X_OK) == 0;
}

std::string tail_of_file(const std::string& path, std::size_t max_chars) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    std::string s = ss.str();
    if (s.size() > max_chars) {
        s = "..." + s.substr(s.size() - max_chars);
    }
    return s;
}

/// Runs argv with stdout and stderr into log_path; returns the exit status (or an error).
Expected<int> run_logged(const std::vector<std::string>& argv, const std::string& log_path) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(
        &fa, STDOUT_FILENO, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
    posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    std::vector<char*> args;
    for (const std::string& a : argv) {
        args.push_back(const_cast<char*>(a.c_str()));
    }
    args.push_back(nullptr);
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, argv[0].c_str(), &fa, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) {
        return make_error(argv[0] + ": cannot start: " + std::strerror(rc));
    }
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR) {
            return make_error(argv[0] + ": waitpid: " + std::strerror(errno));
        }
    }
    if (WIFSIGNALED(status)) {
        return make_error(argv[0] + ": killed by signal " + std::to_string(WTERMSIG(status)));
    }
    return WEXITSTATUS(status);
}

/// Reads the passes render_and_compare needs from Blender's multilayer EXR.
Expected<BlenderPasses> read_passes(const std::string& path) {
    try {
        Imf::InputFile file(path.c_str());
        const Imath::Box2i dw = file.header().dataWindow();
        BlenderPasses p;
        p.width = dw.max.x - dw.min.x + 1;
        p.height = dw.max.y - dw.min.y + 1;
        const std::size_t n = static_cast<std::size_t>(p.width) * p.height;
        p.rgb.assign(3 * n, 0.f);
        p.alpha.assign(n, 0.f);
        p.normal.assign(3 * n, 0.f);
        p.tangent.assign(3 * n, 0.f);
        Imf::FrameBuffer fb;
        const Imf::ChannelList& channels = file.header().channels();
        auto slot = [&](const std::string& name, float* base, std::size_t stride) -> bool {
            if (channels.findChannel(name.c_str()) == nullptr) {
                return false;
            }
            char* origin =
                reinterpret_cast<char*>(base - (static_cast<std::ptrdiff_t>(dw.min.x) +
                                                static_cast<std::ptrdiff_t>(dw.min.y) * p.width) *
                                                   static_cast<std::ptrdiff_t>(stride));
            fb.insert(
                name.c_str(),
                Imf::Slice(
                    Imf::FLOAT, origin, sizeof(float) * stride, sizeof(float) * stride * p.width));
            return true;
        };
        const char* rgb[3] = {"R", "G", "B"};
        const char* xyz[3] = {"X", "Y", "Z"};
        for (int c = 0; c < 3; ++c) {
            const std::string names[3] = {std::string("ViewLayer.Combined.") + rgb[c],
                                          std::string("ViewLayer.Normal.") + xyz[c],
                                          std::string("ViewLayer.tangent.") + rgb[c]};
            float* bases[3] = {p.rgb.data() + c, p.normal.data() + c, p.tangent.data() + c};
            for (int k = 0; k < 3; ++k) {
                if (!slot(names[k], bases[k], 3)) {
                    return make_error(path + ": channel " + names[k] + " missing");
                }
            }
        }
        if (!slot("ViewLayer.Combined.A", p.alpha.data(), 1)) {
            return make_error(path + ": channel ViewLayer.Combined.A missing");
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        return p;
    } catch (const std::exception& e) {
        return make_error(path + ": " + e.what());
    }
}

/// The local frame (t, n x t, n) of a pixel; false when the pixel is not compared (see the file
/// comment of blender_render.h).
bool pixel_frame(const float* n_in, const float* t_in, Vec3d& x, Vec3d& y, Vec3d& z) {
    z = Vec3d(n_in[0], n_in[1], n_in[2]);
    const double len = z.norm();
    if (!(std::abs(len - 1) < 1e-2)) {
        return false;
    }
    z /= len;
    Vec3d t(t_in[0], t_in[1], t_in[2]);
    t -= z * z.dot(t);
    if (!(t.norm() >= 0.5)) {
        return false;
    }
    x = t.normalized();
    y = z.cross(x);
    return true;
}

double percentile(std::vector<double>& v, double q) {
    const std::size_t k =
        static_cast<std::size_t>(std::floor(q * static_cast<double>(v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

}  // namespace

std::string find_blender() {
    if (const char* env = std::getenv("GONIO_BLENDER"); env != nullptr && *env != '\0') {
        return is_executable(env) ? std::string(env) : std::string();
    }
    const char* path = std::getenv("PATH");
    std::stringstream dirs(path != nullptr ? path : "/usr/bin:/bin");
    std::string dir;
    while (std::getline(dirs, dir, ':')) {
        const std::string candidate = (dir.empty() ? std::string(".") : dir) + "/blender";
        if (is_executable(candidate)) {
            return candidate;
        }
    }
    return {};
}

const std::string& blender_scene_script() {
    static const std::string script(kScene);
    return script;
}

namespace {

/// gonio's f cos(theta_i) at every compared pixel of a view (see blender_render.h).
void expected_pixels(const BlenderPasses& p, const brdf::Brdf& truth, BlenderView& v) {
    const Vec3d wi_world = v.light_dir;
    const Vec3d wo_world(0, 0, 1);
    const std::size_t n = static_cast<std::size_t>(p.width) * p.height;
    for (RadianceImage* img : {&v.render, &v.expected}) {
        img->width = p.width;
        img->height = p.height;
        img->pixels.assign(n, Rgbd::Zero());
        img->covered.assign(n, false);
    }
    for (std::size_t i = 0; i < n; ++i) {
        v.render.pixels[i] = Rgbd(p.rgb[3 * i], p.rgb[3 * i + 1], p.rgb[3 * i + 2]);
        Vec3d x, y, z;
        if (!(p.alpha[i] >= 0.999f) || !pixel_frame(&p.normal[3 * i], &p.tangent[3 * i], x, y, z)) {
            continue;
        }
        const Vec3d wi(wi_world.dot(x), wi_world.dot(y), wi_world.dot(z));
        const Vec3d wo(wo_world.dot(x), wo_world.dot(y), wo_world.dot(z));
        if (!(wo.z() >= 0.1) || !(wi.z() >= 0.05)) {
            continue;
        }
        v.expected.pixels[i] = truth.eval(wi, wo) * wi.z();
        v.expected.covered[i] = v.render.covered[i] = true;
        ++v.pixels;
    }
}

/// The relative differences of the channels worth comparing (see blender_render.h).
void relative_differences(BlenderView& v) {
    const std::size_t n = v.expected.pixels.size();
    Rgbd peak = Rgbd::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        if (v.expected.covered[i]) {
            peak = peak.cwiseMax(v.expected.pixels[i]);
        }
    }
    v.pixel_rel.assign(n, -1.0);
    for (std::size_t i = 0; i < n; ++i) {
        if (!v.expected.covered[i]) {
            continue;
        }
        for (int c = 0; c < 3; ++c) {
            const double e = v.expected.pixels[i][c];
            if (e > 0 && e >= 1e-3 * peak[c]) {
                v.rel.push_back(std::abs(v.render.pixels[i][c] - e) / e);
                v.pixel_rel[i] = std::max(v.pixel_rel[i], v.rel.back());
            }
        }
    }
}

}  // namespace

Expected<BlenderView> compare_passes(const BlenderPasses& p,
                                     const brdf::Brdf& truth,
                                     const Vec3d& light_dir) {
    BlenderView v;
    v.light_dir = light_dir.normalized();
    expected_pixels(p, truth, v);
    relative_differences(v);
    if (v.rel.empty()) {
        return make_error("no pixel of the render to compare (is the sphere lit and in view?)");
    }
    std::vector<double> sorted = v.rel;
    v.median_rel = percentile(sorted, 0.5);
    v.p90_rel = percentile(sorted, 0.9);
    if (!std::isfinite(v.median_rel) || !std::isfinite(v.p90_rel)) {
        return make_error("the render holds values that are not finite");
    }
    return v;
}

Expected<BlenderComparison> render_and_compare(const std::string& material_script,
                                               const std::string& material_name,
                                               const brdf::Brdf& truth,
                                               const BlenderRenderOptions& o) {
    const std::string blender = o.blender.empty() ? find_blender() : o.blender;
    if (blender.empty()) {
        return make_error("blender: not found on PATH (install it: apt-get install blender)");
    }
    if (o.size_px < 8 || o.size_px > 4096 || o.samples < 1 || o.samples > 4096 ||
        o.light_dirs.empty() || o.light_dirs.size() > 16) {
        return make_error("blender render: size " + std::to_string(o.size_px) + " px, " +
                          std::to_string(o.samples) + " samples, " +
                          std::to_string(o.light_dirs.size()) +
                          " sun directions: must be 8 to 4096, 1 to 4096 and 1 to 16");
    }
    const std::string dir = o.work_dir.empty() ? std::string(".") : o.work_dir;
    const std::string material_py = dir + "/material.py";
    const std::string scene_py = dir + "/scene.py";
    const std::string prefix = dir + "/render";
    const std::string log = dir + "/blender.log";
    for (const auto& [path, text] :
         {std::pair{material_py, material_script}, std::pair{scene_py, blender_scene_script()}}) {
        if (auto w = write_file_atomic(path, text); !w) {
            return make_error(w.error().message);
        }
    }
    std::vector<std::string> argv = {blender,
                                     "-b",
                                     "--factory-startup",
                                     "--python-exit-code",
                                     "3",
                                     "--python",
                                     material_py,
                                     "--python",
                                     scene_py,
                                     "--",
                                     material_name,
                                     prefix,
                                     std::to_string(o.size_px),
                                     std::to_string(o.samples)};
    std::vector<std::string> exrs;
    for (std::size_t k = 0; k < o.light_dirs.size(); ++k) {
        const Vec3d l = o.light_dirs[k].normalized();
        for (int c = 0; c < 3; ++c) {
            argv.push_back(num(l[c]));
        }
        exrs.push_back(prefix + "_" + std::to_string(k) + ".exr");
        std::remove(exrs.back().c_str());
    }
    const auto t0 = std::chrono::steady_clock::now();
    const Expected<int> status = run_logged(argv, log);
    BlenderComparison out;
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!status) {
        return make_error(status.error().message);
    }
    std::vector<double> all;
    for (std::size_t k = 0; k < exrs.size(); ++k) {
        if (*status != 0 || ::access(exrs[k].c_str(), R_OK) != 0) {
            return make_error(blender + " exited with status " + std::to_string(*status) +
                              " without writing " + exrs[k] + "; end of its log " + log + ":\n" +
                              tail_of_file(log, 1500));
        }
        Expected<BlenderPasses> passes = read_passes(exrs[k]);
        if (!passes) {
            return make_error(passes.error().message);
        }
        Expected<BlenderView> view = compare_passes(*passes, truth, o.light_dirs[k]);
        if (!view) {
            return make_error(exrs[k] + ": " + view.error().message);
        }
        all.insert(all.end(), view->rel.begin(), view->rel.end());
        out.pixels += view->pixels;
        out.views.push_back(std::move(*view));
    }
    out.median_rel = percentile(all, 0.5);
    out.p90_rel = percentile(all, 0.9);
    return out;
}

}  // namespace gonio::report
