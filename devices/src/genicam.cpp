// GenICam node map subset: parse the device description into nodes and resolve feature values
// down to registers (GenICam GenApi standard 2.x, node types Integer/Float/Enumeration/Command/
// Boolean/String and IntReg/MaskedIntReg/FloatReg/StringReg).

#include "gonio/devices/genicam.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace gonio::devices::genicam {

namespace {

constexpr int kMaxIndirection = 16;

std::string trim(const std::string& s) {
    const char* ws = " \t\r\n";
    const std::size_t a = s.find_first_not_of(ws);
    if (a == std::string::npos) {
        return {};
    }
    return s.substr(a, s.find_last_not_of(ws) - a + 1);
}

Expected<std::int64_t> parse_int(const std::string& node, const std::string& tag, std::string s) {
    s = trim(s);
    errno = 0;
    char* end = nullptr;
    long long v = 0;
    if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
        v = static_cast<long long>(std::strtoull(s.c_str() + 2, &end, 16));
    } else {
        v = std::strtoll(s.c_str(), &end, 10);
    }
    if (s.empty() || end == nullptr || *end != '\0' || errno == ERANGE) {
        return make_error("node '" + node + "': <" + tag + "> value '" + s + "' is not an integer");
    }
    return static_cast<std::int64_t>(v);
}

Expected<double> parse_double(const std::string& node, const std::string& tag, std::string s) {
    s = trim(s);
    if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
        auto i = parse_int(node, tag, s);
        if (!i) {
            return tl::unexpected(i.error());
        }
        return static_cast<double>(*i);
    }
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0' || !std::isfinite(v)) {
        return make_error("node '" + node + "': <" + tag + "> value '" + s +
                          "' is not a finite number");
    }
    return v;
}

bool kind_from_tag(const std::string& tag, NodeKind* kind) {
    static const std::pair<const char*, NodeKind> kTags[] = {
        {"Integer", NodeKind::kInteger},
        {"Float", NodeKind::kFloat},
        {"Enumeration", NodeKind::kEnumeration},
        {"Command", NodeKind::kCommand},
        {"Boolean", NodeKind::kBoolean},
        {"String", NodeKind::kString},
        {"IntReg", NodeKind::kIntReg},
        {"MaskedIntReg", NodeKind::kMaskedIntReg},
        {"FloatReg", NodeKind::kFloatReg},
        {"StringReg", NodeKind::kStringReg},
        {"Category", NodeKind::kCategory},
    };
    for (const auto& t : kTags) {
        if (tag == t.first) {
            *kind = t.second;
            return true;
        }
    }
    return false;
}

bool is_register(NodeKind k) {
    return k == NodeKind::kIntReg || k == NodeKind::kMaskedIntReg || k == NodeKind::kFloatReg ||
           k == NodeKind::kStringReg;
}

