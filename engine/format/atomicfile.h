// Output files that appear whole or not at all, and the input check that never blocks (issue 16).
// The one place every command that writes or reads a file goes through: the .ulod Writer, PNG
// and JSON captures, the glTF export, CSV / JSON outputs, the report folder, the synthetic data.
//
// AtomicFile writes PATH through a temporary PATH.tmp-<pid>-<random> in the same folder (a name
// longer than 223 bytes cut to that: besideName):
// - open() refuses, before anything is written:
//   * a PATH that is the same file (device + inode, so hard links too) as one of
//     OutputOptions::inputs, also when replacing: `export m.ulod -o m.ulod` must not destroy m;
//   * an existing PATH unless OutputOptions::replace (the command's --force);
//   * a PATH that is a directory (openFolder: a PATH that is anything but an empty directory).
//   It removes the stale temporaries of PATH: those whose writer pid no longer runs
//   (kill(pid, 0) fails with ESRCH; a killed build leaves its temporary behind). Temporaries of
//   living processes are left alone.
// - write() / writeAt() go through fd() and check every call (short writes, EINTR). A library that
//   creates the file by name (GDAL) gets openByName(): it creates tempPath() itself and must
//   report its own errors.
// - commit() fsyncs and closes, checking both (a full disk often reports only there), then moves
//   the temporary onto PATH: rename() when replacing; otherwise renameat2(RENAME_NOREPLACE), or
//   link() + unlink() where the file system lacks it, so that a PATH that appeared meanwhile is
//   never replaced: of two runs racing to the same new PATH exactly one succeeds, the other fails
//   with "already exists". Then the folder is fsynced (best effort).
// - An AtomicFile destroyed before commit() (any error, an exception) removes its temporary, and
//   so does a SIGINT, SIGTERM, SIGHUP, SIGQUIT or SIGPIPE that stops the process (a handler
//   installed where the signal's action is the default; the process then ends by the signal as
//   before). A temporary folder is left to the stale-temporary removal of the next run.
// Errors name the file and the problem (strerror): "out.glb: write failed: No space left on
// device". On failure PATH is untouched: the old file (if any) stays, no partial file appears.
//
// checkInputFile() refuses, with stat() only (no open, so a FIFO cannot block), a path that exists
// and is not a regular file: a FIFO, a device, a socket, a directory (unless the reader opens
// folders, like GDAL/OGR for a Shapefile folder). A path that does not exist is left to the
// reader (its own "no such file" message; GDAL's /vsizip/... paths are not on the disk at all).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace unilod::format {

struct OutputOptions {
    bool replace = false;             // replace an existing PATH (--force); never an input
    std::vector<std::string> inputs;  // files the command reads: PATH must not be one of them
    // Files that belong to an input and are read with it, as (file, the input): a Shapefile's
    // .dbf, a VRT's source rasters (preprocess/ingest.h addInputFiles). PATH is none of them.
    std::vector<std::pair<std::string, std::string>> inputParts;
};

class AtomicFile {
public:
    AtomicFile() = default;
    ~AtomicFile();  // removes an uncommitted temporary
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    // Checks PATH (above), removes stale temporaries and creates the temporary file.
    bool open(const std::string& path, const OutputOptions& options, std::string& error);
    // The same, but tempPath() is left for a library to create (no fd()): GDAL's drivers create
    // their files by name and some refuse an existing one.
    bool openByName(const std::string& path, const OutputOptions& options, std::string& error);
    // The same for a folder written file by file (`unilod report`): the temporary is a folder
    // and PATH may exist as an empty folder, which the commit replaces.
    bool openFolder(const std::string& path, const OutputOptions& options, std::string& error);

    const std::string& path() const { return path_; }
    const std::string& tempPath() const { return temp_; }
    int fd() const { return fd_; }

    // Appends at the end of what write() wrote so far / writes at a byte offset.
    bool write(const void* data, std::size_t size, std::string& error);
    bool write(std::string_view text, std::string& error) {
        return write(text.data(), text.size(), error);
    }
    bool writeAt(const void* data, std::size_t size, std::uint64_t offset, std::string& error);

