#pragma once

// A raw Modbus client for conformance and fault tests: bytes in, bytes out, over a loopback TCP
// socket or a pseudo-terminal, with bounded waits. Nothing of gonio's Modbus code is used, so the
// tests compare the simulator with the specification rather than with itself.

#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace gonio::test {

using Bytes = std::vector<std::uint8_t>;

/// "01 03 00 CC" -> bytes (spaces ignored).
inline Bytes hex_bytes(const std::string& s) {
    Bytes out;
    std::string d;
    for (char c : s) {
        if (c != ' ') {
            d.push_back(c);
        }
    }
    for (size_t i = 0; i + 1 < d.size(); i += 2) {
        out.push_back(static_cast<std::uint8_t>(std::stoi(d.substr(i, 2), nullptr, 16)));
    }
    return out;
}

inline std::string hex_string(const Bytes& b) {
    static const char* k = "0123456789ABCDEF";
    std::string s;
    for (std::uint8_t x : b) {
        if (!s.empty()) {
            s += ' ';
        }
        s += k[x >> 4];
        s += k[x & 15];
    }
    return s;
}

/// CRC-16/MODBUS as the Modbus over Serial Line specification V1.02 (section 6.2.2 and appendix B)
/// defines it, bit by bit: initial 0xFFFF, polynomial 0xA001 (reflected 0x8005), low byte sent
/// first.
inline Bytes with_crc(Bytes frame) {
    unsigned crc = 0xFFFF;
    for (std::uint8_t b : frame) {
        crc ^= b;
        for (int i = 0; i < 8; ++i) {
            const bool lsb = (crc & 1U) != 0;
            crc >>= 1;
            if (lsb) {
                crc ^= 0xA001U;
            }
        }
    }
    frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    frame.push_back(static_cast<std::uint8_t>(crc >> 8));
    return frame;
}

/// A connected loopback TCP socket (-1 on failure).
inline int tcp_connect(int port, int rcvbuf = 0) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        return -1;
    }
    if (rcvbuf > 0) {
        ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    }
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    sa.sin_port = htons(static_cast<std::uint16_t>(port));
    if (::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
        ::close(fd);
        return -1;
    }
    return fd;
}

inline bool send_all(int fd, const Bytes& b) {
    size_t off = 0;
    while (off < b.size()) {
        ssize_t n = ::send(fd, b.data() + off, b.size() - off, MSG_NOSIGNAL);
        if (n < 0 && errno == ENOTSOCK) {
            n = ::write(fd, b.data() + off, b.size() - off);  // A pseudo-terminal.
        }
        if (n <= 0) {
            return false;
        }
        off += static_cast<size_t>(n);
    }
    return true;
}

/// Reads until `n` bytes arrived, the peer closed (returns what came) or `timeout` passed.
inline Bytes read_bytes(int fd,
                        size_t n,
                        std::chrono::milliseconds timeout,
                        bool* closed = nullptr) {
    Bytes out;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (out.size() < n) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) {
            break;
        }
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) {
            break;
        }
        std::uint8_t buf[512];
        const ssize_t r = ::read(fd, buf, std::min(sizeof buf, n - out.size()));
        if (r <= 0) {
            if (closed != nullptr) {
                *closed = true;
            }
            break;
        }
        out.insert(out.end(), buf, buf + r);
    }
    return out;
}

/// True when nothing arrives within `quiet`.
inline bool silent_for(int fd, std::chrono::milliseconds quiet) {
    pollfd p{fd, POLLIN, 0};
    return ::poll(&p, 1, static_cast<int>(quiet.count())) == 0;
}

/// Opens the client side of the simulator's pseudo-terminal, raw.
inline int open_pty(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) {
        return -1;
    }
    termios t{};
    ::tcgetattr(fd, &t);
    ::cfmakeraw(&t);
    ::tcsetattr(fd, TCSANOW, &t);
    return fd;
}

}  // namespace gonio::test
