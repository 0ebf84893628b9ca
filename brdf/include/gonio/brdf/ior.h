#pragma once

// Indices of refraction of common media, each with its source and conditions. Dielectrics have a
// real index (the same in the three channels); conductors a complex index eta + i k at three
// wavelengths standing for the R, G, B channels. Values are relative to vacuum; the model uses
// them as relative to the incident medium (air, whose index differs from 1 by 3e-4).

#include <string>
#include <vector>

#include "gonio/brdf/coords.h"

namespace gonio::brdf {

struct IorEntry {
    const char* name;        ///< Lower-case key used in model JSON ("copper").
    bool conductor;          ///< True when k matters (a metal).
    Rgbd eta;                ///< Real part of the index per channel (R, G, B).
    Rgbd k;                  ///< Extinction coefficient per channel, >= 0 (0 for dielectrics).
    const char* conditions;  ///< Wavelengths and temperature the numbers belong to.
    const char* source;      ///< Publication the numbers come from.
};

/// Every entry, dielectrics first.
const std::vector<IorEntry>& ior_table();

/// The entry named `name` (exact, lower case), or nullptr.
const IorEntry* find_ior(const std::string& name);

/// "vacuum, air, ..." for error messages.
std::string ior_names();

}  // namespace gonio::brdf
