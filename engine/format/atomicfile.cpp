// Atomic output files and the input-file check (atomicfile.h).
#include "atomicfile.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <utility>

namespace unilod::format {

namespace {

std::string errnoText(int e = errno) {
    return std::strerror(e);
}

// The folder holding `path` ("." for a bare name) and the name inside it.
std::string folderOf(const std::string& path) {
    const std::size_t slash = path.find_last_of('/');
    if (slash == std::string::npos) return ".";
    return slash == 0 ? "/" : path.substr(0, slash);
}
std::string nameOf(const std::string& path) {
    const std::size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

// Names made beside an output (PATH.tmp-<pid>-<hex>, PATH.old-<pid>) add at most 22 bytes;
// a name longer than this is cut to it there, so that an output whose own name is as long as
// the file system allows (255 bytes) can still be written (it failed with "cannot create a
// temporary file beside it: File name too long" until 2026-12-03).
constexpr std::size_t kBesideNameBytes = 255 - 32;

std::string shortName(const std::string& name) {
    if (name.size() <= kBesideNameBytes) return name;
    std::size_t n = kBesideNameBytes;
    while (n > 0 && (static_cast<unsigned char>(name[n]) & 0xC0) == 0x80)
        --n;  // not inside a UTF-8 character
    return name.substr(0, n);
}

std::string kindOf(mode_t mode) {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "";
}

// "is a FIFO (named pipe), not a regular file"
std::string notRegular(mode_t mode) {
    const std::string kind = kindOf(mode);
    return kind.empty() ? "is not a regular file" : "is " + kind + ", not a regular file";
}

// Temporary files removed when the process is stopped by SIGINT, SIGTERM, SIGHUP, SIGQUIT or
// SIGPIPE (Ctrl-C, kill, a closed terminal, Ctrl-\, a reader gone: `unilod order ... | head`
// left its temporary CSV behind until 2026-12-03), so that such a stop leaves no partial file
// behind either: a fixed table the handler walks with async-signal-safe calls only (unlink),
// then the signal's default action is taken again (the process ends by the signal, as before).
// A slot is free (0), being filled (1) or armed (2). Temporary folders (report, 3D Tiles) are not
// removed here (no async-signal-safe recursive removal); the next run writing the same PATH removes
// them as stale. A slot with a `to` path renames `path` back to it instead (renameOnSignal: an old
// folder moved aside by --overwrite goes back, as when the command fails).
constexpr int kSignalSlots = 64;
constexpr std::size_t kSignalPathMax = 4096;
struct SignalSlot {
    std::atomic<int> state{0};
    char path[kSignalPathMax];
    char to[kSignalPathMax];
};
SignalSlot signalSlots[kSignalSlots];

extern "C" void removeTemporariesAndReraise(int sig) {
    for (SignalSlot& slot : signalSlots) {
        if (slot.state.load(std::memory_order_acquire) != 2) continue;
        if (slot.to[0] != '\0') {
            ::rename(slot.path, slot.to);
        } else {
            ::unlink(slot.path);
        }
    }
    ::signal(sig, SIG_DFL);
    ::raise(sig);
}

// Installs the handler for the signals whose action is the default (an ignored SIGHUP under nohup,
// or a handler of the embedding program, stays as it is).
void installSignalCleanup() {
    static std::once_flag once;
    std::call_once(once, [] {
        for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE}) {
            struct sigaction old {};
            if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL ||
                (old.sa_flags & SA_SIGINFO))
                continue;
            struct sigaction action {};
            action.sa_handler = removeTemporariesAndReraise;
            sigemptyset(&action.sa_mask);
            ::sigaction(sig, &action, nullptr);
        }
    });
}

// The slot now armed for `temp` (-1: none free or the path too long: the file is then only
// removed as stale by a later run).
int armSignalCleanup(const std::string& temp, const std::string& to = "") {
    if (temp.size() >= kSignalPathMax || to.size() >= kSignalPathMax) return -1;
    installSignalCleanup();
    for (int i = 0; i < kSignalSlots; ++i) {
        int expected = 0;
        if (signalSlots[i].state.compare_exchange_strong(expected, 1, std::memory_order_acq_rel)) {
            std::memcpy(signalSlots[i].path, temp.c_str(), temp.size() + 1);
            std::memcpy(signalSlots[i].to, to.c_str(), to.size() + 1);
            signalSlots[i].state.store(2, std::memory_order_release);
            return i;
        }
    }
    return -1;
}

