#pragma once

// A GenICam (GenApi schema 1.1) node-map subset: the features a gonioreflectometer needs,
// resolved by name through their nodes down to device registers.
//
// Supported nodes: Integer, Float, Enumeration (+EnumEntry), Command, Boolean, String (via
// StringReg), IntReg, MaskedIntReg, FloatReg, StringReg, Category (listed only). A feature's value
// is <Value> or <pValue> naming another node; limits <Min>/<Max> or <pMin>/<pMax>; registers have
// <Address> (decimal or 0x hex), <Length>, <AccessMode> (RO/WO/RW), <Endianess> (LittleEndian
// default), <Sign>, and <LSB>/<MSB> for MaskedIntReg (bit numbers in the register's own order).

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "gonio/brdf/error.h"

namespace gonio::devices::genicam {

/// The register space a node map reads and writes (the device's GenCP memory).
struct RegisterPort {
    std::function<Expected<std::vector<std::uint8_t>>(std::uint64_t address, std::size_t length)>
        read;
    std::function<Expected<void>(std::uint64_t address, const std::vector<std::uint8_t>& data)>
        write;
};

enum class NodeKind {
    kInteger,       ///< IInteger feature
    kFloat,         ///< IFloat feature
    kEnumeration,   ///< IEnumeration feature
    kEnumEntry,     ///< one value of an enumeration
    kCommand,       ///< ICommand feature
    kBoolean,       ///< IBoolean feature
    kString,        ///< IString feature
    kIntReg,        ///< integer register
    kMaskedIntReg,  ///< bit field of a register
    kFloatReg,      ///< IEEE 754 register (4 or 8 bytes)
    kStringReg,     ///< fixed-length string register
    kCategory,      ///< grouping, no value
};

struct Node {
    NodeKind kind = NodeKind::kInteger;
    std::string name;
    std::string display_name;
    // Feature values: a constant or a pointer to another node.
    std::string p_value;
    bool has_value = false;
    double value = 0;
    std::string p_min, p_max;
    bool has_min = false, has_max = false;
    double min = 0, max = 0;
    std::int64_t inc = 1;
    std::string unit;
    // Enumeration entries: name -> value (in order of appearance).
    std::vector<std::pair<std::string, std::int64_t>> entries;
    // Command.
    std::int64_t command_value = 1;
    // Boolean.
    std::int64_t on_value = 1, off_value = 0;
    // Registers.
    std::uint64_t address = 0;
    std::size_t length = 0;
    std::string access = "RW";
    bool little_endian = true;
    bool is_signed = false;
    int lsb = 0, msb = 0;
};

/// A minimal XML DOM: elements with attributes, children and text (comments, processing
/// instructions and the prolog skipped; CDATA and the five predefined entities decoded).
struct XmlElement {
    std::string name;
    std::vector<std::pair<std::string, std::string>> attributes;
    std::vector<XmlElement> children;
    std::string text;
    const std::string* attribute(const std::string& key) const;
};
/// Errors give the line and the rule ("line 12: closing tag </Value> does not match <Address>").
Expected<XmlElement> parse_xml(const std::string& text);

class NodeMap {
  public:
    /// Builds the node map from the XML text; errors name the node and the rule.
    static Expected<NodeMap> parse(const std::string& xml);

    /// Attaches the device memory used by every value access.
    void set_port(RegisterPort port) { port_ = std::move(port); }
    bool has(const std::string& name) const { return nodes_.count(name) > 0; }
    const Node* node(const std::string& name) const;
    std::vector<std::string> names() const;
    const std::string& model_name() const { return model_name_; }
    const std::string& vendor_name() const { return vendor_name_; }

    Expected<std::int64_t> get_int(const std::string& name) const;
    Expected<void> set_int(const std::string& name, std::int64_t v) const;
    Expected<double> get_float(const std::string& name) const;
    Expected<void> set_float(const std::string& name, double v) const;
    /// Current symbolic value of an enumeration.
    Expected<std::string> get_enum(const std::string& name) const;
    Expected<void> set_enum(const std::string& name, const std::string& entry) const;
    Expected<bool> get_bool(const std::string& name) const;
    Expected<void> set_bool(const std::string& name, bool v) const;
    Expected<std::string> get_string(const std::string& name) const;
    Expected<void> execute(const std::string& name) const;
    /// Numeric value of any Integer/Float/Enumeration/Boolean feature.
    Expected<double> get_number(const std::string& name) const;
    /// Minimum and maximum of an Integer or Float feature.
    Expected<std::pair<double, double>> range(const std::string& name) const;

  private:
    Expected<const Node*> find(const std::string& name, const char* what) const;
    Expected<std::int64_t> read_int_node(const Node& n, int depth) const;
    Expected<void> write_int_node(const Node& n, std::int64_t v, int depth) const;
    Expected<double> read_float_node(const Node& n, int depth) const;
    Expected<void> write_float_node(const Node& n, double v, int depth) const;
    Expected<double> limit(const Node& n, bool want_max, int depth) const;

    std::map<std::string, Node> nodes_;
    std::string model_name_;
    std::string vendor_name_;
    RegisterPort port_;
};

/// Extracts the single file of a zip archive (stored or deflated, as GenCP manifests allow), with
/// its CRC-32 checked. Errors name the archive structure that is wrong.
Expected<std::string> unzip_single_file(const std::vector<std::uint8_t>& zip);
/// Builds a zip archive holding one deflated file (used by the simulator and tests).
Expected<std::vector<std::uint8_t>> zip_single_file(const std::string& file_name,
                                                    const std::string& contents);

}  // namespace gonio::devices::genicam
