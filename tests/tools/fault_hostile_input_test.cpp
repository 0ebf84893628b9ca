// Hostile inputs and honest outputs, through the gonio binary: every command of the hostile-input
// review is run as a child process and checked for its exit status (0 success, 1 failure of the
// work, 2 usage error), a message that names the problem, no file written (or the previous one
// kept), and - where a memory limit applies - the child's peak resident memory (getrusage through
// wait4) below that limit.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/table.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;

struct Child {
    int status = -1;        ///< exit status; -1 when killed by a signal
    int signal = 0;         ///< the signal that ended it, if any
    long peak_rss_kib = 0;  ///< ru_maxrss of the child
    std::string out;        ///< standard output and standard error
};

/// Runs gonio with the arguments (no shell), output to a file of the test folder; waits with
/// wait4 to get the child's own resource usage.
Child run_child(const fs::path& dir, const std::vector<std::string>& args) {
    const std::string out_path = (dir / "child_output.txt").string();
    std::vector<std::string> argv_s = {GONIO_EXE};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& a : argv_s) {
        argv.push_back(a.data());
    }
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    pid_t pid = -1;
    Child c;
    if (posix_spawn(&pid, GONIO_EXE, &fa, nullptr, argv.data(), environ) != 0) {
        posix_spawn_file_actions_destroy(&fa);
        return c;
    }
    posix_spawn_file_actions_destroy(&fa);
    int st = 0;
    struct rusage ru {};
    if (wait4(pid, &st, 0, &ru) == pid) {
        c.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
        c.signal = WIFSIGNALED(st) ? WTERMSIG(st) : 0;
        c.peak_rss_kib = ru.ru_maxrss;
    }
    std::ifstream in(out_path);
    std::stringstream ss;
    ss << in.rdbuf();
    c.out = ss.str();
    fs::remove(out_path);
    return c;
}

void put(const fs::path& p, const std::string& text) {
    std::ofstream(p, std::ios::binary) << text;
}

/// Files whose name says they are temporary (".NAME.xxxx.tmp" or "NAME.tmp") anywhere under dir.
std::vector<std::string> debris(const fs::path& dir) {
    std::vector<std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        const std::string n = e.path().filename().string();
        if (n.size() > 4 && n.compare(n.size() - 4, 4, ".tmp") == 0) {
            out.push_back(e.path().string());
        }
    }
    return out;
}

const char* kHostileModel = R"({"diffuse": [0.2, 0.15, 0.1], "lobes": [{"distribution": "ggx",
    "alpha": 0.3, "shadowing": "smith-correlated", "fresnel": {"type": "schlick", "f0": 0.04}}]})";

constexpr long kMiB = 1024;  // ru_maxrss is in KiB

class Hostile : public ::testing::Test {
  protected:
    void SetUp() override { dir_ = gonio::testing::fresh_test_dir("hostile"); }
    fs::path p(const std::string& name) const { return dir_ / name; }
    Child gonio(const std::vector<std::string>& args) const { return run_child(dir_, args); }
    fs::path dir_;
};

// --- exit codes and usage errors ---------------------------------------------------------------

TEST_F(Hostile, MistypedCommandIsAUsageErrorThatSaysSo) {
    const Child c = gonio({"convrt", "a.json", "b.csv"});
    EXPECT_EQ(c.status, 2) << c.out;
    EXPECT_NE(c.out.find("unknown command \"convrt\""), std::string::npos) << c.out;
    EXPECT_NE(c.out.find("did you mean \"convert\""), std::string::npos) << c.out;
    EXPECT_EQ(c.out.find("A subcommand is required"), std::string::npos) << c.out;
}

