// Names of the model enums, as used in JSON and on the command line.

#include "gonio/brdf/model.h"

namespace gonio::brdf {

const char* to_string(Distribution d) {
    switch (d) {
        case Distribution::kGgx:
            return "ggx";
        case Distribution::kBeckmann:
            return "beckmann";
        case Distribution::kBlinnPhong:
            return "blinn-phong";
        case Distribution::kStudentT:
            return "student-t";
        case Distribution::kTabulated:
            return "tabulated";
    }
    return "?";
}

const char* to_string(Shadowing s) {
    switch (s) {
        case Shadowing::kSmithCorrelated:
            return "smith-correlated";
        case Shadowing::kSmithSeparable:
            return "smith-separable";
        case Shadowing::kVGroove:
            return "v-groove";
        case Shadowing::kNone:
            return "none";
    }
    return "?";
}

const char* to_string(FresnelType f) {
    switch (f) {
        case FresnelType::kNone:
            return "none";
        case FresnelType::kSchlick:
            return "schlick";
        case FresnelType::kDielectric:
            return "dielectric";
        case FresnelType::kConductor:
            return "conductor";
    }
    return "?";
}

}  // namespace gonio::brdf