Expected<Node> build_node(const XmlElement& el, NodeKind kind) {
    Node n;
    n.kind = kind;
    const std::string* name = el.attribute("Name");
    if (name == nullptr || name->empty()) {
        return make_error("<" + el.name + "> without a Name attribute");
    }
    n.name = *name;
    bool has_bit = false;
    for (const XmlElement& c : el.children) {
        const std::string& t = c.name;
        const std::string text = trim(c.text);
        auto take_double = [&](double* out) -> Expected<void> {
            auto v = parse_double(n.name, t, text);
            if (!v) {
                return tl::unexpected(v.error());
            }
            *out = *v;
            return {};
        };
        auto take_int = [&](std::int64_t* out) -> Expected<void> {
            auto v = parse_int(n.name, t, text);
            if (!v) {
                return tl::unexpected(v.error());
            }
            *out = *v;
            return {};
        };
        Expected<void> r;
        std::int64_t iv = 0;
        if (t == "DisplayName") {
            n.display_name = text;
        } else if (t == "pValue") {
            n.p_value = text;
        } else if (t == "Value") {
            r = take_double(&n.value);
            n.has_value = true;
        } else if (t == "Min") {
            r = take_double(&n.min);
            n.has_min = true;
        } else if (t == "Max") {
            r = take_double(&n.max);
            n.has_max = true;
        } else if (t == "pMin") {
            n.p_min = text;
        } else if (t == "pMax") {
            n.p_max = text;
        } else if (t == "Inc") {
            r = take_int(&n.inc);
            if (r && n.inc <= 0) {
                return make_error("node '" + n.name + "': <Inc> " + text + " must be positive");
            }
        } else if (t == "Unit") {
            n.unit = text;
        } else if (t == "CommandValue") {
            r = take_int(&n.command_value);
        } else if (t == "OnValue") {
            r = take_int(&n.on_value);
        } else if (t == "OffValue") {
            r = take_int(&n.off_value);
        } else if (t == "Address") {
            r = take_int(&iv);
            n.address = static_cast<std::uint64_t>(iv);
        } else if (t == "Length") {
            r = take_int(&iv);
            n.length = static_cast<std::size_t>(iv);
            if (r && (iv <= 0 || iv > 4096)) {
                return make_error("node '" + n.name + "': <Length> " + text + " outside [1, 4096]");
            }
        } else if (t == "AccessMode") {
            if (text != "RO" && text != "WO" && text != "RW") {
                return make_error("node '" + n.name + "': <AccessMode> '" + text +
                                  "' is not RO, WO or RW");
            }
            n.access = text;
        } else if (t == "Endianess") {
            if (text != "LittleEndian" && text != "BigEndian") {
                return make_error("node '" + n.name + "': <Endianess> '" + text +
                                  "' is not LittleEndian or BigEndian");
            }
            n.little_endian = text == "LittleEndian";
        } else if (t == "Sign") {
            n.is_signed = text == "Signed";
        } else if (t == "LSB") {
            r = take_int(&iv);
            n.lsb = static_cast<int>(iv);
        } else if (t == "MSB") {
            r = take_int(&iv);
            n.msb = static_cast<int>(iv);
        } else if (t == "Bit") {
            r = take_int(&iv);
            n.lsb = n.msb = static_cast<int>(iv);
            has_bit = true;
        } else if (t == "EnumEntry") {
            const std::string* en = c.attribute("Name");
            if (en == nullptr) {
                return make_error("enumeration '" + n.name + "': <EnumEntry> without a Name");
            }
            bool found = false;
            for (const XmlElement& v : c.children) {
                if (v.name == "Value") {
                    auto ev = parse_int(n.name + "/" + *en, "Value", v.text);
                    if (!ev) {
                        return tl::unexpected(ev.error());
                    }
                    n.entries.emplace_back(*en, *ev);
                    found = true;
                }
            }
            if (!found) {
                return make_error("enumeration '" + n.name + "': entry '" + *en +
                                  "' has no <Value>");
            }
        }
        if (!r) {
            return tl::unexpected(r.error());
        }
    }
    (void)has_bit;
    if (is_register(kind)) {
        if (n.length == 0) {
            return make_error("register '" + n.name + "' has no <Length>");
        }
        if ((kind == NodeKind::kIntReg || kind == NodeKind::kMaskedIntReg) && n.length > 8) {
            return make_error("register '" + n.name + "': <Length> " + std::to_string(n.length) +
                              " > 8 for an integer register");
        }
        if (kind == NodeKind::kFloatReg && n.length != 4 && n.length != 8) {
            return make_error("register '" + n.name + "': <Length> " + std::to_string(n.length) +
                              " is not 4 or 8 for a float register");
        }
        if (kind == NodeKind::kMaskedIntReg) {
            const int bits = static_cast<int>(n.length * 8);
            if (n.lsb < 0 || n.msb < 0 || n.lsb >= bits || n.msb >= bits) {
                return make_error("register '" + n.name + "': bit field LSB " +
                                  std::to_string(n.lsb) + " MSB " + std::to_string(n.msb) +
                                  " outside a " + std::to_string(bits) + "-bit register");
            }
        }
    }
    if (kind == NodeKind::kEnumeration && n.entries.empty()) {
        return make_error("enumeration '" + n.name + "' has no <EnumEntry>");
    }
    const bool needs_value = kind == NodeKind::kInteger || kind == NodeKind::kFloat ||
                             kind == NodeKind::kEnumeration || kind == NodeKind::kCommand ||
                             kind == NodeKind::kBoolean || kind == NodeKind::kString;
    if (needs_value && n.p_value.empty() && !n.has_value) {
        return make_error("feature '" + n.name + "' has neither <pValue> nor <Value>");
    }
    return n;
}

void collect(const XmlElement& el, std::vector<const XmlElement*>& out, int depth) {
    if (depth > 64) {
        return;
    }
    for (const XmlElement& c : el.children) {
        NodeKind k = NodeKind::kCategory;
        if (kind_from_tag(c.name, &k)) {
            out.push_back(&c);
        } else {
            collect(c, out, depth + 1);
        }
    }
}