void disarmSignalCleanup(int& slot) {
    if (slot >= 0) signalSlots[slot].state.store(0, std::memory_order_release);
    slot = -1;
}

// "PATH.tmp-<pid>-": the prefix of every temporary of PATH written by process `pid`.
std::string tempPrefix(const std::string& name) {
    return shortName(name) + ".tmp-";
}

// Removes the temporaries of `path` whose writer is no longer running. Names that do not parse
// as PATH.tmp-<pid>-<anything> are not ours and are left alone (so is everything else on error:
// a stale temporary is only clutter).
void removeStaleTemporaries(const std::string& path) {
    const std::string folder = folderOf(path);
    const std::string prefix = tempPrefix(nameOf(path));
    DIR* dir = ::opendir(folder.c_str());
    if (dir == nullptr) return;
    std::vector<std::string> stale;
    while (const dirent* e = ::readdir(dir)) {
        const std::string name = e->d_name;
        if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
        std::size_t i = prefix.size();
        long long pid = 0;
        while (i < name.size() && name[i] >= '0' && name[i] <= '9' && pid < (1LL << 40))
            pid = pid * 10 + (name[i++] - '0');
        if (i == prefix.size() || i >= name.size() || name[i] != '-' || pid <= 0) continue;
        if (pid == ::getpid()) continue;
        // ESRCH: no such process. EPERM means it runs under another user: still alive.
        if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) stale.push_back(name);
    }
    ::closedir(dir);
    for (const std::string& name : stale) {
        std::error_code ec;
        std::filesystem::remove_all(std::filesystem::path(folder) / name, ec);
    }
}

// A name that no other writer of `path` uses: our pid plus a per-process counter and the clock;
// O_EXCL / mkdir make it certain.
std::string newTempName(const std::string& path) {
    static std::atomic<std::uint64_t> counter{0};
    const auto now =
        static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
    const std::uint64_t mix = (now ^ (counter.fetch_add(1) * 0x9E3779B97F4A7C15ull)) & 0xFFFFFFull;
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, "%06llx", static_cast<unsigned long long>(mix));
    return folderOf(path) + "/" + tempPrefix(nameOf(path)) + std::to_string(::getpid()) + "-" +
           suffix;
}

bool sameFile(const struct stat& a, const struct stat& b) {
    return a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

// The input `name` (or the file inside it, fileInside) is the file `out` describes.
bool inputIs(const std::string& name, const struct stat& out) {
    struct stat in {};
    if (::stat(name.c_str(), &in) == 0) return sameFile(in, out);
    const std::string inside = fileInside(name);
    return !inside.empty() && ::stat(inside.c_str(), &in) == 0 && sameFile(in, out);
}

// Why the existing file `out` at `path` is not to be replaced because it is an input or a file
// of one ("is also an input of this command"); "" when it is neither.
std::string inputConflict(const std::string& path, const struct stat& out,
                          const OutputOptions& options) {
    for (const std::string& input : options.inputs) {
        if (inputIs(input, out)) {
            return input == path
                       ? "is also an input of this command: refusing to overwrite it"
                       : "is the same file as the input '" + input + "': refusing to overwrite it";
        }
    }
    for (const auto& [file, input] : options.inputParts) {
        if (inputIs(file, out)) {
            return "is a file of the input '" + input +
                   "' (read with it): refusing to overwrite it";
        }
    }
    return "";
}

// Makes the directory entries of `folder` (a rename) durable; some file systems refuse fsync
// on folders, so this is best effort.
void syncFolder(const std::string& folder) {
    const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
    }
}

}  // namespace

std::string besideName(const std::string& path, const std::string& tag) {
    const std::size_t slash = path.find_last_of('/');
    const std::size_t start = slash == std::string::npos ? 0 : slash + 1;
    return path.substr(0, start) + shortName(path.substr(start)) + tag;
}

