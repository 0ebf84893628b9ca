// Register and memory addresses at the top of the 32-bit space sent to `gonio camera serve` over
// UDP on loopback: READREG/WRITEREG of 0xFFFFFFFC (one 12- or 16-byte datagram; a range check that
// computes address + 4 in 32 bits wraps to 0 and reads outside the bootstrap block), READMEM/
// WRITEMEM blocks that would wrap past 0xFFFFFFFF to address 0. Each is answered
// GEV_STATUS_INVALID_ADDRESS, the server process keeps running, and it still answers a correct
// READREG and Aravis's own arv-tool afterwards.

#include <signal.h>
#include <sys/wait.h>

#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "gige_test_support.h"

namespace {

using gige_test::arv_value;
using gige_test::RawHost;
using gige_test::run;
namespace gvcp = gonio::devices::gvcp;
namespace gvbs = gonio::devices::gvbs;
namespace gm = gonio::sim::gige_map;

/// `gonio camera serve --ip auto` as a child process; the address it printed.
class ServeProcess {
  public:
    ServeProcess() {
        int out[2];
        if (pipe(out) != 0) {
            return;
        }
        pid_ = fork();
        if (pid_ == 0) {
            dup2(out[1], 1);
            close(out[0]);
            execl(GONIO_BINARY_DIR "/tools/gonio",
                  "gonio",
                  "camera",
                  "serve",
                  "--ip",
                  "auto",
                  "--width",
                  "320",
                  "--height",
                  "240",
                  static_cast<char*>(nullptr));
            _exit(127);
        }
        close(out[1]);
        std::string line;
        char ch;
        while (read(out[0], &ch, 1) == 1 && ch != '\n') {
            line += ch;
        }
        close(out[0]);
        if (line.rfind("gige://", 0) == 0) {
            ip_ = line.substr(std::string("gige://").size());
        }
    }
    ~ServeProcess() {
        if (pid_ > 0 && alive()) {
            kill(pid_, SIGTERM);
            int status = 0;
            waitpid(pid_, &status, 0);
        }
    }
    ServeProcess(const ServeProcess&) = delete;
    ServeProcess& operator=(const ServeProcess&) = delete;

    const std::string& ip() const { return ip_; }
    /// True while the process has not ended; records how it ended otherwise.
    bool alive() {
        if (ended_) {
            return false;
        }
        const pid_t r = waitpid(pid_, &status_, WNOHANG);
        ended_ = r == pid_;
        return r == 0;
    }
    int status() const { return status_; }

  private:
    pid_t pid_ = -1;
    std::string ip_;
    bool ended_ = false;
    int status_ = 0;
};

std::vector<std::uint8_t> corpus_file(const std::string& name) {
    std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/fuzz/corpus/gvcp/" + name, std::ios::binary);
    return std::vector<std::uint8_t>((std::istreambuf_iterator<char>(in)),
                                     std::istreambuf_iterator<char>());
}

TEST(GigeCameraBounds, TopOfAddressSpaceIsRefusedAndTheServerKeepsAnswering) {
    ServeProcess serve;
    ASSERT_FALSE(serve.ip().empty());
    RawHost host(serve.ip());
    struct Case {
        const char* file;
        std::size_t size;
        gvcp::Command answer;
        std::uint16_t req_id;
    };
    const Case cases[] = {
        {"readreg_fffffffc.bin", 12, gvcp::Command::kReadRegAck, 1},
        {"writereg_fffffffc.bin", 16, gvcp::Command::kWriteRegAck, 2},
        {"readmem_wraps_past_fffffffc.bin", 16, gvcp::Command::kReadMemAck, 3},
        {"writemem_wraps_past_fffffffc.bin", 20, gvcp::Command::kWriteMemAck, 4},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.file);
        const std::vector<std::uint8_t> datagram = corpus_file(c.file);
        ASSERT_EQ(datagram.size(), c.size);
        const std::vector<std::uint8_t> reply = host.exchange(datagram);
        auto ack = gvcp::parse_ack(reply.data(), reply.size());
        ASSERT_TRUE(ack.has_value()) << "no acknowledge; server alive: " << serve.alive()
                                     << ", wait status " << serve.status();
        EXPECT_EQ(ack->answer, c.answer);
        EXPECT_EQ(ack->ack_id, c.req_id);
        EXPECT_EQ(ack->status, gvcp::Status::kInvalidAddress);
        ASSERT_TRUE(serve.alive()) << "wait status " << serve.status();
    }
    // The addresses just below the top are refused the same way (no register lives there).
    std::uint32_t v = 0;
    EXPECT_EQ(host.read_reg(0xFFFFFFF8u, &v), gvcp::Status::kInvalidAddress);
    EXPECT_EQ(host.write_reg(0xFFFFFFF8u, 1), gvcp::Status::kInvalidAddress);
    // A correct request gets its correct answer afterwards: the version register and the width.
    std::uint32_t version = 0;
    ASSERT_EQ(host.read_reg(gvbs::kVersion, &version), gvcp::Status::kSuccess);
    EXPECT_EQ(version >> 16, 2u);  // GigE Vision 2.x
    std::uint32_t width = 0;
    ASSERT_EQ(host.read_reg(gm::kRoiBlock, &width), gvcp::Status::kSuccess);
    EXPECT_EQ(width, 320u);
    // So does Aravis, a host of its own.
    const auto r = run("arv-tool-0.8 -a " + serve.ip() + " control Width Height");
    EXPECT_EQ(arv_value(r.out, "Width"), "320") << r.out;
    EXPECT_EQ(arv_value(r.out, "Height"), "240") << r.out;
    EXPECT_TRUE(serve.alive());
}

}  // namespace