TEST_F(Hostile, ParseErrorsExitWithTwoAndHelpDocumentsTheCodes) {
    const Child missing = gonio({"convert"});
    EXPECT_EQ(missing.status, 2) << missing.out;
    const Child unknown_opt = gonio({"check", "--no-such-option", "x.json"});
    EXPECT_EQ(unknown_opt.status, 2) << unknown_opt.out;
    const Child none = gonio({});
    EXPECT_EQ(none.status, 2) << none.out;
    const Child help = gonio({"--help"});
    EXPECT_EQ(help.status, 0);
    EXPECT_NE(help.out.find("Exit status: 0 success, 1"), std::string::npos) << help.out;
    EXPECT_NE(help.out.find("2 usage error"), std::string::npos) << help.out;
}

TEST_F(Hostile, AcquireOptionsOutOfRangeAreUsageErrors) {
    const std::vector<std::vector<std::string>> cases = {
        {"acquire", "--plan-only", "--plan", "bogus"},
        {"acquire", "--plan-only", "--adaptive", "-3"},
        {"acquire", "--plan-only", "--time-scale", "nan"},
        {"acquire", "--plan-only", "--n-theta", "1e20"},
        {"acquire", "--mode", "image", "--max-frames", "-1"},
        {"acquire", "--mode", "image", "--coverage-target", "inf"}};
    const std::vector<std::string> named = {"bogus", "-3", "nan", "1e20", "-1", "inf"};
    for (std::size_t k = 0; k < cases.size(); ++k) {
        const Child c = gonio(cases[k]);
        EXPECT_EQ(c.status, 2) << cases[k][cases[k].size() - 2] << ": " << c.out;
        EXPECT_NE(c.out.find(named[k]), std::string::npos) << c.out;
    }
}

TEST_F(Hostile, PlotThetaNanIsRefusedBeforeAnyPicture) {
    put(p("model.json"), kHostileModel);
    ASSERT_EQ(gonio({"convert", p("model.json").string(), p("d.csv").string(), "--grid", "8x8x16"})
                  .status,
              0);
    const Child c =
        gonio({"plot", p("d.csv").string(), "--theta-i", "nan", "--out", p("plots").string()});
    EXPECT_EQ(c.status, 2) << c.out;
    EXPECT_NE(c.out.find("--theta-i"), std::string::npos) << c.out;
    EXPECT_NE(c.out.find("nan"), std::string::npos) << c.out;
    EXPECT_FALSE(fs::exists(p("plots")));
}

TEST_F(Hostile, MaxMemoryOptionIsValidated) {
    put(p("x.json"), "{}");  // a readable input: the refusal is the memory size
    const Child c = gonio({"--max-memory", "12X", "check", p("x.json").string()});
    EXPECT_EQ(c.status, 2) << c.out;
    EXPECT_NE(c.out.find("12X"), std::string::npos) << c.out;
}

// --- crashes of the review: now errors that name the problem ------------------------------------

TEST_F(Hostile, ReportOfA100000DeepCampaignJsonFailsWithoutCrashing) {
    fs::create_directories(p("D"));
    std::string deep;
    for (int i = 0; i < 100000; ++i) {
        deep += "{\"a\":";
    }
    deep += "1" + std::string(100000, '}');
    put(p("D/campaign.json"), deep);
    const Child c = gonio({"report", p("D").string()});
    EXPECT_EQ(c.signal, 0) << "killed by signal " << c.signal;
    EXPECT_EQ(c.status, 1) << c.out;
    EXPECT_NE(c.out.find("campaign.json:1: objects and arrays nested deeper than 64"),
              std::string::npos)
        << c.out;
    EXPECT_FALSE(fs::exists(p("D/report.html")));
    EXPECT_TRUE(debris(p("D")).empty());
}

