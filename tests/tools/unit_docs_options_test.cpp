// The documentation against the program: every option docs/*.md names on a `gonio SUBCOMMAND` line
// exists in that subcommand's --help, and every default the docs state next to an option ("--width
// N (default 800)") is the default --help prints.

#include <gtest/gtest.h>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;

struct Help {
    std::set<std::string> options;
    std::map<std::string, std::string> defaults;  ///< option -> default as --help prints it
};

/// The subcommands a `--help` text lists.
std::vector<std::string> subcommands_in(const std::string& help) {
    std::vector<std::string> out;
    std::istringstream in(help);
    std::string line;
    bool in_list = false;
    while (std::getline(in, line)) {
        if (line.rfind("Subcommands:", 0) == 0) {
            in_list = true;
            continue;
        }
        std::smatch m;
        if (in_list && std::regex_search(line, m, std::regex("^  ([a-z]+)\\b"))) {
            out.push_back(m[1]);
        } else if (in_list && !line.empty() && line[0] != ' ') {
            in_list = false;
        }
    }
    return out;
}

/// The subcommands `gonio --help` lists.
std::vector<std::string> subcommands() {
    return subcommands_in(run_gonio("--help").out);
}

/// Options and defaults of `gonio SUB --help` (CLI11 2.1: "  --name TYPE:CHECK=DEFAULT  text"),
/// merged with those of its own subcommands (`gonio camera serve`).
Help help_of(const std::string& sub) {
    Help h;
    const CliRun r = run_gonio(sub + " --help");
    std::istringstream in(r.out);
    std::string line;
    const std::regex opt("^\\s+(?:-[a-zA-Z],)?(--[a-z0-9][a-z0-9-]*)");
    const std::regex def("=([^\\s=]+)\\s*$");
    while (std::getline(in, line)) {
        std::smatch m;
        if (!std::regex_search(line, m, opt)) {
            continue;
        }
        const std::string name = m[1];
        h.options.insert(name);
        // The default closes the option's spec, before the description (two or more spaces).
        const std::string rest = line.substr(static_cast<std::size_t>(m.position(0) + m.length(0)));
        const auto two_spaces = rest.find("  ");
        const std::string spec =
            two_spaces == std::string::npos ? rest : rest.substr(0, two_spaces);
        std::smatch d;
        if (std::regex_search(spec, d, def)) {
            h.defaults[name] = d[1];
        }
    }
    if (sub.find(' ') == std::string::npos) {
        for (const std::string& s : subcommands_in(r.out)) {
            const Help inner = help_of(sub + " " + s);
            h.options.insert(inner.options.begin(), inner.options.end());
            h.defaults.insert(inner.defaults.begin(), inner.defaults.end());
        }
    }
    return h;
}

struct DocMention {
    std::string file;
    int line = 0;
    std::string sub;
    std::string option;
    std::string stated_default;  ///< empty when the docs state none
};

