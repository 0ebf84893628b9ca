// The split of the command set between gonio (no device, camera or image library) and gonio-full:
// both list the same commands with the same descriptions, gonio hands the device, camera and image
// commands to gonio-full with their arguments and exit status, and gonio itself maps none of those
// libraries.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "cli_run.h"

namespace gonio::testing {
namespace {

/// Output and exit status of a shell command (standard error merged).
CliRun shell(const std::string& cmd) {
    CliRun r;
    FILE* p = popen((cmd + " 2>&1").c_str(), "r");
    if (p == nullptr) {
        return r;
    }
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) {
        r.out.append(buf, n);
    }
    const int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

/// The lines of CLI11's "Subcommands:" section.
std::vector<std::string> subcommand_lines(const std::string& help) {
    std::vector<std::string> out;
    const std::size_t start = help.find("Subcommands:");
    if (start == std::string::npos) {
        return out;
    }
    std::size_t p = help.find('\n', start);
    while (p != std::string::npos && p + 1 < help.size()) {
        const std::size_t e = help.find('\n', p + 1);
        const std::string line = help.substr(p + 1, e == std::string::npos ? e : e - p - 1);
        if (line.empty() || line[0] != ' ') {
            break;
        }
        out.push_back(line);
        p = e;
    }
    return out;
}

TEST(ProcessStart, BothExecutablesListTheSameCommandsAndDescriptions) {
    const CliRun light = run_gonio("--help");
    const CliRun full = shell(std::string(GONIO_FULL_EXE) + " --help");
    ASSERT_EQ(light.status, 0) << light.out;
    ASSERT_EQ(full.status, 0) << full.out;
    const std::vector<std::string> a = subcommand_lines(light.out);
    const std::vector<std::string> b = subcommand_lines(full.out);
    EXPECT_EQ(a.size(), 13u) << light.out;
    EXPECT_EQ(a, b) << "gonio --help:\n" << light.out << "\ngonio-full --help:\n" << full.out;
}

TEST(ProcessStart, DeviceCommandsRunInGonioFullWithTheirArgumentsAndStatus) {
    // A sim option only gonio-full knows, and a usage error that must come back as exit status 2.
    const CliRun help = run_gonio("sim --help");
    EXPECT_EQ(help.status, 0) << help.out;
    EXPECT_NE(help.out.find("serve the virtual rig"), std::string::npos) << help.out;
    const CliRun bad = run_gonio("sim --no-such-option");
    EXPECT_EQ(bad.status, 2) << bad.out;
    EXPECT_NE(bad.out.find("--no-such-option"), std::string::npos) << bad.out;
}

TEST(ProcessStart, GonioMapsNoDeviceCameraOrImageLibrary) {
    // The dynamic loader's list of the objects it maps for the executable (what ldd prints).
    const CliRun trace = shell(std::string("LD_TRACE_LOADED_OBJECTS=1 ") + GONIO_EXE);
    ASSERT_EQ(trace.status, 0) << trace.out;
    ASSERT_NE(trace.out.find("libc.so"), std::string::npos) << trace.out;
    for (const char* lib : {"libopencv",
                            "libaravis",
                            "libmodbus",
                            "libusb",
                            "libOpenEXR",
                            "libgio",
                            "libglib",
                            "libgobject"}) {
        EXPECT_EQ(trace.out.find(lib), std::string::npos) << lib << " is loaded:\n" << trace.out;
    }
    // gonio-full, for contrast, maps them.
    const CliRun full = shell(std::string("LD_TRACE_LOADED_OBJECTS=1 ") + GONIO_FULL_EXE);
    EXPECT_NE(full.out.find("libaravis"), std::string::npos) << full.out;
}

}  // namespace
}  // namespace gonio::testing