std::uint64_t field_mask(int bits) {
    return bits >= 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << bits) - 1);
}

}  // namespace

Expected<NodeMap> NodeMap::parse(const std::string& xml) {
    auto doc = parse_xml(xml);
    if (!doc) {
        return tl::unexpected(doc.error());
    }
    if (doc->name != "RegisterDescription") {
        return make_error("GenICam XML: root element <" + doc->name +
                          "> is not <RegisterDescription>");
    }
    NodeMap map;
    if (const std::string* m = doc->attribute("ModelName")) {
        map.model_name_ = *m;
    }
    if (const std::string* v = doc->attribute("VendorName")) {
        map.vendor_name_ = *v;
    }
    std::vector<const XmlElement*> elements;
    collect(*doc, elements, 0);
    for (const XmlElement* el : elements) {
        NodeKind kind = NodeKind::kCategory;
        kind_from_tag(el->name, &kind);
        auto node = build_node(*el, kind);
        if (!node) {
            return tl::unexpected(with_context("GenICam XML", node.error()));
        }
        if (map.nodes_.count(node->name)) {
            return make_error("GenICam XML: node '" + node->name + "' defined twice");
        }
        map.nodes_.emplace(node->name, std::move(*node));
    }
    // Every pointer must name a node.
    for (const auto& [name, n] : map.nodes_) {
        for (const std::string* p : {&n.p_value, &n.p_min, &n.p_max}) {
            if (!p->empty() && map.nodes_.count(*p) == 0) {
                return make_error("GenICam XML: node '" + name + "' points to unknown node '" + *p +
                                  "'");
            }
        }
    }
    return map;
}

const Node* NodeMap::node(const std::string& name) const {
    auto it = nodes_.find(name);
    return it == nodes_.end() ? nullptr : &it->second;
}

std::vector<std::string> NodeMap::names() const {
    std::vector<std::string> out;
    for (const auto& kv : nodes_) {
        out.push_back(kv.first);
    }
    return out;
}

Expected<const Node*> NodeMap::find(const std::string& name, const char* what) const {
    const Node* n = node(name);
    if (n == nullptr) {
        return make_error("feature '" + name + "' is not in the device's node map");
    }
    (void)what;
    return n;
}

Expected<std::int64_t> NodeMap::read_int_node(const Node& n, int depth) const {
    if (depth > kMaxIndirection) {
        return make_error("node '" + n.name + "': pointer chain deeper than " +
                          std::to_string(kMaxIndirection) + " (a cycle?)");
    }
    switch (n.kind) {
        case NodeKind::kIntReg:
        case NodeKind::kMaskedIntReg: {
            if (n.access == "WO") {
                return make_error("register '" + n.name + "' is write-only (AccessMode WO)");
            }
            if (!port_.read) {
                return make_error("register '" + n.name + "': no device port attached");
            }
            auto bytes = port_.read(n.address, n.length);
            if (!bytes) {
                return tl::unexpected(with_context("register '" + n.name + "'", bytes.error()));
            }
            if (bytes->size() != n.length) {
                return make_error("register '" + n.name + "': read " +
                                  std::to_string(bytes->size()) + " bytes, expected " +
                                  std::to_string(n.length));
            }
            std::uint64_t raw = 0;
            for (std::size_t i = 0; i < n.length; ++i) {
                const std::size_t idx = n.little_endian ? n.length - 1 - i : i;
                raw = (raw << 8) | (*bytes)[idx];
            }
            const int bits = static_cast<int>(n.length * 8);
            if (n.kind == NodeKind::kMaskedIntReg) {
                // Big-endian registers number bits from the most significant one.
                const int lo =
                    n.little_endian ? std::min(n.lsb, n.msb) : bits - 1 - std::max(n.lsb, n.msb);
                const int width = std::abs(n.msb - n.lsb) + 1;
                std::uint64_t v = (raw >> lo) & field_mask(width);
                if (n.is_signed && width < 64 && (v >> (width - 1)) & 1u) {
                    v |= ~field_mask(width);
                }
                return static_cast<std::int64_t>(v);
            }
            if (n.is_signed && bits < 64 && (raw >> (bits - 1)) & 1u) {
                raw |= ~field_mask(bits);
            }
            return static_cast<std::int64_t>(raw);
        }
        case NodeKind::kFloatReg: {
            auto v = read_float_node(n, depth + 1);
            if (!v) {
                return tl::unexpected(v.error());
            }
            return static_cast<std::int64_t>(std::llround(*v));
        }
        case NodeKind::kInteger:
        case NodeKind::kEnumeration:
        case NodeKind::kBoolean:
        case NodeKind::kCommand:
        case NodeKind::kFloat: {
            if (!n.p_value.empty()) {
                const Node& p = nodes_.at(n.p_value);
                if (p.kind == NodeKind::kFloatReg || p.kind == NodeKind::kFloat) {
                    auto v = read_float_node(p, depth + 1);
                    if (!v) {
                        return tl::unexpected(v.error());
                    }
                    return static_cast<std::int64_t>(std::llround(*v));
                }
                return read_int_node(p, depth + 1);
            }
            return static_cast<std::int64_t>(std::llround(n.value));
        }
        default:
            return make_error("node '" + n.name + "' has no integer value");
    }
}