bool checkInputFile(const std::string& path, bool folderAllowed, std::string& why) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return true;  // the reader reports a missing file
    if (S_ISREG(st.st_mode) || (folderAllowed && S_ISDIR(st.st_mode))) return true;
    why = notRegular(st.st_mode);
    return false;
}

int renameOnSignal(const std::string& from, const std::string& to) {
    return armSignalCleanup(from, to);
}

void cancelOnSignal(int& slot) {
    disarmSignalCleanup(slot);
}

bool checkOutputPath(const std::string& path, const OutputOptions& options, bool folder,
                     std::string& error) {
    auto fail = [&](const std::string& what) {
        error = path + ": " + what;
        return false;
    };
    if (path.empty()) {
        error = "no output file given";
        return false;
    }
    struct stat out {};
    if (::stat(path.c_str(), &out) == 0) {
        const std::string conflict = inputConflict(path, out, options);
        if (!conflict.empty()) return fail(conflict);
        if (folder) {
            if (!S_ISDIR(out.st_mode) || !std::filesystem::is_empty(path)) {
                return fail("already exists and is not an empty folder");
            }
        } else if (S_ISDIR(out.st_mode)) {
            return fail("is a directory");
        } else if (!S_ISREG(out.st_mode)) {
            return fail(notRegular(out.st_mode) + ": refusing to replace it");
        } else if (!options.replace) {
            return fail("already exists (use --overwrite to replace it)");
        }
    }
    const std::string dir = folderOf(path);
    struct stat ds {};
    if (::stat(dir.c_str(), &ds) != 0 || !S_ISDIR(ds.st_mode) || ::access(dir.c_str(), W_OK) != 0) {
        return fail("folder '" + dir + "' does not exist or is not writable");
    }
    return true;
}

AtomicFile::~AtomicFile() {
    abandon();
}

void AtomicFile::abandon() {
    if (fd_ >= 0) ::close(std::exchange(fd_, -1));
    disarmSignalCleanup(signalSlot_);
    if (!temp_.empty()) {
        std::error_code ec;
        if (folder_) {
            std::filesystem::remove_all(temp_, ec);
        } else {
            ::unlink(temp_.c_str());
        }
        temp_.clear();
    }
}

bool AtomicFile::fail(const std::string& what, std::string& error) {
    error = path_ + ": " + what;
    abandon();
    return false;
}

bool AtomicFile::open(const std::string& path, const OutputOptions& options, std::string& error) {
    return openImpl(path, options, Kind::File, error);
}

bool AtomicFile::openByName(const std::string& path, const OutputOptions& options,
                            std::string& error) {
    return openImpl(path, options, Kind::ByName, error);
}

bool AtomicFile::openFolder(const std::string& path, const OutputOptions& options,
                            std::string& error) {
    return openImpl(path, options, Kind::Folder, error);
}

bool AtomicFile::openImpl(const std::string& path, const OutputOptions& options, Kind kind,
                          std::string& error) {
    const bool folder = kind == Kind::Folder;
    abandon();
    path_ = path;
    options_ = options;
    folder_ = folder;
    offset_ = bytes_ = 0;
    if (!checkOutputPath(path, options, folder, error)) return false;
    removeStaleTemporaries(path);
    for (int attempt = 0; attempt < 100; ++attempt) {
        const std::string temp = newTempName(path);
        // Armed before the file exists: a signal between its creation and the arming left it
        // behind (seen once in tests that signal as soon as it appears). The name carries our
        // pid, so a signal before the creation removes nothing of another process's.
        int slot = folder ? -1 : armSignalCleanup(temp);
        // 0666 / 0777 less the umask: an output is ordinary data.
        const int made = folder
                             ? ::mkdir(temp.c_str(), 0777)
                             : ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (made < 0) {
            const int why = errno;
            disarmSignalCleanup(slot);
            if (why == EEXIST) continue;
            errno = why;
            return fail(std::string("cannot create a temporary ") + (folder ? "folder" : "file") +
                            " beside it: " + errnoText(),
                        error);
        }
        temp_ = temp;
        signalSlot_ = slot;
        if (kind == Kind::File) fd_ = made;
        // ByName: the name was unique a moment ago (O_EXCL) and carries our pid; the library
        // creates the file.
        if (kind == Kind::ByName && (::close(made) != 0 || ::unlink(temp.c_str()) != 0)) {
            return fail("cannot prepare a temporary file beside it: " + errnoText(), error);
        }
        return true;
    }
    return fail("cannot create a temporary file beside it: every name taken", error);
}

