#include "outputopts.h"

#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace unilod::cli {

CLI::Option* addOutputOptions(CLI::App* sub, OutputFlags& o, const std::string& help, bool required,
                              bool stdoutAllowed) {
    CLI::Option* output = sub->add_option("-o,--output", o.path, help);
    if (required) output->required();
    if (!stdoutAllowed) output->check(notStdout(sub->get_name()));
    // The old spelling feeds the documented option, so that `required` is met by either.
    sub->add_option_function<std::string>(
           "--out", [output](const std::string& v) { output->add_result(v); },
           "old spelling of -o,--output")
        ->trigger_on_parse()
        ->group("");
    sub->add_flag("--overwrite", o.overwrite,
                  "replace an existing output (a folder output: one that is not empty)");
    sub->add_flag("--force", o.overwrite, "old spelling of --overwrite")->group("");
    return output;
}

CLI::Validator notStdout(const std::string& command) {
    return CLI::Validator(
        [command](std::string& v) -> std::string {
            if (v != "-") return "";
            return "'-' is not stdout here: " + command +
                   " writes to a named path (./- is one called '-')";
        },
        "");
}

bool checkOutput(const OutputFlags& o, OutputKind kind, std::string& error) {
    if (o.path.empty()) {
        error = "no output given (-o, --output)";
        return false;
    }
    struct stat st {};
    if (::lstat(o.path.c_str(), &st) != 0) return true;  // missing: written as new
    if (kind == OutputKind::Folder && S_ISDIR(st.st_mode)) {
        std::error_code ec;
        if (std::filesystem::is_empty(o.path, ec) || o.overwrite) return true;
        error = o.path + ": already exists and is not an empty folder (use --overwrite to "
                         "replace it)";
        return false;
    }
    if (kind == OutputKind::File && S_ISREG(st.st_mode)) {
        if (o.overwrite) return true;
        error = o.path + ": already exists (use --overwrite to replace it)";
        return false;
    }
    if (S_ISDIR(st.st_mode)) {
        error = o.path + ": is a directory, not a file";
    } else if (S_ISLNK(st.st_mode)) {
        if (o.overwrite) return true;  // a link to a file: the rename replaces the link
        error = o.path + ": already exists (use --overwrite to replace it)";
    } else {
        error = o.path + (kind == OutputKind::Folder ? ": exists and is not a folder"
                                                     : ": exists and is not a regular file");
    }
    return false;
}

format::OutputOptions outputOptions(const OutputFlags& o, std::vector<std::string> inputs) {
    format::OutputOptions out;
    out.replace = o.overwrite;
    out.inputs = std::move(inputs);
    return out;
}

CLI::Option* addQuietFlag(CLI::App* sub, bool& quiet) {
    return sub->add_flag("-q,--quiet", quiet,
                         "no progress or information lines on stderr (errors and warnings still "
                         "print)");
}

CLI::Option* addJsonOption(CLI::App* sub, JsonFlags& j, const std::string& help,
                           bool fileAllowed) {
    CLI::Option* json = sub->add_option("--json", j.target, help)
                            ->expected(0, 1)
                            ->default_str("-");
    if (!fileAllowed) {
        json->check(CLI::Validator(
            [](std::string& v) -> std::string {
                return v == "-" ? "" : "only '-' (stdout) is accepted, not '" + v + "'";
            },
            "[-]"));
    }
    return json;
}

ReplacedFolder::~ReplacedFolder() {
    format::cancelOnSignal(signalSlot_);
    if (aside_.empty()) return;
    // The writer failed: it left nothing at path_ (atomicfile.h), so the old folder goes back.
    if (::rename(aside_.c_str(), path_.c_str()) != 0) {
        std::fprintf(stderr, "warning: could not move '%s' back to '%s': %s\n", aside_.c_str(),
                     path_.c_str(), std::strerror(errno));
    }
}

bool ReplacedFolder::moveAside(const std::string& path, const format::OutputOptions& inputs,
                               const ForeignPart& foreign, const std::string& what,
                               std::string& error) {
    struct stat st {};
    std::error_code ec;
    if (::lstat(path.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) ||
        std::filesystem::is_empty(path, ec))
        return true;
    // An input inside the folder (by its real path: symbolic links and ".." resolved).
    const std::filesystem::path folder = std::filesystem::weakly_canonical(path, ec);
    std::vector<std::string> files = inputs.inputs;
    for (const auto& part : inputs.inputParts)
        files.push_back(part.first);
    for (const std::string& input : files) {
        if (ec) break;
        if (input.empty()) continue;  // an input not given (report's --dem)
        std::error_code ic;
        const std::filesystem::path in = std::filesystem::weakly_canonical(input, ic);
        if (ic) continue;
        const auto [f, i] = std::mismatch(folder.begin(), folder.end(), in.begin(), in.end());
        if (f == folder.end() && i != in.end()) {
            error = path + ": holds '" + input +
                    "', an input of this command: refusing to replace the folder (write the "
                    "output elsewhere)";
            return false;
        }
    }
    // Only an earlier output of the command is replaced: every entry one it writes.
    std::vector<std::string> foreignNames;
    // Advanced with an error code: the range-for's increment throws on a read error.
    for (std::filesystem::directory_iterator it(path, ec), end; !ec && it != end;
         it.increment(ec)) {
        std::string name = foreign(*it);
        if (!name.empty()) foreignNames.push_back(std::move(name));
    }
    if (ec) {
        error = path + ": cannot list the folder: " + ec.message();
        return false;
    }
    if (!foreignNames.empty()) {
        std::sort(foreignNames.begin(), foreignNames.end());
        std::string names;
        for (std::size_t i = 0; i < foreignNames.size() && i < 3; ++i)
            names += (i == 0 ? "'" : ", '") + foreignNames[i] + "'";
        if (foreignNames.size() > 3)
            names += " and " + std::to_string(foreignNames.size() - 3) + " more";
        error = path + ": holds " + names + ", not of " + what +
                ": refusing to replace the folder (--overwrite replaces " + what +
                " written before; give a new or empty folder)";
        return false;
    }
    std::string p = path;
    while (p.size() > 1 && p.back() == '/')
        p.pop_back();
    const std::string aside = format::besideName(p, ".old-" + std::to_string(::getpid()));
    // Armed first: a Ctrl-C at any time from here on puts the old folder back (before the move,
    // the rename back finds nothing to move).
    signalSlot_ = format::renameOnSignal(aside, p);
    if (::rename(p.c_str(), aside.c_str()) != 0) {
        format::cancelOnSignal(signalSlot_);
        error = path + ": cannot move the old folder aside to '" + aside +
                "': " + std::strerror(errno);
        return false;
    }
    path_ = p;
    aside_ = aside;
    return true;
}

void ReplacedFolder::keep() {
    format::cancelOnSignal(signalSlot_);
    if (aside_.empty()) return;
    std::error_code ec;
    std::filesystem::remove_all(aside_, ec);
    if (ec) {
        std::fprintf(stderr, "warning: could not remove the old folder '%s': %s\n",
                     aside_.c_str(), ec.message().c_str());
    }
    aside_.clear();
}

}  // namespace unilod::cli