TEST_F(Hostile, ConvertOfAHugeSampleValueFailsAndWritesNothing) {
    put(p("s.csv"),
        "theta_i,phi_i,theta_o,phi_o,r,g,b\n0.5,0,0.5,3.1,1e308,1e308,1e308\n"
        "0.4,0,0.45,3.0,0.2,0.2,0.2\n");
    const Child c =
        gonio({"convert", p("s.csv").string(), p("o.gtab").string(), "--grid", "8x8x16"});
    EXPECT_EQ(c.signal, 0) << c.out;
    EXPECT_EQ(c.status, 1) << c.out;
    EXPECT_NE(c.out.find("1e+308"), std::string::npos) << c.out;
    EXPECT_FALSE(fs::exists(p("o.gtab")));
    EXPECT_TRUE(debris(dir_).empty());
}

TEST_F(Hostile, ModelWithHugeDiffuseIsRefusedByConvertAndExport) {
    put(p("m.json"), R"({"diffuse": 1e308, "lobes": []})");
    const Child conv =
        gonio({"convert", p("m.json").string(), p("o.gtab").string(), "--grid", "8x8x16"});
    EXPECT_EQ(conv.status, 1) << conv.out;
    EXPECT_NE(conv.out.find("diffuse = 1e+308: must be <= 100"), std::string::npos) << conv.out;
    const Child exp =
        gonio({"export", p("m.json").string(), "--to", "merl", "--out", p("o.binary").string()});
    EXPECT_EQ(exp.status, 1) << exp.out;
    EXPECT_NE(exp.out.find("diffuse = 1e+308"), std::string::npos) << exp.out;
    EXPECT_FALSE(fs::exists(p("o.gtab")));
    EXPECT_FALSE(fs::exists(p("o.binary")));
}

TEST_F(Hostile, GiantGridIsRefusedBeforeAllocating) {
    put(p("m.json"), kHostileModel);
    const Child c =
        gonio({"convert", p("m.json").string(), p("o.gtab").string(), "--grid", "4096x4096x4096"});
    EXPECT_EQ(c.signal, 0) << c.out;
    EXPECT_EQ(c.status, 1) << c.out;
    EXPECT_NE(c.out.find("TiB of memory, above the limit of 2 GiB"), std::string::npos) << c.out;
    EXPECT_NE(c.out.find("--max-memory"), std::string::npos) << c.out;
    EXPECT_LT(c.peak_rss_kib, 256 * kMiB);
    EXPECT_FALSE(fs::exists(p("o.gtab")));

    // 300^3 bins to CSV: one sample per bin is several GiB, refused at once.
    const Child csv =
        gonio({"convert", p("m.json").string(), p("o.csv").string(), "--grid", "300x300x300"});
    EXPECT_EQ(csv.status, 1) << csv.out;
    EXPECT_NE(csv.out.find("above the limit"), std::string::npos) << csv.out;
    EXPECT_LT(csv.peak_rss_kib, 256 * kMiB);
    EXPECT_FALSE(fs::exists(p("o.csv")));
    EXPECT_TRUE(debris(dir_).empty());
}

TEST_F(Hostile, MaxMemoryLowersAndRaisesTheBudget) {
    put(p("m.json"), kHostileModel);
    // 90 x 90 x 180 bins x 25 bytes = 35 MiB for the table, as much again for its encoding.
    const Child low = gonio({"--max-memory",
                             "16M",
                             "convert",
                             p("m.json").string(),
                             p("o.gtab").string(),
                             "--grid",
                             "90x90x180"});
    EXPECT_EQ(low.status, 1) << low.out;
    EXPECT_NE(low.out.find("above the limit of 16 MiB"), std::string::npos) << low.out;
    EXPECT_FALSE(fs::exists(p("o.gtab")));
    const Child high = gonio({"convert",
                              p("m.json").string(),
                              p("o.gtab").string(),
                              "--grid",
                              "90x90x180",
                              "--max-memory",
                              "96M"});
    EXPECT_EQ(high.status, 0) << high.out;
    // The refused run allocated nothing: its peak is the program itself. The work stays within
    // the budget on top of it.
    EXPECT_LT(high.peak_rss_kib - low.peak_rss_kib, 96 * kMiB);
    EXPECT_TRUE(fs::exists(p("o.gtab")));
}