    // Makes the temporary durable and moves it onto PATH (above). False with `error`; the
    // temporary is gone either way.
    bool commit(std::string& error);
    std::uint64_t bytes() const { return bytes_; }  // the committed file's size

    // A folder (openFolder): writes the new file `relative` (its parent folders must exist)
    // inside the temporary folder, checking every call; no fsync per file: commit() syncs the
    // whole file system of the temporary folder once (syncfs), before the move. For outputs of
    // many files (a 3D Tiles tileset: thousands) one sync instead of one per file. False with
    // `error` naming the file; the temporary folder is gone then.
    bool writeInside(const std::string& relative, std::string_view data, std::string& error);

    // Removes the temporary now (what the destructor does).
    void abandon();

private:
    enum class Kind { File, ByName, Folder };
    bool openImpl(const std::string& path, const OutputOptions& options, Kind kind,
                  std::string& error);
    bool fail(const std::string& what, std::string& error);

    std::string path_, temp_;
    OutputOptions options_;
    int fd_ = -1;
    int signalSlot_ = -1;  // the temporary's slot in the SIGINT / SIGTERM cleanup (atomicfile.cpp)
    bool folder_ = false, unsynced_ = false;
    std::uint64_t offset_ = 0, bytes_ = 0;
};

// `path` with `tag` (at most 22 bytes: ".old-<pid>") appended to its name, the name first cut to
// 223 bytes (at a UTF-8 character), so that the result is a valid name wherever `path` is.
std::string besideName(const std::string& path, const std::string& tag);

// Several files that replace their old versions together or not at all (capture's frames with
// --overwrite): add() writes each file to its temporary (AtomicFile; nothing at PATH changes);
// commit() moves them into place one by one, each old file first renamed aside to
// PATH.old-<pid>, and where a move fails it moves back what it had moved, so that a failed set
// leaves every old file as it was; the old files are removed after the last move. A set
// destroyed before commit() removes its temporaries.
class AtomicFileSet {
public:
    // Opens PATH's temporary (AtomicFile::open: the same checks) and writes `data` to it.
    bool add(const std::string& path, std::string_view data, const OutputOptions& options,
             std::string& error);
    // False with `error` naming the file that failed; the old files are back then.
    bool commit(std::string& error);
    std::size_t size() const { return files_.size(); }

private:
    std::vector<std::unique_ptr<AtomicFile>> files_;
};

// The checks open() makes before creating anything (also for a command that wants to fail before
// its long work): PATH not an input, not a directory / other non-regular file, absent unless
// `replace`, its folder an existing writable directory. `folder`: as openFolder.
bool checkOutputPath(const std::string& path, const OutputOptions& options, bool folder,
                     std::string& error);

// While armed, a SIGINT, SIGTERM, SIGHUP, SIGQUIT or SIGPIPE that stops the process renames
// `from` to `to` first (as AtomicFile removes its temporary then): an old folder moved aside by
// --overwrite goes back where it was (cli/outputopts.h ReplacedFolder). The slot to pass to
// cancelOnSignal (-1: none free or a path too long; nothing is renamed then).
int renameOnSignal(const std::string& from, const std::string& to);
void cancelOnSignal(int& slot);  // disarms `slot` and sets it to -1

// Writes `data` to PATH with an AtomicFile (open, write, commit).
bool writeFileAtomically(const std::string& path, std::string_view data,
                         const OutputOptions& options, std::string& error);

// Refuses PATH when it exists and is not a regular file (or, with folderAllowed, a directory):
// false with `why` = the problem without the path ("is a FIFO (named pipe), not a regular
// file"), so that each reader words the message its own way. True when PATH does not exist.
bool checkInputFile(const std::string& path, bool folderAllowed, std::string& why);

// The file a GDAL dataset name reads when the name itself is no file: a subdataset
// (DRIVER:path:name, DRIVER:"path":name; netCDF, HDF5, GeoPackage tables) or a member of an
// archive (/vsizip/archive.zip/member, /vsitar/, /vsigzip/): the longest part of the name after
// its driver or /vsi prefix, ending at a ':', '"' or '/', that is an existing regular file.
// Empty when there is none. The output checks compare an output with this file of each input,
// so an output cannot replace the container an input is read from.
std::string fileInside(const std::string& name);

}  // namespace unilod::format
