// The README's CLI against the binary (issue 20, item 3):
// - the table "Options every command shares" must say what `unilod <command> --help` lists;
// - every `unilod ...` line of the README's ```sh blocks runs, with `assets/` and `out/` pointed
//   at the bundled data and a temporary folder, and exits 0 or the status its `# exit N` comment
//   gives. The Quick start's `tools/demo.sh` and `tools/test.sh` lines are not `unilod` lines and
//   are not run: the test suite itself runs under tools/test.sh, and tools.test_demo runs the demo.
//   ```text blocks are synopses (placeholders, brackets), not commands.
// Also the existing-output rule of tools/cli/outputopts.h on a folder (report) and on files.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cliutil.h"

namespace {

namespace fs = std::filesystem;
using unilod::test::CliResult;
using unilod::test::q;
using unilod::test::runCli;
using unilod::test::slurp;

// The Vulkan driver (lavapipe) leaks from an unloaded module under LeakSanitizer (see
// tests/CMakeLists.txt): commands that start the engine run without leak detection.
std::string prefixFor(const std::string& args) {
    for (const char* engine : {"capture", "bench", "view", "report", "export"})
        if (args.rfind(std::string(engine) + " ", 0) == 0) return "ASAN_OPTIONS=detect_leaks=0";
    return "";
}

std::vector<std::string> readmeLines() {
    std::ifstream in(std::string(UNILOD_SOURCE_DIR) + "/README.md");
    std::vector<std::string> lines;
    for (std::string l; std::getline(in, l);)
        lines.push_back(l);
    return lines;
}

std::string trim(std::string s) {
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t'))
        s.pop_back();
    std::size_t i = 0;
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t'))
        ++i;
    return s.substr(i);
}

std::vector<std::string> cells(const std::string& row) {
    std::vector<std::string> out;
    std::string cur;
    for (std::size_t i = 1; i < row.size(); ++i) {
        if (row[i] == '|' && row[i - 1] != '\\') {
            out.push_back(trim(cur));
            cur.clear();
        } else {
            cur += row[i];
        }
    }
    return out;
}

// The option names `unilod ARGS --help` lists ("-o,--output TEXT ..." -> -o, --output).
std::set<std::string> helpOptions(const std::string& command) {
    const CliResult r = runCli(command + " --help");
    EXPECT_EQ(r.code, 0) << command << ": " << r.err;
    std::set<std::string> names;
    std::istringstream in(r.out);
    for (std::string line; std::getline(in, line);) {
        line = trim(line);
        if (line.empty() || line[0] != '-') continue;
        const std::string first = line.substr(0, line.find(' '));
        std::stringstream parts(first);
        for (std::string n; std::getline(parts, n, ',');) {
            if (!n.empty() && n[0] == '!') n.erase(0, 1);
            const auto brace = n.find('{');
            if (brace != std::string::npos) n.erase(brace);
            if (!n.empty()) names.insert(n);
        }
    }
    return names;
}

// The names a cell lists in backticks: "`-o`, `--out`" -> -o, --out.
std::vector<std::string> backticked(const std::string& cell) {
    std::vector<std::string> out;
    const std::regex re("`([^`]+)`");
    for (std::sregex_iterator it(cell.begin(), cell.end(), re), end; it != end; ++it)
        out.push_back((*it)[1]);
    return out;
}

TEST(CliReadme, SharedOptionsTableMatchesHelp) {
    const std::vector<std::string> lines = readmeLines();
    std::size_t header = lines.size();
    for (std::size_t i = 0; i < lines.size(); ++i)
        if (lines[i].rfind("| command | what it writes |", 0) == 0) header = i;
    ASSERT_LT(header, lines.size()) << "README: no table '| command | what it writes | ...'";
    const std::vector<std::string> head = cells(lines[header]);
    ASSERT_EQ(head.size(), 7u);
    // Column -> the options it stands for (from its own header text).
    std::vector<std::vector<std::string>> columns;
    for (std::size_t c = 2; c < head.size(); ++c) {
        columns.push_back(backticked(head[c]));
        ASSERT_FALSE(columns.back().empty()) << head[c];
    }
    std::set<std::string> commands;
    for (std::size_t i = header + 2; i < lines.size() && lines[i].rfind("|", 0) == 0; ++i) {
        const std::vector<std::string> row = cells(lines[i]);
        ASSERT_EQ(row.size(), head.size()) << lines[i];
        const std::vector<std::string> name = backticked(row[0]);
        ASSERT_EQ(name.size(), 1u) << lines[i];
        commands.insert(name[0]);
        const std::set<std::string> help = helpOptions(name[0]);
        ASSERT_TRUE(help.count("--help")) << name[0];
        for (std::size_t c = 0; c < columns.size(); ++c) {
            const std::string& cell = row[c + 2];
            const std::string what = name[0] + ", column " + head[c + 2] + " '" + cell + "'";
            if (cell == "yes") {
                for (const std::string& o : columns[c])
                    EXPECT_TRUE(help.count(o)) << what << ": --help lacks " << o;
            } else if (cell == "—") {
                for (const std::string& o : columns[c])
                    EXPECT_FALSE(help.count(o)) << what << ": --help lists " << o;
            } else {
                const std::vector<std::string> listed = backticked(cell);
                EXPECT_FALSE(listed.empty()) << what << ": yes, — or the options in backticks";
                for (const std::string& o : listed) {
                    EXPECT_TRUE(help.count(o)) << what << ": --help lacks " << o;
                }
            }
        }
        // The old spellings work but are not documented in --help (export keeps --out for now).
        for (const char* old : {"--force", "--target-srs", "--assume-crs", "--rivers-srs"})
            EXPECT_FALSE(help.count(old)) << name[0] << " --help lists the old " << old;
    }
    // Every command of the binary has its row.
    const CliResult all = runCli("--help");
    const std::regex sub("^  ([a-z]+) ");
    std::set<std::string> listed;
    std::istringstream in(all.out);
    bool inSubcommands = false;
    for (std::string line; std::getline(in, line);) {
        if (line.rfind("Subcommands:", 0) == 0) inSubcommands = true;
        std::smatch m;
        if (inSubcommands && std::regex_search(line, m, sub)) listed.insert(m[1]);
    }
    EXPECT_EQ(listed.size(), 11u) << all.out;
    EXPECT_EQ(listed, commands);
}

struct ReadmeCommand {
    std::string args;  // after "unilod "
    int expected = 0;
    std::size_t line = 0;
};

std::vector<ReadmeCommand> readmeCommands() {
    const std::vector<std::string> lines = readmeLines();
    std::vector<ReadmeCommand> out;
    bool inSh = false, inOther = false;
    const std::regex exitComment("#\\s*exit\\s+([0-9]+)");
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const std::string l = trim(lines[i]);
        if (l.rfind("```", 0) == 0) {
            if (inSh || inOther) {
                inSh = inOther = false;
            } else {
                (l == "```sh" ? inSh : inOther) = true;
            }
            continue;
        }
        if (!inSh || l.rfind("unilod ", 0) != 0) continue;
        ReadmeCommand c;
        c.line = i + 1;
        std::string text = l.substr(7);
        const std::size_t hash = text.find('#');
        if (hash != std::string::npos) {
            std::smatch m;
            const std::string comment = text.substr(hash);
            if (std::regex_search(comment, m, exitComment)) c.expected = std::stoi(m[1]);
            text = trim(text.substr(0, hash));
        }
        EXPECT_EQ(text.find('\\'), std::string::npos)
            << "README line " << c.line << ": a command in a ```sh block must fit on one line";
        c.args = text;
        out.push_back(c);
    }
    return out;
}