bool AtomicFile::write(const void* data, std::size_t size, std::string& error) {
    if (!writeAt(data, size, offset_, error)) return false;
    offset_ += size;
    return true;
}

bool AtomicFile::writeAt(const void* data, std::size_t size, std::uint64_t offset,
                         std::string& error) {
    if (fd_ < 0) return fail("write failed: the file is not open", error);
    const auto* p = static_cast<const unsigned char*>(data);
    while (size > 0) {
        const ssize_t put = ::pwrite(fd_, p, size, static_cast<off_t>(offset));
        if (put < 0 && errno == EINTR) continue;
        // pwrite never returns 0 for size > 0 on a regular file; guard against a loop anyway.
        if (put <= 0) return fail("write failed: " + errnoText(put < 0 ? errno : EIO), error);
        p += put;
        size -= static_cast<std::size_t>(put);
        offset += static_cast<std::uint64_t>(put);
    }
    return true;
}

bool AtomicFile::writeInside(const std::string& relative, std::string_view data,
                             std::string& error) {
    if (!folder_ || temp_.empty()) {
        return fail("write failed: not an open folder output", error);
    }
    const std::string file = temp_ + "/" + relative;
    const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) return fail(relative + ": cannot create: " + errnoText(), error);
    const char* p = data.data();
    std::size_t size = data.size();
    while (size > 0) {
        const ssize_t put = ::write(fd, p, size);
        if (put < 0 && errno == EINTR) continue;
        if (put <= 0) {
            const int e = put < 0 ? errno : EIO;
            ::close(fd);
            return fail(relative + ": write failed: " + errnoText(e), error);
        }
        p += put;
        size -= static_cast<std::size_t>(put);
    }
    if (::close(fd) != 0) return fail(relative + ": write failed (close): " + errnoText(), error);
    unsynced_ = true;
    return true;
}