TEST_F(Hostile, HugePlanIsRefusedBeforeAllocating) {
    put(p("c.json"),
        R"({"plan":{"kind":"uniform","n_theta":100000,"n_dphi":100000,"theta_max_deg":60}})");
    const Child c = gonio({"acquire", p("c.json").string(), "--plan-only"});
    EXPECT_EQ(c.status, 1) << c.out;
    EXPECT_NE(c.out.find("plan.n_theta = 100000: must be a whole number in [2, 1000]"),
              std::string::npos)
        << c.out;
    EXPECT_LT(c.peak_rss_kib, 256 * kMiB);

    put(p("c2.json"), R"({"plan":{"kind":"uniform","n_theta":1e20,"n_dphi":5}})");
    const Child c2 = gonio({"acquire", p("c2.json").string(), "--plan-only"});
    EXPECT_EQ(c2.status, 1) << c2.out;
    EXPECT_NE(c2.out.find("plan.n_theta = 1e+20"), std::string::npos) << c2.out;
    EXPECT_EQ(c2.out.find("-2147483648"), std::string::npos) << c2.out;

    // Within each axis limit but too many configurations together.
    put(p("c3.json"), R"({"plan":{"kind":"half-diff","n_theta_h":1000,"n_theta_d":1000,
                                  "n_phi_d":1000}})");
    const Child c3 = gonio({"acquire", p("c3.json").string(), "--plan-only"});
    EXPECT_EQ(c3.status, 1) << c3.out;
    EXPECT_NE(c3.out.find("at most 1000 per axis and 1000000 in all"), std::string::npos) << c3.out;
    EXPECT_LT(c3.peak_rss_kib, 256 * kMiB);
}

TEST_F(Hostile, ModelWith100000LobesIsRefusedAtOnce) {
    std::string m = R"({"lobes": [)";
    for (int i = 0; i < 100000; ++i) {
        m += std::string(i ? "," : "") +
             R"({"distribution":"ggx","alpha":0.2,"shadowing":"none","fresnel":{"type":"none"}})";
    }
    m += "]}";
    put(p("m.json"), m);
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"check", p("m.json").string()},
          std::vector<std::string>{"preview", p("m.json").string(), "--out", p("x.png").string()},
          std::vector<std::string>{"export", p("m.json").string(), "--to", "pbrt"}}) {
        const Child c = gonio(args);
        EXPECT_EQ(c.status, 1) << args[0] << ": " << c.out;
        EXPECT_NE(c.out.find("lobes: 100000 lobes, at most 16 allowed"), std::string::npos)
            << c.out;
    }
    EXPECT_FALSE(fs::exists(p("x.png")));
}

// --- silent acceptance --------------------------------------------------------------------------

TEST_F(Hostile, CampaignJsonUnknownKeysAndJunkPlansAreRejectedWithTheirPath) {
    put(p("a.json"), R"({"sample": "x", "plann": {"kind": "uniform"}})");
    const Child a = gonio({"acquire", p("a.json").string(), "--plan-only"});
    EXPECT_EQ(a.status, 1) << a.out;
    EXPECT_NE(a.out.find("a.json: plann: unknown key"), std::string::npos) << a.out;

    put(p("b.json"), R"({"plan": {"junk": [1, 2, 3]}})");
    const Child b = gonio({"acquire", p("b.json").string(), "--plan-only"});
    EXPECT_EQ(b.status, 1) << b.out;
    EXPECT_NE(b.out.find("plan.junk: unknown key"), std::string::npos) << b.out;

    put(p("c.json"), R"({"sample": ["not", "a", "string"]})");
    const Child c = gonio({"acquire", p("c.json").string(), "--plan-only"});
    EXPECT_EQ(c.status, 1) << c.out;
    EXPECT_NE(c.out.find("sample: expected a string, got array"), std::string::npos) << c.out;
    EXPECT_EQ(c.out.find("json.exception"), std::string::npos) << c.out;
}