/// Options named on `gonio SUB ...` command lines of the docs: inside fenced code blocks (a line
/// starting a command and its indented continuation lines) and in inline code spans.
std::vector<DocMention> doc_mentions(const std::set<std::string>& subs) {
    std::vector<DocMention> out;
    const fs::path docs = fs::path(GONIO_SOURCE_DIR) / "docs";
    const std::regex cmd("gonio ([a-z]+)\\b");
    const std::regex opt("(--[a-z0-9][a-z0-9-]*)");
    const std::regex the_default("`(--[a-z0-9][a-z0-9-]*) ([^`\\s]+)` \\(the default\\)");
    const std::regex default_after(
        "`(--[a-z0-9][a-z0-9-]*)(?: [^`]*)?`[^.;`]{0,30}?\\bdefault:? "
        "`?([0-9A-Za-z_-]+(?:\\.[0-9A-Za-z_-]+)*)`?");
    for (const auto& e : fs::directory_iterator(docs)) {
        if (e.path().extension() != ".md") {
            continue;
        }
        std::ifstream in(e.path());
        std::string line;
        int n = 0;
        bool fenced = false;
        std::string block_sub;  // the command a fenced line continues
        while (std::getline(in, line)) {
            ++n;
            if (line.rfind("```", 0) == 0) {
                fenced = !fenced;
                block_sub.clear();
                continue;
            }
            std::vector<std::pair<std::string, std::string>> spans;  // (sub, text)
            if (fenced) {
                std::smatch m;
                if (std::regex_search(line, m, cmd) && subs.count(m[1]) != 0) {
                    block_sub = m[1];
                    spans.push_back({block_sub, m.suffix().str()});
                } else if (!block_sub.empty() && !line.empty() && std::isspace(line[0]) != 0) {
                    spans.push_back({block_sub, line});
                } else {
                    block_sub.clear();
                }
            } else {
                // Inline code spans `gonio SUB ...`.
                const std::regex span("`gonio ([a-z]+)([^`]*)`");
                for (auto it = std::sregex_iterator(line.begin(), line.end(), span);
                     it != std::sregex_iterator();
                     ++it) {
                    if (subs.count((*it)[1]) != 0) {
                        spans.push_back({(*it)[1], (*it)[2]});
                    }
                }
            }
            for (const auto& [sub, text] : spans) {
                std::string t = text;
                // A comment after '#' in a code block is prose, not options.
                if (fenced && t.find(" #") != std::string::npos) {
                    t = t.substr(0, t.find(" #"));
                }
                for (auto it = std::sregex_iterator(t.begin(), t.end(), opt);
                     it != std::sregex_iterator();
                     ++it) {
                    out.push_back({e.path().filename().string(), n, sub, (*it)[1], ""});
                }
            }
            // Defaults stated in prose: "`--opt V` (the default)" or "`--opt ...` ... default V".
            if (!fenced) {
                std::smatch cm;
                const std::string sub = std::regex_search(line, cm, cmd) && subs.count(cm[1]) != 0
                                            ? std::string(cm[1])
                                            : std::string();
                for (const std::regex& re : {the_default, default_after}) {
                    for (auto it = std::sregex_iterator(line.begin(), line.end(), re);
                         it != std::sregex_iterator();
                         ++it) {
                        out.push_back({e.path().filename().string(), n, sub, (*it)[1], (*it)[2]});
                    }
                }
            }
        }
    }
    return out;
}

TEST(Docs, EveryDocumentedOptionExistsAndEveryStatedDefaultMatchesHelp) {
    const std::vector<std::string> list = subcommands();
    ASSERT_GE(list.size(), 10u) << "gonio --help lists too few subcommands";
    const std::set<std::string> subs(list.begin(), list.end());
    std::map<std::string, Help> helps;
    for (const std::string& s : list) {
        helps[s] = help_of(s);
        EXPECT_FALSE(helps[s].options.empty()) << "gonio " << s << " --help lists no option";
    }
    const std::vector<DocMention> mentions = doc_mentions(subs);
    // The docs name options of most subcommands: the scan itself must find them.
    EXPECT_GE(mentions.size(), 30u);
    std::size_t defaults_compared = 0;
    for (DocMention m : mentions) {
        if (m.option == "--help") {
            continue;
        }
        if (m.sub.empty()) {
            // A default stated without its command: the one subcommand that has the option.
            std::vector<std::string> owners;
            for (const auto& [name, help] : helps) {
                if (help.options.count(m.option) != 0) {
                    owners.push_back(name);
                }
            }
            if (owners.size() != 1) {
                continue;
            }
            m.sub = owners.front();
        }
        const Help& h = helps[m.sub];
        EXPECT_EQ(h.options.count(m.option), 1u)
            << m.file << ":" << m.line << ": `gonio " << m.sub << " " << m.option
            << "` is documented, but `gonio " << m.sub << " --help` has no such option";
        if (!m.stated_default.empty() && h.defaults.count(m.option) != 0) {
            ++defaults_compared;
            EXPECT_EQ(m.stated_default, h.defaults.at(m.option))
                << m.file << ":" << m.line << ": the docs state the default of `gonio " << m.sub
                << " " << m.option << "` as " << m.stated_default << ", --help as "
                << h.defaults.at(m.option);
        }
    }
    std::printf("%zu documented options checked, %zu stated defaults compared\n",
                mentions.size(),
                defaults_compared);
}

TEST(Docs, TheScanFindsAPlantedDisagreement) {
    // The scanner itself: an option that does not exist and a wrong default are both caught.
    const Help h = help_of("plot");
    ASSERT_EQ(h.options.count("--width"), 1u);
    ASSERT_EQ(h.defaults.count("--width"), 1u);
    EXPECT_EQ(h.defaults.at("--width"), "800");
    EXPECT_EQ(h.options.count("--no-such-option"), 0u);
    EXPECT_EQ(h.defaults.at("--scale"), "auto");
}

}  // namespace
}  // namespace gonio::testing
