// The libusb carrier of U3V bytes: the control interface (class 0xEF, subclass 0x05, protocol 0)
// with a bulk OUT and a bulk IN endpoint, the streaming interface (protocol 2) with a bulk IN.

#include "gonio/devices/usb_transport.h"

#include <libusb.h>

#include <cstdio>
#include <cstdlib>

#include "gonio/devices/usb_devices.h"

namespace gonio::devices {

namespace {

struct Endpoints {
    int control_interface = -1;
    int stream_interface = -1;
    unsigned char control_out = 0, control_in = 0, stream_in = 0;
};

Endpoints find_endpoints(libusb_device* dev) {
    Endpoints ep;
    libusb_config_descriptor* cfg = nullptr;
    if (libusb_get_active_config_descriptor(dev, &cfg) != 0) {
        return ep;
    }
    for (int i = 0; i < cfg->bNumInterfaces; ++i) {
        const libusb_interface& itf = cfg->interface[i];
        for (int a = 0; a < itf.num_altsetting; ++a) {
            const libusb_interface_descriptor& d = itf.altsetting[a];
            if (d.bInterfaceClass != kU3vInterfaceClass ||
                d.bInterfaceSubClass != kU3vInterfaceSubclass) {
                continue;
            }
            for (int e = 0; e < d.bNumEndpoints; ++e) {
                const libusb_endpoint_descriptor& epd = d.endpoint[e];
                if ((epd.bmAttributes & 0x3) != LIBUSB_TRANSFER_TYPE_BULK) {
                    continue;
                }
                const bool in = (epd.bEndpointAddress & LIBUSB_ENDPOINT_IN) != 0;
                if (d.bInterfaceProtocol == kU3vProtocolControl) {
                    ep.control_interface = d.bInterfaceNumber;
                    (in ? ep.control_in : ep.control_out) = epd.bEndpointAddress;
                } else if (d.bInterfaceProtocol == kU3vProtocolStream && in) {
                    ep.stream_interface = d.bInterfaceNumber;
                    ep.stream_in = epd.bEndpointAddress;
                }
            }
        }
    }
    libusb_free_config_descriptor(cfg);
    return ep;
}

class UsbTransport : public U3vTransport {
  public:
    UsbTransport(libusb_context* ctx, libusb_device_handle* h, Endpoints ep, std::string name)
        : ctx_(ctx), h_(h), ep_(ep), name_(std::move(name)) {}
    ~UsbTransport() override {
        libusb_release_interface(h_, ep_.control_interface);
        if (ep_.stream_interface >= 0) {
            libusb_release_interface(h_, ep_.stream_interface);
        }
        libusb_close(h_);
        libusb_exit(ctx_);
    }

    Expected<void> control_out(const Bytes& bytes, std::chrono::milliseconds timeout) override {
        int done = 0;
        const int rc = libusb_bulk_transfer(h_,
                                            ep_.control_out,
                                            const_cast<unsigned char*>(bytes.data()),
                                            static_cast<int>(bytes.size()),
                                            &done,
                                            static_cast<unsigned>(timeout.count()));
        if (rc != 0 || done != static_cast<int>(bytes.size())) {
            return fail(rc, "control OUT");
        }
        return {};
    }

    Expected<Bytes> control_in(std::size_t max_bytes, std::chrono::milliseconds timeout) override {
        return bulk_in(ep_.control_in, max_bytes, timeout, "control IN");
    }

    Expected<Bytes> stream_in(std::size_t max_bytes, std::chrono::milliseconds timeout) override {
        if (ep_.stream_interface < 0) {
            failure_ = TransportFailure::kOther;
            return make_error(name_ + ": the device has no streaming interface");
        }
        return bulk_in(ep_.stream_in, max_bytes, timeout, "stream IN");
    }

    void stream_flush() override {
        if (ep_.stream_interface >= 0) {
            libusb_clear_halt(h_, ep_.stream_in);
        }
    }

    TransportFailure last_failure() const override { return failure_; }
    std::string describe() const override { return name_; }