TEST_F(Hostile, CampaignPathsOutsideItsFolderAreNotFollowed) {
    put(p("a.json"), R"({"rig": "../rig.json"})");
    const Child a = gonio({"acquire", p("a.json").string(), "--plan-only"});
    EXPECT_EQ(a.status, 1) << a.out;
    EXPECT_NE(a.out.find("rig = \"../rig.json\": \"..\" is not followed"), std::string::npos)
        << a.out;
    put(p("b.json"), R"({"scene": "/etc/passwd"})");
    const Child b = gonio({"acquire", p("b.json").string(), "--plan-only"});
    EXPECT_EQ(b.status, 1) << b.out;
    EXPECT_NE(b.out.find("absolute paths are not followed"), std::string::npos) << b.out;
}

TEST_F(Hostile, CheckAndPreviewRefuseATableWithoutValidBins) {
    const gonio::brdf::TabulatedBrdf empty =
        gonio::brdf::TabulatedBrdf::empty({4, 4, 8}, gonio::brdf::kMerlScale, "empty");
    ASSERT_TRUE(gonio::brdf::write_merl(p("empty.gtab").string(), empty));
    const Child c = gonio({"check", p("empty.gtab").string()});
    EXPECT_EQ(c.status, 1) << c.out;
    EXPECT_NE(c.out.find("0 of 128 bins valid"), std::string::npos) << c.out;
    EXPECT_EQ(c.out.find("all checks passed"), std::string::npos) << c.out;
    const Child v = gonio({"preview", p("empty.gtab").string(), "--out", p("v.png").string()});
    EXPECT_EQ(v.status, 1) << v.out;
    EXPECT_NE(v.out.find("0 of 128 bins valid; nothing to render"), std::string::npos) << v.out;
    EXPECT_FALSE(fs::exists(p("v.png")));
}

TEST_F(Hostile, ExportRefusesNamesThatWouldInjectStatements) {
    put(p("m.json"), kHostileModel);
    for (const char* to : {"pbrt", "mitsuba"}) {
        const std::string out = p(std::string("o.") + to).string();
        const Child c = gonio({"export",
                               p("m.json").string(),
                               "--to",
                               to,
                               "--out",
                               out,
                               "--name",
                               "a\"\nShape \"sphere\"\n#"});
        EXPECT_EQ(c.status, 1) << to << ": " << c.out;
        EXPECT_NE(c.out.find("character 2 (0x22) is not allowed"), std::string::npos) << c.out;
        EXPECT_FALSE(fs::exists(out));
    }
    const Child ok = gonio({"export",
                            p("m.json").string(),
                            "--to",
                            "pbrt",
                            "--out",
                            p("ok.pbrt").string(),
                            "--name",
                            "red_plastic-2.b"});
    EXPECT_EQ(ok.status, 0) << ok.out;
    EXPECT_NE(gonio::testing::read_text(p("ok.pbrt")).find("\"red_plastic-2.b\""),
              std::string::npos);
}

// --- outputs that are folders or devices --------------------------------------------------------