Expected<void> NodeMap::write_int_node(const Node& n, std::int64_t v, int depth) const {
    if (depth > kMaxIndirection) {
        return make_error("node '" + n.name + "': pointer chain deeper than " +
                          std::to_string(kMaxIndirection) + " (a cycle?)");
    }
    switch (n.kind) {
        case NodeKind::kIntReg:
        case NodeKind::kMaskedIntReg: {
            if (n.access == "RO") {
                return make_error("register '" + n.name + "' is read-only (AccessMode RO)");
            }
            if (!port_.write) {
                return make_error("register '" + n.name + "': no device port attached");
            }
            const int bits = static_cast<int>(n.length * 8);
            std::uint64_t raw = static_cast<std::uint64_t>(v) & field_mask(bits);
            if (n.kind == NodeKind::kMaskedIntReg) {
                // Read-modify-write of the bit field.
                Node whole = n;
                whole.kind = NodeKind::kIntReg;
                whole.is_signed = false;
                whole.access = "RW";
                auto cur = read_int_node(whole, depth + 1);
                if (!cur) {
                    return tl::unexpected(cur.error());
                }
                const int lo =
                    n.little_endian ? std::min(n.lsb, n.msb) : bits - 1 - std::max(n.lsb, n.msb);
                const int width = std::abs(n.msb - n.lsb) + 1;
                const std::uint64_t mask = field_mask(width) << lo;
                raw = (static_cast<std::uint64_t>(*cur) & ~mask) |
                      ((static_cast<std::uint64_t>(v) << lo) & mask);
            }
            std::vector<std::uint8_t> bytes(n.length);
            for (std::size_t i = 0; i < n.length; ++i) {
                const std::size_t idx = n.little_endian ? i : n.length - 1 - i;
                bytes[idx] = static_cast<std::uint8_t>((raw >> (8 * i)) & 0xFF);
            }
            auto r = port_.write(n.address, bytes);
            if (!r) {
                return tl::unexpected(with_context("register '" + n.name + "'", r.error()));
            }
            return {};
        }
        case NodeKind::kFloatReg:
            return write_float_node(n, static_cast<double>(v), depth + 1);
        case NodeKind::kInteger:
        case NodeKind::kEnumeration:
        case NodeKind::kBoolean:
        case NodeKind::kCommand:
        case NodeKind::kFloat: {
            if (n.p_value.empty()) {
                return make_error("feature '" + n.name + "' is a constant");
            }
            return write_int_node(nodes_.at(n.p_value), v, depth + 1);
        }
        default:
            return make_error("node '" + n.name + "' takes no integer value");
    }
}

Expected<double> NodeMap::read_float_node(const Node& n, int depth) const {
    if (depth > kMaxIndirection) {
        return make_error("node '" + n.name + "': pointer chain deeper than " +
                          std::to_string(kMaxIndirection) + " (a cycle?)");
    }
    if (n.kind == NodeKind::kFloatReg) {
        if (n.access == "WO") {
            return make_error("register '" + n.name + "' is write-only (AccessMode WO)");
        }
        if (!port_.read) {
            return make_error("register '" + n.name + "': no device port attached");
        }
        auto bytes = port_.read(n.address, n.length);
        if (!bytes) {
            return tl::unexpected(with_context("register '" + n.name + "'", bytes.error()));
        }
        if (bytes->size() != n.length) {
            return make_error("register '" + n.name + "': read " + std::to_string(bytes->size()) +
                              " bytes, expected " + std::to_string(n.length));
        }
        std::uint8_t le[8];
        for (std::size_t i = 0; i < n.length; ++i) {
            le[i] = n.little_endian ? (*bytes)[i] : (*bytes)[n.length - 1 - i];
        }
        double v = 0;
        if (n.length == 4) {
            float f;
            std::memcpy(&f, le, 4);
            v = f;
        } else {
            std::memcpy(&v, le, 8);
        }
        if (!std::isfinite(v)) {
            return make_error("register '" + n.name + "' holds a non-finite value");
        }
        return v;
    }
    if (n.kind == NodeKind::kFloat) {
        if (!n.p_value.empty()) {
            return read_float_node(nodes_.at(n.p_value), depth + 1);
        }
        return n.value;
    }
    auto i = read_int_node(n, depth);
    if (!i) {
        return tl::unexpected(i.error());
    }
    return static_cast<double>(*i);
}

