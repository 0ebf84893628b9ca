// A small XML reader for GenICam device descriptions: elements, attributes, text, CDATA, the five
// predefined entities and numeric character references; comments, processing instructions and
// DOCTYPE skipped. Recursion is bounded so that hostile input cannot exhaust the stack.

#include <cctype>
#include <cstdlib>

#include "gonio/devices/genicam.h"

namespace gonio::devices::genicam {

const std::string* XmlElement::attribute(const std::string& key) const {
    for (const auto& kv : attributes) {
        if (kv.first == key) {
            return &kv.second;
        }
    }
    return nullptr;
}

namespace {

constexpr int kMaxDepth = 64;

class Parser {
  public:
    explicit Parser(const std::string& s) : s_(s) {}

    Expected<XmlElement> document() {
        skip_misc();
        if (!at("<")) {
            return fail("expected the root element");
        }
        XmlElement root;
        if (auto r = element(root, 0); !r) {
            return tl::unexpected(r.error());
        }
        skip_misc();
        if (pos_ != s_.size()) {
            return fail("content after the root element");
        }
        return root;
    }

  private:
    tl::unexpected<Error> fail(const std::string& rule) const {
        int line = 1;
        for (std::size_t i = 0; i < pos_ && i < s_.size(); ++i) {
            line += s_[i] == '\n';
        }
        return make_error("XML line " + std::to_string(line) + ": " + rule);
    }

    bool at(const char* lit) const {
        return s_.compare(pos_, std::char_traits<char>::length(lit), lit) == 0;
    }

    void skip_ws() {
        while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) {
            ++pos_;
        }
    }

    bool skip_until(const char* end) {
        const std::size_t e = s_.find(end, pos_);
        if (e == std::string::npos) {
            pos_ = s_.size();
            return false;
        }
        pos_ = e + std::char_traits<char>::length(end);
        return true;
    }

    // Prolog, comments, processing instructions, DOCTYPE and whitespace.
    void skip_misc() {
        for (;;) {
            skip_ws();
            if (at("<?")) {
                skip_until("?>");
            } else if (at("<!--")) {
                skip_until("-->");
            } else if (at("<!DOCTYPE")) {
                skip_until(">");
            } else {
                return;
            }
        }
    }

    static bool name_char(char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' ||
               c == '.';
    }

    Expected<std::string> name() {
        const std::size_t start = pos_;
        while (pos_ < s_.size() && name_char(s_[pos_])) {
            ++pos_;
        }
        if (pos_ == start) {
            return fail("expected a name");
        }
        return s_.substr(start, pos_ - start);
    }

    Expected<void> decode(const std::string& raw, std::string& out) {
        for (std::size_t i = 0; i < raw.size(); ++i) {
            if (raw[i] != '&') {
                out += raw[i];
                continue;
            }
            const std::size_t semi = raw.find(';', i);
            if (semi == std::string::npos || semi - i > 10) {
                return fail("unterminated entity reference");
            }
            const std::string ent = raw.substr(i + 1, semi - i - 1);
            if (ent == "lt") {
                out += '<';
            } else if (ent == "gt") {
                out += '>';
            } else if (ent == "amp") {
                out += '&';
            } else if (ent == "quot") {
                out += '"';
            } else if (ent == "apos") {
                out += '\'';
            } else if (ent.size() > 1 && ent[0] == '#') {
                const bool hexa = ent[1] == 'x' || ent[1] == 'X';
                char* end = nullptr;
                const char* digits = ent.c_str() + (hexa ? 2 : 1);
                const long code = std::strtol(digits, &end, hexa ? 16 : 10);
                if (end == digits || *end != '\0' || code <= 0 || code > 0x10FFFF) {
                    return fail("bad character reference &" + ent + ";");
                }
                // Only ASCII is meaningful in the features we read; others become '?'.
                out += code < 128 ? static_cast<char>(code) : '?';
            } else {
                return fail("unknown entity &" + ent + ";");
            }
            i = semi;
        }
        return {};
    }

    Expected<void> element(XmlElement& el, int depth) {
        if (depth > kMaxDepth) {
            return fail("elements nested deeper than " + std::to_string(kMaxDepth));
        }
        ++pos_;  // '<'
        auto n = name();
        if (!n) {
            return tl::unexpected(n.error());
        }
        el.name = *n;
        for (;;) {
            skip_ws();
            if (pos_ >= s_.size()) {
                return fail("unterminated start tag <" + el.name + ">");
            }
            if (at("/>")) {
                pos_ += 2;
                return {};
            }
            if (s_[pos_] == '>') {
                ++pos_;
                break;
            }
            auto key = name();
            if (!key) {
                return tl::unexpected(key.error());
            }
            skip_ws();
            if (pos_ >= s_.size() || s_[pos_] != '=') {
                return fail("attribute " + *key + " of <" + el.name + "> has no '='");
            }
            ++pos_;
            skip_ws();
            if (pos_ >= s_.size() || (s_[pos_] != '"' && s_[pos_] != '\'')) {
                return fail("attribute " + *key + " of <" + el.name + "> is not quoted");
            }
            const char q = s_[pos_++];
            const std::size_t end = s_.find(q, pos_);
            if (end == std::string::npos) {
                return fail("unterminated attribute " + *key);
            }
            std::string value;
            if (auto r = decode(s_.substr(pos_, end - pos_), value); !r) {
                return tl::unexpected(r.error());
            }
            el.attributes.emplace_back(*key, std::move(value));
            pos_ = end + 1;
        }
        // Content.
        for (;;) {
            if (pos_ >= s_.size()) {
                return fail("element <" + el.name + "> is not closed");
            }
            if (at("</")) {
                pos_ += 2;
                auto closing = name();
                if (!closing) {
                    return tl::unexpected(closing.error());
                }
                if (*closing != el.name) {
                    return fail("closing tag </" + *closing + "> does not match <" + el.name + ">");
                }
                skip_ws();
                if (pos_ >= s_.size() || s_[pos_] != '>') {
                    return fail("closing tag </" + el.name + "> has no '>'");
                }
                ++pos_;
                return {};
            }
            if (at("<!--")) {
                if (!skip_until("-->")) {
                    return fail("unterminated comment");
                }
            } else if (at("<![CDATA[")) {
                pos_ += 9;
                const std::size_t end = s_.find("]]>", pos_);
                if (end == std::string::npos) {
                    return fail("unterminated CDATA section");
                }
                el.text += s_.substr(pos_, end - pos_);
                pos_ = end + 3;
            } else if (at("<?")) {
                if (!skip_until("?>")) {
                    return fail("unterminated processing instruction");
                }
            } else if (s_[pos_] == '<') {
                el.children.emplace_back();
                if (auto r = element(el.children.back(), depth + 1); !r) {
                    return r;
                }
            } else {
                const std::size_t end = s_.find('<', pos_);
                const std::size_t stop = end == std::string::npos ? s_.size() : end;
                if (auto r = decode(s_.substr(pos_, stop - pos_), el.text); !r) {
                    return r;
                }
                pos_ = stop;
            }
        }
    }

    const std::string& s_;
    std::size_t pos_ = 0;
};

}  // namespace

Expected<XmlElement> parse_xml(const std::string& text) {
    return Parser(text).document();
}

}  // namespace gonio::devices::genicam