TEST_F(Hostile, OutputsThatAreFoldersOrDevicesAreRefusedBeforeWork) {
    put(p("m.json"), kHostileModel);
    ASSERT_EQ(
        gonio({"convert", p("m.json").string(), p("d.csv").string(), "--grid", "8x8x16"}).status,
        0);
    fs::create_directories(p("outdir"));
    const Child fit = gonio({"fit", p("d.csv").string(), "--out", p("outdir").string()});
    EXPECT_EQ(fit.status, 1) << fit.out;
    EXPECT_NE(fit.out.find("outdir: output path is a folder"), std::string::npos) << fit.out;
    EXPECT_FALSE(fs::exists(p("outdir.report.json")));
    EXPECT_EQ(fit.out.find("rmse"), std::string::npos) << "the fit ran: " << fit.out;

    const Child dev = gonio({"convert", p("m.json").string(), "/dev/null"});
    EXPECT_EQ(dev.status, 2) << dev.out;  // not a table or CSV name
    const Child dev2 = gonio({"preview", p("m.json").string(), "--out", "/dev/full"});
    EXPECT_EQ(dev2.status, 1) << dev2.out;
    EXPECT_NE(dev2.out.find("/dev/full: output path is a device"), std::string::npos) << dev2.out;
    struct stat st {};
    ASSERT_EQ(stat("/dev/full", &st), 0);
    EXPECT_TRUE(S_ISCHR(st.st_mode));

    const Child exp =
        gonio({"export", p("m.json").string(), "--to", "mitsuba", "--out", p("outdir").string()});
    EXPECT_EQ(exp.status, 1) << exp.out;
    EXPECT_TRUE(fs::is_directory(p("outdir")));
    const Child missing = gonio(
        {"convert", p("m.json").string(), p("no/such/folder/o.csv").string(), "--grid", "8x8x16"});
    EXPECT_EQ(missing.status, 1) << missing.out;
    EXPECT_NE(missing.out.find("does not exist"), std::string::npos) << missing.out;
}

TEST_F(Hostile, FailedCampaignStartLeavesNoFolder) {
    const Child c = gonio({"acquire",
                           "--material",
                           "nope",
                           "--out",
                           p("camp").string(),
                           "--n-theta",
                           "3",
                           "--n-dphi",
                           "2",
                           "--adaptive",
                           "0"});
    EXPECT_EQ(c.status, 1) << c.out;
    EXPECT_NE(c.out.find("nope"), std::string::npos) << c.out;
    EXPECT_FALSE(fs::exists(p("camp"))) << c.out;
}

/// Starts `gonio ARGS`, reads its standard output until a line starting with "plan:" (printed
/// once metadata.json lists the run), then kills it with SIGKILL. True when the line was seen.
bool start_and_kill_after_plan(const std::vector<std::string>& args, std::string* seen) {
    int fds[2];
    if (pipe(fds) != 0) {
        return false;
    }
    const pid_t pid = fork();
    if (pid < 0) {
        return false;
    }
    if (pid == 0) {
        dup2(fds[1], 1);
        close(fds[0]);
        std::vector<char*> argv = {const_cast<char*>(GONIO_EXE)};
        for (const std::string& a : args) {
            argv.push_back(const_cast<char*>(a.c_str()));
        }
        argv.push_back(nullptr);
        execv(GONIO_EXE, argv.data());
        _exit(127);
    }
    close(fds[1]);
    FILE* in = fdopen(fds[0], "r");
    char line[4096];
    bool found = false;
    while (std::fgets(line, sizeof line, in) != nullptr) {
        *seen += line;
        if (std::string(line).rfind("plan:", 0) == 0) {
            found = true;
            break;
        }
    }
    kill(pid, SIGKILL);
    int st = 0;
    waitpid(pid, &st, 0);
    std::fclose(in);
    return found;
}

// metadata.json lists a run from its start; a run killed with SIGKILL is marked "killed" by the
// next one, with how it ended.
TEST_F(Hostile, KilledRunsAreListedInMetadata) {
    const std::string camp = p("camp").string();
    std::string out;
    ASSERT_TRUE(start_and_kill_after_plan({"acquire",
                                           "--out",
                                           camp,
                                           "--n-theta",
                                           "3",
                                           "--n-dphi",
                                           "2",
                                           "--adaptive",
                                           "0",
                                           "--time-scale",
                                           "1"},
                                          &out))
        << out;
    const std::string first = gonio::testing::read_text(p("camp/metadata.json"));
    EXPECT_NE(first.find("\"state\": \"running\""), std::string::npos) << first;
    // The second run starts (and is killed too): it marks the first one.
    out.clear();
    ASSERT_TRUE(start_and_kill_after_plan({"acquire", "--resume", camp}, &out)) << out;
    const std::string second = gonio::testing::read_text(p("camp/metadata.json"));
    const auto killed = second.find("\"state\": \"killed\"");
    const auto running = second.find("\"state\": \"running\"");
    EXPECT_NE(killed, std::string::npos) << second;
    EXPECT_NE(running, std::string::npos) << second;
    EXPECT_LT(killed, running) << "runs in order: the killed first, the running second\n" << second;
    EXPECT_NE(second.find("stopped without writing its end"), std::string::npos) << second;
}