Expected<void> NodeMap::write_float_node(const Node& n, double v, int depth) const {
    if (depth > kMaxIndirection) {
        return make_error("node '" + n.name + "': pointer chain deeper than " +
                          std::to_string(kMaxIndirection) + " (a cycle?)");
    }
    if (!std::isfinite(v)) {
        return make_error("feature '" + n.name + "': refusing to write a non-finite value");
    }
    if (n.kind == NodeKind::kFloatReg) {
        if (n.access == "RO") {
            return make_error("register '" + n.name + "' is read-only (AccessMode RO)");
        }
        if (!port_.write) {
            return make_error("register '" + n.name + "': no device port attached");
        }
        std::uint8_t le[8];
        if (n.length == 4) {
            const float f = static_cast<float>(v);
            std::memcpy(le, &f, 4);
        } else {
            std::memcpy(le, &v, 8);
        }
        std::vector<std::uint8_t> bytes(n.length);
        for (std::size_t i = 0; i < n.length; ++i) {
            bytes[n.little_endian ? i : n.length - 1 - i] = le[i];
        }
        auto r = port_.write(n.address, bytes);
        if (!r) {
            return tl::unexpected(with_context("register '" + n.name + "'", r.error()));
        }
        return {};
    }
    if (n.kind == NodeKind::kFloat) {
        if (n.p_value.empty()) {
            return make_error("feature '" + n.name + "' is a constant");
        }
        return write_float_node(nodes_.at(n.p_value), v, depth + 1);
    }
    return write_int_node(n, static_cast<std::int64_t>(std::llround(v)), depth);
}

Expected<double> NodeMap::limit(const Node& n, bool want_max, int depth) const {
    const std::string& p = want_max ? n.p_max : n.p_min;
    if (!p.empty()) {
        return read_float_node(nodes_.at(p), depth + 1);
    }
    if (want_max ? n.has_max : n.has_min) {
        return want_max ? n.max : n.min;
    }
    return want_max ? HUGE_VAL : -HUGE_VAL;
}

Expected<std::pair<double, double>> NodeMap::range(const std::string& name) const {
    auto n = find(name, "range");
    if (!n) {
        return tl::unexpected(n.error());
    }
    auto lo = limit(**n, false, 0);
    if (!lo) {
        return tl::unexpected(lo.error());
    }
    auto hi = limit(**n, true, 0);
    if (!hi) {
        return tl::unexpected(hi.error());
    }
    return std::make_pair(*lo, *hi);
}

Expected<std::int64_t> NodeMap::get_int(const std::string& name) const {
    auto n = find(name, "Integer");
    if (!n) {
        return tl::unexpected(n.error());
    }
    return read_int_node(**n, 0);
}

Expected<void> NodeMap::set_int(const std::string& name, std::int64_t v) const {
    auto n = find(name, "Integer");
    if (!n) {
        return tl::unexpected(n.error());
    }
    auto r = range(name);
    if (!r) {
        return tl::unexpected(r.error());
    }
    const double dv = static_cast<double>(v);
    if (dv < r->first || dv > r->second) {
        return make_error("feature '" + name + "' = " + std::to_string(v) + " outside [" +
                          std::to_string(static_cast<long long>(r->first)) + ", " +
                          std::to_string(static_cast<long long>(r->second)) + "]");
    }
    const std::int64_t base = std::isfinite(r->first) ? static_cast<std::int64_t>(r->first) : 0;
    if ((*n)->inc > 1 && (v - base) % (*n)->inc != 0) {
        return make_error("feature '" + name + "' = " + std::to_string(v) +
                          " is not a multiple of its increment " + std::to_string((*n)->inc));
    }
    return write_int_node(**n, v, 0);
}