// `assets/X` and `out/X` words -> the bundled data and `dir`.
std::string substitute(const std::string& args, const std::string& dir) {
    std::istringstream in(args);
    std::string out;
    for (std::string w; in >> w;) {
        if (w.rfind("assets/", 0) == 0) w = q(std::string(UNILOD_ASSETS_DIR) + "/" + w.substr(7));
        else if (w.rfind("out/", 0) == 0) w = q(dir + "/" + w.substr(4));
        out += (out.empty() ? "" : " ") + w;
    }
    return out;
}

TEST(CliReadme, EveryCommandLineRuns) {
    const std::vector<ReadmeCommand> commands = readmeCommands();
    // The session block alone has more than a dozen: a README without them fails here.
    ASSERT_GE(commands.size(), 12u);
    const fs::path dir = fs::temp_directory_path() / ("unilod_readme_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::set<std::string> seen;
    for (const ReadmeCommand& c : commands) {
        const std::string args = substitute(c.args, dir.string());
        const CliResult r = runCli(args, prefixFor(c.args));
        EXPECT_EQ(r.code, c.expected) << "README line " << c.line << ": unilod " << c.args
                                      << "\nstdout:\n" << r.out << "\nstderr:\n" << r.err;
        seen.insert(c.args.substr(0, c.args.find(' ')));
        // `--json -` prints JSON on stdout.
        if (r.code == 0 && c.args.find("--json -") != std::string::npos) {
            EXPECT_FALSE(nlohmann::json::parse(r.out, nullptr, false).is_discarded())
                << "README line " << c.line << ": not JSON:\n" << r.out;
        }
        if (c.expected == 1) {
            EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
        }
        if (c.expected == 2 && c.args.rfind("foo", 0) == 0) {
            EXPECT_NE(r.err.find("unknown command 'foo'"), std::string::npos) << r.err;
        }
    }
    // Every command that writes or prints without a display appears, and wrote what it says.
    for (const char* name : {"synth", "build", "check", "info", "stats", "order", "capture",
                             "bench", "export", "report"})
        EXPECT_TRUE(seen.count(name)) << "README session lacks " << name;
    EXPECT_TRUE(fs::exists(dir / "synth" / "dem.tif"));
    EXPECT_TRUE(fs::exists(dir / "jacksboro.ulod"));
    EXPECT_TRUE(fs::exists(dir / "capture" / "frame_0000.png"));
    EXPECT_TRUE(fs::exists(dir / "report" / "tables.md"));
    EXPECT_FALSE(nlohmann::json::parse(slurp((dir / "bench.json").string()), nullptr, false)
                     .is_discarded());
    if (!HasFailure()) fs::remove_all(dir);
}

// The rule for an existing output (outputopts.h) on a folder (report) and on files (synth,
// order), with the old spelling --force.
TEST(CliReadme, ExistingOutputsNeedOverwrite) {
    const fs::path dir = fs::temp_directory_path() / ("unilod_overwrite_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string synth = (dir / "synth").string(), model = (dir / "m.ulod").string();
    ASSERT_EQ(runCli("synth --points 3000 -q -o " + q(synth)).code, 0);
    CliResult r = runCli("synth --points 3000 -q -o " + q(synth));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("dem.tif: already exists (use --overwrite to replace it)"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(runCli("synth --points 3000 -q --force -o " + q(synth)).code, 0);
    ASSERT_EQ(runCli("build -q " + q(synth + "/dem.tif") + " " + q(synth + "/rivers.geojson") +
                     " -o " + q(model))
                  .code,
              0);

    // order: the CSV as a file output; the old spelling --out too.
    const std::string csv = (dir / "order.csv").string();
    {
        std::ofstream(csv) << "keep me\n";
    }
    r = runCli("order -q " + q(synth + "/dem.tif") + " " + q(synth + "/rivers.geojson") +
               " --out " + q(csv));
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(slurp(csv), "keep me\n");
    r = runCli("order -q " + q(synth + "/dem.tif") + " " + q(synth + "/rivers.geojson") + " -o " +
               q(csv) + " --overwrite");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(slurp(csv).rfind("rank,id,", 0), 0u);

    // report: a non-empty folder is refused and stays as it was; --overwrite replaces an earlier
    // report whole, never a folder holding anything else (it removed every file there).
    const fs::path report = dir / "report";
    fs::create_directories(report);
    {
        std::ofstream(report / "old.txt") << "old";
    }
    const std::string reportArgs = "report -q " + q(model) + " -o " + q(report.string()) +
                                   " --no-rivers --distance 100km --image-size 64";
    r = runCli(reportArgs, "ASAN_OPTIONS=detect_leaks=0");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("not an empty folder (use --overwrite"), std::string::npos) << r.err;
    EXPECT_TRUE(fs::exists(report / "old.txt"));
    EXPECT_FALSE(fs::exists(report / "tables.md"));
    r = runCli(reportArgs + " --overwrite", "ASAN_OPTIONS=detect_leaks=0");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("holds 'old.txt', not of a report: refusing to replace the folder"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(slurp((report / "old.txt").string()), "old");
    EXPECT_FALSE(fs::exists(report / "tables.md"));
    fs::remove(report / "old.txt");
    r = runCli(reportArgs, "ASAN_OPTIONS=detect_leaks=0");  // an empty folder: written as new
    EXPECT_EQ(r.code, 0) << r.err;
    fs::remove(report / "tables.md");  // an earlier report missing one of its files
    r = runCli(reportArgs + " --overwrite", "ASAN_OPTIONS=detect_leaks=0");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(report / "tables.md"));
    // Nothing left beside it (the old folder moved aside is removed).
    std::size_t entries = 0;
    for (const auto& e : fs::directory_iterator(dir))
        entries += e.path().filename().string().rfind("report", 0) == 0;
    EXPECT_EQ(entries, 1u);

    // A missing -o is a usage error naming the option; the old spelling satisfies it.
    r = runCli("report -q " + q(model));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("--output is required"), std::string::npos) << r.err;
    if (!HasFailure()) fs::remove_all(dir);
}

TEST(CliReadme, UnknownCommandIsNamed) {
    CliResult r = runCli("frobnicate --x");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("unilod: unknown command 'frobnicate'; commands: synth, order, build"),
              std::string::npos)
        << r.err;
    r = runCli("");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("no command given"), std::string::npos) << r.err;
    // `--json` takes only '-' where it is a stdout flag, and leaves the file to FILE.
    r = runCli("info --json nosuch.ulod");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("nosuch.ulod"), std::string::npos) << r.err;
    r = runCli("info nosuch.ulod --json other.json");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("only '-' (stdout)"), std::string::npos) << r.err;
    // A usage error reads like every other error: the command, "error:", what is wrong, and
    // where the usage is.
    r = runCli("build only_a_dem.tif");
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err.rfind("unilod build: error: --output is required\n", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("unilod build --help"), std::string::npos) << r.err;
    r = runCli("--frobnicate");
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err.rfind("unilod: error: ", 0), 0u) << r.err;
}

}  // namespace