// A file size limit (RLIMIT_FSIZE: writes fail with EFBIG as a full disk fails with ENOSPC) stops
// the campaign part way: the error says how to resume, and the resume completes it.
TEST_F(Hostile, CampaignStoppedByAFullDiskSaysHowToResume) {
    const std::string camp = p("camp").string();
    const std::string out_path = p("full.txt").string();
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        const int fd = open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(fd, 1);
        dup2(fd, 2);
        signal(SIGXFSZ, SIG_IGN);
        struct rlimit rl {
            8000, 8000
        };
        setrlimit(RLIMIT_FSIZE, &rl);
        execl(GONIO_EXE,
              GONIO_EXE,
              "acquire",
              "--out",
              camp.c_str(),
              "--n-theta",
              "4",
              "--n-dphi",
              "3",
              "--adaptive",
              "0",
              "--time-scale",
              "500",
              static_cast<char*>(nullptr));
        _exit(127);
    }
    int st = 0;
    ASSERT_EQ(waitpid(pid, &st, 0), pid);
    const std::string out = gonio::testing::read_text(out_path);
    ASSERT_TRUE(WIFEXITED(st)) << out;
    EXPECT_EQ(WEXITSTATUS(st), 1) << out;
    EXPECT_NE(out.find("File too large"), std::string::npos) << out;
    EXPECT_NE(out.find("continue with: gonio acquire --resume " + camp), std::string::npos) << out;
    // Without the limit the resume finishes the campaign.
    const Child again = gonio({"acquire", "--resume", camp});
    EXPECT_EQ(again.status, 0) << again.out;
    EXPECT_NE(again.out.find("completed"), std::string::npos) << again.out;
}

// --resume reads everything from the campaign folder: the embedded rig's ground truth is copied
// in, the original can go; a rig.json pointing outside the folder is refused.
TEST_F(Hostile, ResumeReadsOnlyTheCampaignFolder) {
    put(p("truth.json"), kHostileModel);
    const std::string camp = p("camp").string();
    const Child c = gonio({"acquire",
                           "--brdf",
                           p("truth.json").string(),
                           "--out",
                           camp,
                           "--n-theta",
                           "3",
                           "--n-dphi",
                           "2",
                           "--adaptive",
                           "0",
                           "--time-scale",
                           "500"});
    ASSERT_EQ(c.status, 0) << c.out;
    EXPECT_EQ(gonio::testing::read_text(p("camp/ground_truth.json")), kHostileModel);
    fs::remove(p("truth.json"));
    const Child again = gonio({"acquire", "--resume", camp});
    EXPECT_EQ(again.status, 0) << again.out;
    EXPECT_NE(again.out.find("ground_truth.json"), std::string::npos) << again.out;

    std::string rig = gonio::testing::read_text(p("camp/rig.json"));
    const std::string from = "\"brdf\": \"ground_truth.json\"";
    const auto at = rig.find(from);
    ASSERT_NE(at, std::string::npos) << rig;
    rig.replace(at, from.size(), "\"brdf\": \"../truth.json\"");
    put(p("camp/rig.json"), rig);
    const Child outside = gonio({"acquire", "--resume", camp});
    EXPECT_EQ(outside.status, 1) << outside.out;
    EXPECT_NE(outside.out.find("lies outside the campaign folder"), std::string::npos)
        << outside.out;
}

}  // namespace