Expected<double> NodeMap::get_float(const std::string& name) const {
    auto n = find(name, "Float");
    if (!n) {
        return tl::unexpected(n.error());
    }
    return read_float_node(**n, 0);
}

Expected<void> NodeMap::set_float(const std::string& name, double v) const {
    auto n = find(name, "Float");
    if (!n) {
        return tl::unexpected(n.error());
    }
    auto r = range(name);
    if (!r) {
        return tl::unexpected(r.error());
    }
    if (!(v >= r->first && v <= r->second)) {
        return make_error("feature '" + name + "' = " + std::to_string(v) + " outside [" +
                          std::to_string(r->first) + ", " + std::to_string(r->second) + "]");
    }
    return write_float_node(**n, v, 0);
}

Expected<std::string> NodeMap::get_enum(const std::string& name) const {
    auto n = find(name, "Enumeration");
    if (!n) {
        return tl::unexpected(n.error());
    }
    if ((*n)->kind != NodeKind::kEnumeration) {
        return make_error("feature '" + name + "' is not an Enumeration");
    }
    auto v = read_int_node(**n, 0);
    if (!v) {
        return tl::unexpected(v.error());
    }
    for (const auto& e : (*n)->entries) {
        if (e.second == *v) {
            return e.first;
        }
    }
    return make_error("enumeration '" + name + "': device value " + std::to_string(*v) +
                      " matches no entry");
}

Expected<void> NodeMap::set_enum(const std::string& name, const std::string& entry) const {
    auto n = find(name, "Enumeration");
    if (!n) {
        return tl::unexpected(n.error());
    }
    if ((*n)->kind != NodeKind::kEnumeration) {
        return make_error("feature '" + name + "' is not an Enumeration");
    }
    for (const auto& e : (*n)->entries) {
        if (e.first == entry) {
            return write_int_node(**n, e.second, 0);
        }
    }
    std::string known;
    for (const auto& e : (*n)->entries) {
        known += (known.empty() ? "" : ", ") + e.first;
    }
    return make_error("enumeration '" + name + "' has no entry '" + entry + "' (has " + known +
                      ")");
}

Expected<bool> NodeMap::get_bool(const std::string& name) const {
    auto n = find(name, "Boolean");
    if (!n) {
        return tl::unexpected(n.error());
    }
    auto v = read_int_node(**n, 0);
    if (!v) {
        return tl::unexpected(v.error());
    }
    return *v == (*n)->on_value;
}

Expected<void> NodeMap::set_bool(const std::string& name, bool v) const {
    auto n = find(name, "Boolean");
    if (!n) {
        return tl::unexpected(n.error());
    }
    return write_int_node(**n, v ? (*n)->on_value : (*n)->off_value, 0);
}

Expected<std::string> NodeMap::get_string(const std::string& name) const {
    auto n = find(name, "String");
    if (!n) {
        return tl::unexpected(n.error());
    }
    const Node* reg = *n;
    if (reg->kind == NodeKind::kString && !reg->p_value.empty()) {
        reg = &nodes_.at(reg->p_value);
    }
    if (reg->kind != NodeKind::kStringReg) {
        return make_error("feature '" + name + "' is not a string register");
    }
    if (!port_.read) {
        return make_error("register '" + reg->name + "': no device port attached");
    }
    auto bytes = port_.read(reg->address, reg->length);
    if (!bytes) {
        return tl::unexpected(with_context("register '" + reg->name + "'", bytes.error()));
    }
    std::size_t len = 0;
    while (len < bytes->size() && (*bytes)[len] != 0) {
        ++len;
    }
    return std::string(bytes->begin(), bytes->begin() + static_cast<std::ptrdiff_t>(len));
}

Expected<void> NodeMap::execute(const std::string& name) const {
    auto n = find(name, "Command");
    if (!n) {
        return tl::unexpected(n.error());
    }
    if ((*n)->kind != NodeKind::kCommand) {
        return make_error("feature '" + name + "' is not a Command");
    }
    return write_int_node(**n, (*n)->command_value, 0);
}

Expected<double> NodeMap::get_number(const std::string& name) const {
    auto n = find(name, "number");
    if (!n) {
        return tl::unexpected(n.error());
    }
    return read_float_node(**n, 0);
}

}  // namespace gonio::devices::genicam
