// The options every `unilod` command shares for what it writes and prints (issue 20, item 3):
// `-o,--output`, `--overwrite`, `-q,--quiet`, `--json [-]`, `--t-srs` / `--s-srs` (the last two
// in ingestopts.h). One definition, so that names, old spellings, help and the rule for an
// existing output cannot drift between commands (cmd_export.cpp adopts it too).
//
// The rule for an existing output (README "Files written and read"):
// - a file output (build, order, bench, export, the two synth files) exists when anything is at
//   the path; without --overwrite the command fails with exit 1 and the message
//   "PATH: already exists (use --overwrite to replace it)" before any work, and writes nothing.
//   With --overwrite the file is replaced atomically (format::AtomicFile, OutputOptions::replace =
//   outputOptions(...).replace): the old file stays until the new one is complete.
// - a folder output (capture, report) exists when it is a folder that is not empty (a missing or
//   empty folder is written as before); anything else at the path is refused as for a file.
//   With --overwrite, capture replaces the frames of the same names (other files stay) and report
//   replaces the whole folder (the old one is moved aside and removed only after the new one is in
//   place: ReplacedFolder below).
// An output that is one of the command's inputs is refused with --overwrite too (atomicfile.h).
// Exit status: 0 success, 1 data error (an existing output is one), 2 usage error (a missing
// -o/--output).
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "atomicfile.h"

namespace unilod::cli {

struct OutputFlags {
    std::string path;
    bool overwrite = false;
};

enum class OutputKind { File, Folder };

// Adds `-o,--output PATH` (help `help`) and `--overwrite`, with the old spellings `--out` and
// `--force` as hidden aliases. `required`: a missing -o/--output is a usage error (exit 2, raised
// after the subcommand's options are parsed, so that the old alias satisfies it too).
// `stdoutAllowed`: `-o -` means stdout (bench's JSON, order's CSV); otherwise `-` is refused as a
// usage error (exit 2) instead of writing a file named "-" (`-o ./-` still names one). Returns
// the -o,--output option.
CLI::Option* addOutputOptions(CLI::App* sub, OutputFlags& o, const std::string& help,
                              bool required = true, bool stdoutAllowed = false);

// Refuses `-` as an output path of `command` (a usage error, exit 2): its output is a named file or
// folder, not stdout (addOutputOptions without stdoutAllowed; export --3dtiles, view --screenshot).
CLI::Validator notStdout(const std::string& command);

// The existing-output rule above for `o.path` (`kind`): true when the command may write it.
// False with `error` = "PATH: already exists (use --overwrite to replace it)" (or why the path
// cannot be an output: a directory where a file is expected, a FIFO). Commands that write through
// an AtomicFile get the same check from it (outputOptions); this one is for the folders and for
// failing before long work.
bool checkOutput(const OutputFlags& o, OutputKind kind, std::string& error);

// The AtomicFile options for `o`: replace = --overwrite; never one of `inputs`.
format::OutputOptions outputOptions(const OutputFlags& o, std::vector<std::string> inputs);

// `-q,--quiet`: no progress or information lines on stderr; errors and warnings still print.
CLI::Option* addQuietFlag(CLI::App* sub, bool& quiet);

// `--json [-]`: JSON output; `-` (or no value) is stdout. `fileAllowed`: `--json FILE` writes the
// JSON to FILE (bench, its old spelling of -o FILE); otherwise only `-` is accepted. The value
// is taken only when no required positional argument is still missing, so that
// `unilod info --json m.ulod` keeps meaning FILE = m.ulod.
struct JsonFlags {
    std::string target;  // empty: not asked for; "-": stdout; else a file
    bool requested() const { return !target.empty(); }
    bool toStdout() const { return target == "-"; }
};
CLI::Option* addJsonOption(CLI::App* sub, JsonFlags& j, const std::string& help,
                           bool fileAllowed = false);

// --overwrite of a folder output whose writer needs a missing or empty folder (report): moves an
// existing non-empty folder aside (PATH.old-<pid>) so that the writer sees none; keep() removes
// the old folder after the new one is in place, and the destructor (the writer failed) moves it
// back, so that a failed run leaves the old folder as it was; so does a stop by SIGINT, SIGTERM,
// SIGHUP, SIGQUIT or SIGPIPE (format::renameOnSignal; until 2026-12-03 Ctrl-C left it at
// PATH.old-<pid> and nothing at PATH).
class ReplacedFolder {
public:
    ReplacedFolder() = default;
    ~ReplacedFolder();
    ReplacedFolder(const ReplacedFolder&) = delete;
    ReplacedFolder& operator=(const ReplacedFolder&) = delete;

    // What of an existing folder is an earlier output of the command: for an entry of the
    // folder, "" when the command wrote it, else the name to show (the entry's, or a part of it:
    // "tiles/notes.txt"). Defined beside each writer (report.h reportForeignPart, tiles3d.h
    // tilesetForeignPart), which knows its own names and marks.
    using ForeignPart = std::function<std::string(const std::filesystem::directory_entry&)>;

    // Moves `path` aside when it is a non-empty folder. False with `error` when it cannot, when
    // one of `inputs` (the command's input files and their parts) is inside it (replacing the
    // folder would remove the input), or when `foreign` names any part of it: --overwrite
    // replaces an earlier output, never a folder of other files (`report m.ulod -o ~/Documents
    // --overwrite` removed every document until 2026-12-03; a report.json placed by hand that
    // listed other files, or another tool's tileset.json beside a tiles/ folder, made them
    // count as the output's until 2026-12-08). `what` names that output in the message ("a
    // report").
    bool moveAside(const std::string& path, const format::OutputOptions& inputs,
                   const ForeignPart& foreign, const std::string& what, std::string& error);
    void keep();  // the new folder is in place: remove the old one

private:
    std::string path_, aside_;
    int signalSlot_ = -1;  // format::renameOnSignal: a Ctrl-C moves the old folder back
};

}  // namespace unilod::cli
