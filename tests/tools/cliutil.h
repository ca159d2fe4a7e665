// Shared by the CLI tests: run the built `unilod` binary (UNILOD_CLI) through the shell and
// capture its exit code, stdout and stderr.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ulod.h"

namespace unilod::test {

inline std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

struct CliResult {
    int code = -1;
    std::string out, err;
};

// Runs `unilod ARGS` (ARGS already shell-quoted where needed). `shellPrefix` comes before the
// command in the same shell: "timeout 20" (a hang fails instead of blocking the test), "ulimit -f
// 16; exec" (a file size limit).
inline CliResult runCli(const std::string& args, const std::string& shellPrefix = "") {
    namespace fs = std::filesystem;
    static int counter = 0;
    const fs::path base =
        fs::temp_directory_path() /
        ("unilod_test_cli_run_" + std::to_string(getpid()) + "_" + std::to_string(counter++));
    const std::string out = base.string() + ".out", err = base.string() + ".err";
    const std::string command = shellPrefix + " '" + std::string(UNILOD_CLI) + "' " + args + " >'" +
                                out + "' 2>'" + err + "'";
    const int status = std::system(command.c_str());
    CliResult r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    fs::remove(out);
    fs::remove(err);
    return r;
}

// Single-quotes a path for the shell.
inline std::string q(const std::string& s) {
    return "'" + s + "'";
}

// Reads a whole .ulod file: header, directory and every block. False with `error` on failure.
struct Model {
    format::Header header;
    std::vector<format::BlockInfo> infos;
    std::vector<format::Block> blocks;
};
inline bool readModel(const std::string& path, Model& model, std::string& error) {
    format::Reader reader;
    if (!reader.open(path, error)) return false;
    model.header = reader.header();
    model.infos = reader.blocks();
    model.blocks.resize(model.infos.size());
    for (std::size_t i = 0; i < model.blocks.size(); ++i)
        if (!reader.readBlock(i, model.blocks[i], error)) return false;
    return true;
}

}  // namespace unilod::test
