// `gonio acquire --plan-only` lists the plan it would measure: one CSV row per configuration and
// one per unreachable target with why. The rows are checked against the summary line's counts and
// against geometry computed here: every planned pair is above the horizon, and every target in the
// blind zone has its light and detector closer than the rig's 5-degree limit.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"

namespace {

using gonio::testing::CliRun;
using gonio::testing::run_gonio;

struct Row {
    std::string status;
    double theta_i = 0, phi_i = 0, theta_o = 0, phi_o = 0;
    std::string reason;
};

/// Unit vector of (theta, phi) in degrees.
void unit(double theta_deg, double phi_deg, double v[3]) {
    const double k = M_PI / 180.0;
    v[0] = std::sin(theta_deg * k) * std::cos(phi_deg * k);
    v[1] = std::sin(theta_deg * k) * std::sin(phi_deg * k);
    v[2] = std::cos(theta_deg * k);
}

double angle_between_deg(const Row& r) {
    double a[3], b[3];
    unit(r.theta_i, r.phi_i, a);
    unit(r.theta_o, r.phi_o, b);
    const double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return std::acos(std::fmax(-1.0, std::fmin(1.0, c))) * 180.0 / M_PI;
}

TEST(PlanOnly, ListsEveryConfigurationAndEachUnreachableTargetWithWhy) {
    const CliRun r = run_gonio("acquire --plan-only --n-theta 6 --n-dphi 4 --adaptive 0");
    ASSERT_EQ(r.status, 0) << r.out;
    std::istringstream in(r.out);
    std::string line;
    ASSERT_TRUE(std::getline(in, line));
    std::size_t planned = 0, unreachable = 0;
    ASSERT_EQ(std::sscanf(line.c_str(),
                          "# uniform plan: %zu configurations, %zu unreachable",
                          &planned,
                          &unreachable),
              2)
        << line;
    ASSERT_TRUE(std::getline(in, line));
    EXPECT_EQ(line, "status,index,theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,weight,reason");
    std::vector<Row> rows;
    while (std::getline(in, line)) {
        Row row;
        std::istringstream f(line);
        std::string cell;
        std::vector<std::string> cells;
        while (std::getline(f, cell, ',')) {
            cells.push_back(cell);
        }
        ASSERT_GE(cells.size(), 6u) << line;
        row.status = cells[0];
        row.theta_i = std::stod(cells[2]);
        row.phi_i = std::stod(cells[3]);
        row.theta_o = std::stod(cells[4]);
        row.phi_o = std::stod(cells[5]);
        if (cells.size() > 7) {
            row.reason = cells[7];
        }
        rows.push_back(row);
    }
    std::size_t n_planned = 0, n_unreachable = 0;
    for (const Row& row : rows) {
        if (row.status == "planned") {
            ++n_planned;
            EXPECT_LT(row.theta_i, 90.0);
            EXPECT_LT(row.theta_o, 90.0);
            EXPECT_GE(row.theta_i, 0.0);
        } else {
            ASSERT_EQ(row.status, "unreachable");
            ++n_unreachable;
            EXPECT_FALSE(row.reason.empty());
            if (row.reason.find("blind zone") != std::string::npos) {
                EXPECT_LT(angle_between_deg(row), 5.0 + 1e-3)
                    << "a blind-zone target whose arms are apart: " << row.theta_i << " "
                    << row.phi_i << " " << row.theta_o << " " << row.phi_o;
            }
        }
    }
    EXPECT_EQ(n_planned, planned);
    EXPECT_EQ(n_unreachable, unreachable);
    EXPECT_GT(planned, 20u);
    EXPECT_GT(unreachable, 0u) << "the default rig's blind zone holds the retro-reflection targets";
}

}  // namespace
