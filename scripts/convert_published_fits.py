#!/usr/bin/env python3
"""Converts the published Lambert + Cook-Torrance fits of Ngan, Durand and Matusik (EGSR 2005) into gonio's
model schema (data/materials/ngan2005.json).

Source line form:
  name = Aggregate(Lambertian(albedo = [r, g, b]), NganCookTorrance(albedo = [r, g, b], eta = F0, roughness = m))
with f = albedo_d / pi + albedo_s * F * D * G / (pi cos_i cos_o) (Beckmann D with slope m, V-groove G, Schlick F
with normal reflectance F0 = eta). In gonio's form f = diffuse/pi + scale * F D G / (4 cos_i cos_o), so
scale = albedo_s * 4 / pi.

usage: convert_published_fits.py INPUT.fit OUTPUT.json
"""
import json
import math
import re
import sys

LINE = re.compile(
    r"^(?P<name>[\w-]+)\s*=\s*Aggregate\(Lambertian\(albedo\s*=\s*\[(?P<d>[^\]]*)\]\),\s*"
    r"NganCookTorrance\(albedo\s*=\s*\[(?P<s>[^\]]*)\],\s*eta\s*=\s*(?P<f0>[-+0-9.eE]+),\s*"
    r"roughness\s*=\s*(?P<m>[-+0-9.eE]+)\)\)\s*$")


def rgb(text, where):
    values = [float(v) for v in text.split(",")]
    if len(values) != 3:
        sys.exit(f"{where}: expected three values, got {len(values)}")
    return values


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dst = sys.argv[1], sys.argv[2]
    materials = {}
    with open(src, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            m = LINE.match(line)
            if not m:
                sys.exit(f"{src}:{number}: line not understood")
            where = f"{src}:{number}"
            scale = [round(a * 4.0 / math.pi, 12) for a in rgb(m["s"], where)]
            f0 = float(m["f0"])
            materials[m["name"]] = {
                "diffuse": rgb(m["d"], where),
                "lobes": [{
                    "distribution": "beckmann",
                    "alpha": float(m["m"]),
                    "shadowing": "v-groove",
                    "fresnel": {"type": "schlick", "f0": [f0, f0, f0]},
                    "scale": scale,
                }],
            }
    document = {
        "source": "Ngan, Durand, Matusik, Experimental Analysis of BRDF Models, EGSR 2005 "
                  "(Lambert + Cook-Torrance fits of MERL materials), as tabulated by the BSDF benchmark "
                  "project; BSD licence in LICENSE beside this file",
        "conversion": "diffuse = Lambertian albedo; beckmann alpha = roughness; v-groove shadowing; "
                      "schlick f0 = eta; scale = NganCookTorrance albedo * 4 / pi",
        "materials": materials,
    }
    with open(dst, "w", encoding="utf-8") as f:
        json.dump(document, f, indent=1)
        f.write("\n")
    print(f"{dst}: {len(materials)} materials")


if __name__ == "__main__":
    main()
