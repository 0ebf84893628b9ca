// The IOR table. Sources:
// [Hecht] E. Hecht, "Optics", 4th ed., Addison-Wesley 2002, chapter 4, table of approximate
//         indices of refraction (sodium D line, 589 nm, room temperature).
// [HGK74] H.-J. Hagemann, W. Gudat, C. Kunz, "Optical constants from the far infrared to the
//         x-ray region: Mg, Al, Cu, Ag, Au, Bi, C, and Al2O3", DESY report SR-74/7, 1974
//         (tabulated n, k versus photon energy; the tabulated point nearest to 650, 550 and
//         450 nm is used for R, G and B, its wavelength is given in `conditions`).

#include "gonio/brdf/ior.h"

namespace gonio::brdf {

namespace {

IorEntry dielectric(const char* name, double n, const char* conditions, const char* source) {
    return {name, false, Rgbd::Constant(n), Rgbd::Zero(), conditions, source};
}

IorEntry conductor(const char* name, Rgbd eta, Rgbd k, const char* conditions) {
    return {name,
            true,
            eta,
            k,
            conditions,
            "Hagemann, Gudat, Kunz, DESY report SR-74/7, 1974 (tabulated n, k)"};
}

std::vector<IorEntry> make_table() {
    const char* kHecht = "Hecht, Optics, 4th ed., 2002, ch. 4 (table of indices)";
    const char* kSodiumD = "589 nm, room temperature";
    return {
        dielectric("vacuum", 1.0, "all wavelengths", "definition"),
        dielectric("air", 1.00029, "589 nm, 1 atm", kHecht),
        dielectric("water", 1.333, "589 nm, 20 C", kHecht),
        dielectric("glass", 1.5, "589 nm; common glasses lie in 1.5-1.6", kHecht),
        dielectric("crown-glass", 1.52, kSodiumD, kHecht),
        dielectric("dense-flint-glass", 1.66, kSodiumD, kHecht),
        dielectric("diamond", 2.42, kSodiumD, kHecht),
        conductor("copper",
                  Rgbd(0.214, 1.037, 1.169),
                  Rgbd(3.67, 2.59, 2.36),
                  "R 652.5 nm, G 539.1 nm, B 442.8 nm"),
        conductor("aluminium",
                  Rgbd(1.292, 0.771, 0.548),
                  Rgbd(7.28, 5.91, 5.00),
                  "R 619.9 nm, G 495.9 nm, B 413.3 nm"),
        conductor("gold",
                  Rgbd(0.487, 0.613, 1.826),
                  Rgbd(3.31, 2.64, 1.81),
                  "R 619.9 nm, G 563.5 nm, B 442.8 nm"),
        conductor("silver",
                  Rgbd(0.269, 0.237, 0.226),
                  Rgbd(4.18, 3.09, 2.28),
                  "R 619.9 nm, G 495.9 nm, B 413.3 nm"),
    };
}

}  // namespace

const std::vector<IorEntry>& ior_table() {
    static const std::vector<IorEntry> table = make_table();
    return table;
}

const IorEntry* find_ior(const std::string& name) {
    for (const IorEntry& e : ior_table()) {
        if (name == e.name) {
            return &e;
        }
    }
    return nullptr;
}

std::string ior_names() {
    std::string out;
    for (const IorEntry& e : ior_table()) {
        if (!out.empty()) {
            out += ", ";
        }
        out += e.name;
    }
    return out;
}

}  // namespace gonio::brdf