bool AtomicFile::commit(std::string& error) {
    if (temp_.empty()) return fail("nothing to commit (not open or already committed)", error);
    // Our descriptor first: errors of delayed writes (a full disk) show up in fsync and close.
    if (fd_ >= 0) {
        if (::fsync(fd_) != 0) return fail("write failed (fsync): " + errnoText(), error);
        if (::close(std::exchange(fd_, -1)) != 0) {
            return fail("write failed (close): " + errnoText(), error);
        }
    }
    // What a library wrote by name (tempPath()) reaches the disk too; the size is what landed.
    if (folder_) {
        if (unsynced_) {
            // What writeInside wrote: one sync of the file system (errors of delayed writes,
            // a full disk, are reported by syncfs since Linux 5.8).
            const int fd = ::open(temp_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
            if (fd < 0) return fail("cannot reopen the temporary folder: " + errnoText(), error);
            const bool synced = ::syncfs(fd) == 0;
            const int syncError = errno;
            ::close(fd);
            if (!synced) return fail("write failed (syncfs): " + errnoText(syncError), error);
        }
        syncFolder(temp_);
    } else {
        const int fd = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
        struct stat st {};
        if (fd < 0) return fail("cannot reopen the temporary file: " + errnoText(), error);
        const bool synced = ::fsync(fd) == 0 && ::fstat(fd, &st) == 0;
        const int syncError = errno;
        ::close(fd);
        if (!synced) return fail("write failed (fsync): " + errnoText(syncError), error);
        bytes_ = static_cast<std::uint64_t>(st.st_size);
    }

    // Inputs may have been moved onto PATH while we wrote: check again just before the move.
    struct stat out {};
    if (::stat(path_.c_str(), &out) == 0) {
        const std::string conflict = inputConflict(path_, out, options_);
        if (!conflict.empty()) return fail(conflict, error);
    }

    const char* from = temp_.c_str();
    const char* to = path_.c_str();
    int moved = -1;
    if (folder_) {
        // rename() replaces only an empty folder: a folder that another run filled meanwhile
        // fails with ENOTEMPTY / EEXIST.
        moved = ::rename(from, to);
    } else if (options_.replace) {
        moved = ::rename(from, to);
    } else {
        moved = ::renameat2(AT_FDCWD, from, AT_FDCWD, to, RENAME_NOREPLACE);
        if (moved != 0 && (errno == EINVAL || errno == ENOSYS || errno == ENOTSUP)) {
            // No RENAME_NOREPLACE on this file system: link() fails with EEXIST too.
            moved = ::link(from, to);
            if (moved == 0) ::unlink(from);
        }
    }
    if (moved != 0) {
        const int e = errno;
        if (e == EEXIST || e == ENOTEMPTY) {
            return fail(folder_ ? "already exists and is not an empty folder (written meanwhile "
                                  "by another process?)"
                                : "already exists (created meanwhile by another process?); not "
                                  "replaced",
                        error);
        }
        return fail("cannot move the temporary " + temp_ + " into place: " + errnoText(e), error);
    }
    disarmSignalCleanup(signalSlot_);
    temp_.clear();
    syncFolder(folderOf(path_));
    return true;
}

bool AtomicFileSet::add(const std::string& path, std::string_view data,
                        const OutputOptions& options, std::string& error) {
    auto file = std::make_unique<AtomicFile>();
    if (!file->open(path, options, error) || !file->write(data, error)) return false;
    files_.push_back(std::move(file));
    return true;
}

bool AtomicFileSet::commit(std::string& error) {
    struct Moved {
        std::string path, aside;  // aside: where the old file went ("" when there was none)
    };
    std::vector<Moved> moved;
    const auto rollback = [&] {
        for (auto m = moved.rbegin(); m != moved.rend(); ++m) {
            if (m->aside.empty())
                ::unlink(m->path.c_str());
            else
                ::rename(m->aside.c_str(), m->path.c_str());
        }
        files_.clear();  // the temporaries not moved yet
    };
    for (std::unique_ptr<AtomicFile>& file : files_) {
        Moved m{file->path(), ""};
        struct stat st {};
        if (::lstat(m.path.c_str(), &st) == 0) {
            m.aside = besideName(m.path, ".old-" + std::to_string(::getpid()));
            if (::rename(m.path.c_str(), m.aside.c_str()) != 0) {
                error =
                    m.path + ": cannot move the old file aside to " + m.aside + ": " + errnoText();
                rollback();
                return false;
            }
        }
        if (!file->commit(error)) {
            if (!m.aside.empty()) ::rename(m.aside.c_str(), m.path.c_str());
            rollback();
            return false;
        }
        moved.push_back(std::move(m));
    }
    for (const Moved& m : moved)
        if (!m.aside.empty()) ::unlink(m.aside.c_str());
    files_.clear();
    return true;
}

bool writeFileAtomically(const std::string& path, std::string_view data,
                         const OutputOptions& options, std::string& error) {
    AtomicFile file;
    return file.open(path, options, error) && file.write(data, error) && file.commit(error);
}

std::string fileInside(const std::string& name) {
    std::size_t start = 0;
    if (name.rfind("/vsi", 0) == 0) {
        // /vsizip/, /vsitar/, /vsigzip/, ... and the chained /vsizip/{...} form is not handled.
        start = name.find('/', 1);
        if (start == std::string::npos) return {};
        ++start;
    } else {
        const std::size_t colon = name.find(':');
        if (colon == 0 || colon == std::string::npos) return {};
        for (std::size_t i = 0; i < colon; ++i) {
            const unsigned char ch = static_cast<unsigned char>(name[i]);
            if (!std::isupper(ch) && !std::isdigit(ch) && ch != '_') return {};
        }
        start = colon + 1;
        if (start < name.size() && name[start] == '"') ++start;
    }
    for (std::size_t end = name.size(); end > start; --end) {
        if (end < name.size() && name[end] != ':' && name[end] != '"' && name[end] != '/') continue;
        const std::string file = name.substr(start, end - start);
        struct stat st {};
        if (::stat(file.c_str(), &st) == 0 && S_ISREG(st.st_mode)) return file;
    }
    return {};
}

}  // namespace unilod::format