  private:
    tl::unexpected<Error> fail(int rc, const char* what) {
        failure_ = rc == LIBUSB_ERROR_TIMEOUT     ? TransportFailure::kTimeout
                   : rc == LIBUSB_ERROR_NO_DEVICE ? TransportFailure::kDisconnected
                                                  : TransportFailure::kOther;
        return make_error(name_ + ": " + what + ": " +
                          (rc != 0 ? libusb_error_name(rc) : "short transfer"));
    }

    Expected<Bytes> bulk_in(unsigned char ep,
                            std::size_t max_bytes,
                            std::chrono::milliseconds timeout,
                            const char* what) {
        Bytes buf(max_bytes);
        int done = 0;
        // libusb treats 0 as "no timeout": wait at least 1 ms.
        const auto ms = static_cast<unsigned>(std::max<long long>(1, timeout.count()));
        const int rc =
            libusb_bulk_transfer(h_, ep, buf.data(), static_cast<int>(buf.size()), &done, ms);
        if (rc != 0) {
            return fail(rc, what);
        }
        buf.resize(static_cast<std::size_t>(done));
        return buf;
    }

    libusb_context* ctx_;
    libusb_device_handle* h_;
    Endpoints ep_;
    std::string name_;
    TransportFailure failure_ = TransportFailure::kOther;
};

}  // namespace

Expected<std::unique_ptr<U3vTransport>> open_usb_transport(const std::string& selector) {
    const std::string name = "usb:" + selector;
    int want_bus = -1, want_addr = -1;
    {
        int b = 0, a = 0;
        char tail = 0;
        if (std::sscanf(selector.c_str(), "%d-%d%c", &b, &a, &tail) == 2) {
            want_bus = b;
            want_addr = a;
        }
    }
    libusb_context* ctx = nullptr;
    if (const int rc = libusb_init(&ctx); rc != 0) {
        return make_error(name + ": libusb_init: " + libusb_error_name(rc));
    }
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx, &list);
    std::string problems;
    libusb_device_handle* found = nullptr;
    Endpoints found_ep;
    for (ssize_t i = 0; i < n && found == nullptr; ++i) {
        libusb_device* dev = list[i];
        if (want_bus >= 0 && (libusb_get_bus_number(dev) != want_bus ||
                              libusb_get_device_address(dev) != want_addr)) {
            continue;
        }
        const Endpoints ep = find_endpoints(dev);
        if (ep.control_interface < 0 || ep.control_in == 0 || ep.control_out == 0) {
            continue;
        }
        libusb_device_descriptor desc{};
        libusb_get_device_descriptor(dev, &desc);
        libusb_device_handle* h = nullptr;
        const int rc = libusb_open(dev, &h);
        if (rc != 0) {
            problems += std::string("; ") + libusb_error_name(rc) +
                        (rc == LIBUSB_ERROR_ACCESS ? " (" + udev_rule_hint(desc.idVendor) + ")"
                                                   : std::string());
            continue;
        }
        if (want_bus < 0) {
            unsigned char serial[256] = {};
            const int len =
                libusb_get_string_descriptor_ascii(h, desc.iSerialNumber, serial, sizeof serial);
            if (len <= 0 || selector != std::string(reinterpret_cast<char*>(serial),
                                                    static_cast<std::size_t>(len))) {
                libusb_close(h);
                continue;
            }
        }
        found = h;
        found_ep = ep;
    }
    if (n >= 0) {
        libusb_free_device_list(list, 1);
    }
    if (found == nullptr) {
        libusb_exit(ctx);
        return make_error(name + ": no USB3 Vision device matches" +
                          (problems.empty() ? std::string(" (none found)") : problems));
    }
    libusb_set_auto_detach_kernel_driver(found, 1);
    for (int itf : {found_ep.control_interface, found_ep.stream_interface}) {
        if (itf < 0) {
            continue;
        }
        if (const int rc = libusb_claim_interface(found, itf); rc != 0) {
            libusb_close(found);
            libusb_exit(ctx);
            return make_error(name + ": claiming interface " + std::to_string(itf) + ": " +
                              libusb_error_name(rc));
        }
    }
    return std::unique_ptr<U3vTransport>(new UsbTransport(ctx, found, found_ep, name));
}

}  // namespace gonio::devices
