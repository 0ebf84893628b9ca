// Units shared by the tests (each test file once defined its own; one definition lets the test sources
// of an executable be compiled together, GONIO_UNITY_TESTS).
#pragma once

namespace gonio::test_units {

/// One degree in radians.
inline constexpr double kDeg = 3.14159265358979323846 / 180.0;

}  // namespace gonio::test_units
