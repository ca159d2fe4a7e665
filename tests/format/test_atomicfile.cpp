// format::AtomicFile and format::checkInputFile (engine/format/atomicfile.h): the output appears
// whole at commit and not before; an existing file is replaced only when asked; two writers of
// the same new file: exactly one wins; the output is never an input (also through a hard link or
// one moved there meanwhile); stale temporaries of dead writers are removed, living ones kept; a
// failing write (RLIMIT_FSIZE in a child: EFBIG, as a full disk gives ENOSPC) is reported with
// the file and strerror and leaves nothing; non-regular inputs are refused without opening them;
// a set of files (AtomicFileSet) replaces its old files all together or not at all.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>

#include "atomicfile.h"
#include "testutil.h"
#include "tools/cliutil.h"
#include "ulod.h"

using namespace unilod::format;
namespace fs = std::filesystem;
using unilod::test::slurp;
using unilod::test::TempDir;

namespace {

std::set<std::string> names(const TempDir& dir) {
    std::set<std::string> out;
    for (const auto& e : fs::directory_iterator(dir.path))
        out.insert(e.path().filename().string());
    return out;
}

using unilod::test::deadPid;

const OutputOptions kReplace{.replace = true, .inputs = {}, .inputParts = {}};
const OutputOptions kNoReplace{.replace = false, .inputs = {}, .inputParts = {}};

}  // namespace

TEST(AtomicFile, AppearsOnlyAtCommitThroughAPidNamedTemporary) {
    TempDir dir("commit");
    const std::string path = dir.file("out.bin");
    AtomicFile file;
    std::string error;
    ASSERT_TRUE(file.open(path, kNoReplace, error)) << error;
    const std::string prefix = path + ".tmp-" + std::to_string(getpid()) + "-";
    EXPECT_EQ(file.tempPath().rfind(prefix, 0), 0u) << file.tempPath();
    ASSERT_TRUE(file.write("hello ", error)) << error;
    ASSERT_TRUE(file.write("world", error)) << error;
    const char patch = 'H';
    ASSERT_TRUE(file.writeAt(&patch, 1, 0, error)) << error;
    EXPECT_FALSE(fs::exists(path));
    EXPECT_TRUE(fs::exists(file.tempPath()));
    ASSERT_TRUE(file.commit(error)) << error;
    EXPECT_EQ(slurp(path), "Hello world");
    EXPECT_EQ(file.bytes(), 11u);
    EXPECT_EQ(names(dir), std::set<std::string>{"out.bin"});
}

// An output whose name is as long as a name may be (255 bytes) is written: the temporary and
// the aside names beside it are cut (besideName); they were the name plus ".tmp-...", which the
// file system refused ("File name too long").
TEST(AtomicFile, NameOfTheLongestLengthWritten) {
    TempDir dir("longname");
    // 254 bytes ending inside a run of two-byte characters: the cut keeps whole characters.
    std::string name(200, 'n');
    while (name.size() < 250)
        name += "\xc3\xa9";  // é
    name += ".bin";
    ASSERT_EQ(name.size(), 254u);
    const std::string path = dir.write(name, "old");
    std::string error;
    AtomicFile file;
    ASSERT_TRUE(file.open(path, kReplace, error)) << error;
    const std::string temp = fs::path(file.tempPath()).filename().string();
    EXPECT_LE(temp.size(), 255u);
    // Byte 223 is the second byte of an é: the cut is before that é.
    EXPECT_EQ(temp.rfind(name.substr(0, 222) + ".tmp-", 0), 0u) << temp;
    ASSERT_TRUE(file.write("new", error)) << error;
    ASSERT_TRUE(file.commit(error)) << error;
    EXPECT_EQ(slurp(path), "new");
    // The set's old file moved aside under a cut name and removed after the commit.
    AtomicFileSet set;
    ASSERT_TRUE(set.add(path, "newer", kReplace, error)) << error;
    ASSERT_TRUE(set.commit(error)) << error;
    EXPECT_EQ(slurp(path), "newer");
    EXPECT_EQ(names(dir), std::set<std::string>{name});
    const std::string aside = besideName(path, ".old-4194304");
    EXPECT_LE(fs::path(aside).filename().string().size(), 255u);
    EXPECT_EQ(aside.rfind(dir.path, 0), 0u);
    // Inside a two-byte character at byte 223: cut before it.
    EXPECT_EQ(besideName("a/" + std::string(222, 'x') + "\xc3\xa9" + std::string(40, 'y'), ".t"),
              "a/" + std::string(222, 'x') + ".t");
    EXPECT_EQ(besideName("short", ".t"), "short.t");
}

TEST(AtomicFile, AbandonedLeavesTheOldFileAndNoTemporary) {
    TempDir dir("abandon");
    const std::string path = dir.write("out.bin", "old");
    {
        AtomicFile file;
        std::string error;
        ASSERT_TRUE(file.open(path, kReplace, error)) << error;
        ASSERT_TRUE(file.write("new, never committed", error)) << error;
    }
    EXPECT_EQ(slurp(path), "old");
    EXPECT_EQ(names(dir), std::set<std::string>{"out.bin"});
}

TEST(AtomicFile, ExistingFileReplacedOnlyWhenAsked) {
    TempDir dir("existing");
    const std::string path = dir.write("out.bin", "old");
    std::string error;
    EXPECT_FALSE(writeFileAtomically(path, "new", kNoReplace, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("already exists"), std::string::npos) << error;
    EXPECT_EQ(slurp(path), "old");
    ASSERT_TRUE(writeFileAtomically(path, "new", kReplace, error)) << error;
    EXPECT_EQ(slurp(path), "new");
    EXPECT_EQ(names(dir), std::set<std::string>{"out.bin"});

    // A directory or a FIFO is never replaced, even when replacing.
    fs::create_directory(dir.file("folder"));
    EXPECT_FALSE(writeFileAtomically(dir.file("folder"), "x", kReplace, error));
    EXPECT_NE(error.find("is a directory"), std::string::npos) << error;
    ASSERT_EQ(mkfifo(dir.file("fifo").c_str(), 0644), 0);
    EXPECT_FALSE(writeFileAtomically(dir.file("fifo"), "x", kReplace, error));
    EXPECT_NE(error.find("FIFO"), std::string::npos) << error;
    EXPECT_TRUE(fs::is_fifo(dir.file("fifo")));
}

TEST(AtomicFile, TwoWritersOfANewFileExactlyOneWins) {
    TempDir dir("race");
    const std::string path = dir.file("out.bin");
    AtomicFile first, second;
    std::string error;
    // Both checked "does not exist" and started writing before either finished.
    ASSERT_TRUE(first.open(path, kNoReplace, error)) << error;
    ASSERT_TRUE(second.open(path, kNoReplace, error)) << error;
    ASSERT_TRUE(first.write("first", error)) << error;
    ASSERT_TRUE(second.write("second", error)) << error;
    ASSERT_TRUE(second.commit(error)) << error;
    const std::string firstTemp = first.tempPath();
    EXPECT_FALSE(first.commit(error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("already exists"), std::string::npos) << error;
    EXPECT_EQ(slurp(path), "second");
    EXPECT_FALSE(fs::exists(firstTemp));
    EXPECT_EQ(names(dir), std::set<std::string>{"out.bin"});

    // A file that another program creates between open and commit stays too.
    const std::string other = dir.file("other.bin");
    AtomicFile third;
    ASSERT_TRUE(third.open(other, kNoReplace, error)) << error;
    ASSERT_TRUE(third.write("mine", error)) << error;
    dir.write("other.bin", "theirs");
    EXPECT_FALSE(third.commit(error));
    EXPECT_NE(error.find("already exists"), std::string::npos) << error;
    EXPECT_EQ(slurp(other), "theirs");
    EXPECT_EQ(names(dir), (std::set<std::string>{"other.bin", "out.bin"}));
}

TEST(AtomicFile, OutputNeverAnInput) {
    TempDir dir("inputs");
    const std::string input = dir.write("model.ulod", "precious");
    const OutputOptions withInput{.replace = true, .inputs = {input}, .inputParts = {}};
    std::string error;
    // The input itself, also when replacing (--force).
    EXPECT_FALSE(writeFileAtomically(input, "glb", withInput, error));
    EXPECT_NE(error.find(input), std::string::npos) << error;
    EXPECT_NE(error.find("input"), std::string::npos) << error;
    // Another name of the same file: a hard link, a path with "./" in it.
    ASSERT_EQ(link(input.c_str(), dir.file("alias.ulod").c_str()), 0);
    EXPECT_FALSE(writeFileAtomically(dir.file("alias.ulod"), "glb", withInput, error));
    EXPECT_FALSE(
        writeFileAtomically((dir.path / "." / "model.ulod").string(), "glb", withInput, error));
    EXPECT_EQ(slurp(input), "precious");
    // The input moved onto the output's name while the output was being written.
    const std::string out = dir.file("out.glb");
    AtomicFile file;
    ASSERT_TRUE(file.open(out, withInput, error)) << error;
    ASSERT_TRUE(file.write("glb", error)) << error;
    ASSERT_EQ(link(input.c_str(), out.c_str()), 0);
    EXPECT_FALSE(file.commit(error));
    EXPECT_NE(error.find("input"), std::string::npos) << error;
    EXPECT_EQ(slurp(input), "precious");
    EXPECT_EQ(names(dir), (std::set<std::string>{"alias.ulod", "model.ulod", "out.glb"}));
}

// A GDAL dataset name reads a file it contains: a subdataset (DRIVER:path:name, quoted or not)
// or an archive member (/vsizip/archive.zip/member). The output may not replace that file.
TEST(AtomicFile, OutputNeverTheFileInsideAnInputName) {
    TempDir dir("inside");
    const std::string gpkg = dir.write("dem.gpkg", "tables");
    const std::string zip = dir.write("dem.zip", "archive");
    EXPECT_EQ(fileInside("GPKG:" + gpkg + ":elev"), gpkg);
    EXPECT_EQ(fileInside("NETCDF:\"" + gpkg + "\":z"), gpkg);
    EXPECT_EQ(fileInside("/vsizip/" + zip + "/tiles/dem.tif"), zip);
    EXPECT_EQ(fileInside("GPKG:" + dir.file("none.gpkg") + ":elev"), "");
    EXPECT_EQ(fileInside("lower:" + gpkg + ":elev"), "");  // not a driver prefix
    EXPECT_EQ(fileInside(gpkg), "");                       // a plain path: nothing inside
    std::string error;
    for (const auto& [input, output] :
         {std::pair{"GPKG:" + gpkg + ":elev", gpkg}, {"/vsizip/" + zip + "/dem.tif", zip}}) {
        const OutputOptions options{.replace = true, .inputs = {input}, .inputParts = {}};
        EXPECT_FALSE(writeFileAtomically(output, "model", options, error)) << input;
        EXPECT_NE(error.find("is the same file as the input '" + input + "'"), std::string::npos)
            << error;
    }
    EXPECT_EQ(slurp(gpkg), "tables");
    EXPECT_EQ(slurp(zip), "archive");
}

TEST(AtomicFile, StaleTemporariesOfDeadWritersRemoved) {
    TempDir dir("stale");
    const std::string path = dir.file("out.bin");
    const std::string dead = "out.bin.tmp-" + std::to_string(deadPid()) + "-abc123";
    const std::string deadFolder = "out.bin.tmp-" + std::to_string(deadPid()) + "-def456";
    const std::string living = "out.bin.tmp-" + std::to_string(getpid()) + "-abc123";
    const std::string init = "out.bin.tmp-1-abc123";  // pid 1 always runs
    const std::string notOurs = "out.bin.tmp-XXXXXX";
    const std::string otherOutput = "other.bin.tmp-" + std::to_string(deadPid()) + "-abc123";
    for (const std::string& n : {dead, living, init, notOurs, otherOutput})
        dir.write(n, "x");
    fs::create_directories(dir.path / deadFolder / "inside");
    std::string error;
    ASSERT_TRUE(writeFileAtomically(path, "data", kNoReplace, error)) << error;
    EXPECT_EQ(names(dir), (std::set<std::string>{"out.bin", living, init, notOurs, otherOutput}));
}

TEST(AtomicFile, FailingWriteReportedAndNothingLeft) {
    TempDir dir("efbig");
    const std::string path = dir.file("out.bin");
    // In a child: a file size limit makes write() fail with EFBIG (SIGXFSZ ignored), as a full
    // disk makes it fail with ENOSPC. Exit codes say which expectation failed.
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        signal(SIGXFSZ, SIG_IGN);
        const rlimit limit{4096, 4096};
        if (setrlimit(RLIMIT_FSIZE, &limit) != 0) _exit(10);
        std::string error;
        const std::string data(64 * 1024, 'x');
        if (writeFileAtomically(path, data, kNoReplace, error)) _exit(11);
        if (error.find(path) == std::string::npos) _exit(12);
        if (error.find(std::strerror(EFBIG)) == std::string::npos) _exit(13);
        AtomicFile file;  // the same through the streamed interface
        if (!file.open(path, kNoReplace, error)) _exit(14);
        if (file.write(data, error)) _exit(15);
        if (error.find(std::strerror(EFBIG)) == std::string::npos) _exit(16);
        _exit(0);
    }
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status)) << "child killed by signal " << WTERMSIG(status);
    EXPECT_EQ(WEXITSTATUS(status), 0);
    EXPECT_TRUE(names(dir).empty());
}

TEST(AtomicFile, FolderCommittedWholeAndOnlyOverAnEmptyFolder) {
    TempDir dir("folder");
    const std::string path = dir.file("report");
    AtomicFile folder;
    std::string error;
    ASSERT_TRUE(folder.openFolder(path, kNoReplace, error)) << error;
    ASSERT_TRUE(writeFileAtomically(folder.tempPath() + "/a.txt", "a", kReplace, error)) << error;
    EXPECT_FALSE(fs::exists(path));
    ASSERT_TRUE(folder.commit(error)) << error;
    EXPECT_EQ(slurp(path + "/a.txt"), "a");
    EXPECT_EQ(names(dir), std::set<std::string>{"report"});

    // A non-empty folder is refused at open; one filled while we wrote is refused at commit.
    EXPECT_FALSE(folder.openFolder(path, kNoReplace, error));
    EXPECT_NE(error.find("not an empty folder"), std::string::npos) << error;
    const std::string later = dir.file("later");
    fs::create_directory(later);
    ASSERT_TRUE(folder.openFolder(later, kNoReplace, error)) << error;
    AtomicFile other;
    ASSERT_TRUE(other.openFolder(later, kNoReplace, error)) << error;
    ASSERT_TRUE(writeFileAtomically(other.tempPath() + "/b.txt", "b", kReplace, error)) << error;
    ASSERT_TRUE(other.commit(error)) << error;
    EXPECT_FALSE(folder.commit(error));
    EXPECT_NE(error.find("already exists"), std::string::npos) << error;
    EXPECT_EQ(slurp(later + "/b.txt"), "b");
    EXPECT_EQ(names(dir), (std::set<std::string>{"later", "report"}));
}

TEST(AtomicFile, WriteInsideAFolderSyncedOnceAtCommit) {
    TempDir dir("inside");
    const std::string path = dir.file("tiles");
    AtomicFile folder;
    std::string error;
    ASSERT_TRUE(folder.openFolder(path, kNoReplace, error)) << error;
    fs::create_directory(folder.tempPath() + "/sub");
    ASSERT_TRUE(folder.writeInside("sub/a.bin", std::string(100000, 'a'), error)) << error;
    ASSERT_TRUE(folder.writeInside("b.txt", "", error)) << error;  // an empty file is a file
    EXPECT_FALSE(fs::exists(path));
    ASSERT_TRUE(folder.commit(error)) << error;
    EXPECT_EQ(slurp(path + "/sub/a.bin"), std::string(100000, 'a'));
    EXPECT_TRUE(fs::exists(path + "/b.txt"));
    EXPECT_EQ(names(dir), std::set<std::string>{"tiles"});

    // A name written twice, or into a missing folder: an error naming it, nothing left.
    AtomicFile twice;
    ASSERT_TRUE(twice.openFolder(dir.file("twice"), kNoReplace, error)) << error;
    ASSERT_TRUE(twice.writeInside("x", "1", error)) << error;
    EXPECT_FALSE(twice.writeInside("x", "2", error));
    EXPECT_NE(error.find("x: cannot create"), std::string::npos) << error;
    EXPECT_FALSE(twice.commit(error));
    AtomicFile missing;
    ASSERT_TRUE(missing.openFolder(dir.file("missing"), kNoReplace, error)) << error;
    EXPECT_FALSE(missing.writeInside("no/such/y", "1", error));
    EXPECT_EQ(names(dir), std::set<std::string>{"tiles"});
    // Not a folder output: refused.
    AtomicFile file;
    ASSERT_TRUE(file.open(dir.file("f"), kNoReplace, error)) << error;
    EXPECT_FALSE(file.writeInside("z", "1", error));
    EXPECT_EQ(names(dir), std::set<std::string>{"tiles"});
}

// A set replaces its old files together or not at all. The second file's move is made to fail
// in the middle of the commit: its old file cannot be moved aside because a non-empty folder
// holds the name it would go to. The first file, already moved into place, goes back.
TEST(AtomicFileSet, FailedCommitPutsEveryOldFileBack) {
    TempDir dir("set");
    const std::string a = dir.file("a.txt"), b = dir.file("b.txt"), c = dir.file("c.txt");
    for (const std::string& p : {a, b}) {
        std::string error;
        ASSERT_TRUE(writeFileAtomically(p, "old " + p, kNoReplace, error)) << error;
    }
    const std::string blocker = b + ".old-" + std::to_string(getpid());
    fs::create_directory(blocker);
    std::ofstream(blocker + "/x") << "x";
    {
        AtomicFileSet set;
        std::string error;
        ASSERT_TRUE(set.add(a, "new a", kReplace, error)) << error;
        ASSERT_TRUE(set.add(b, "new b", kReplace, error)) << error;
        ASSERT_TRUE(set.add(c, "new c", kReplace, error)) << error;
        EXPECT_EQ(slurp(a), "old " + a);  // nothing moves before commit()
        EXPECT_FALSE(set.commit(error));
        EXPECT_NE(error.find(b), std::string::npos) << error;
    }
    EXPECT_EQ(slurp(a), "old " + a);
    EXPECT_EQ(slurp(b), "old " + b);
    EXPECT_FALSE(fs::exists(c));
    const std::string blockerName = fs::path(blocker).filename().string();
    EXPECT_EQ(names(dir), (std::set<std::string>{"a.txt", "b.txt", blockerName}));
    // Without the blocker the same set commits, and no old file is left aside.
    fs::remove_all(blocker);
    AtomicFileSet set;
    std::string error;
    ASSERT_TRUE(set.add(a, "new a", kReplace, error)) << error;
    ASSERT_TRUE(set.add(b, "new b", kReplace, error)) << error;
    ASSERT_TRUE(set.add(c, "new c", kReplace, error)) << error;
    ASSERT_TRUE(set.commit(error)) << error;
    EXPECT_EQ(slurp(a), "new a");
    EXPECT_EQ(slurp(b), "new b");
    EXPECT_EQ(slurp(c), "new c");
    EXPECT_EQ(names(dir), (std::set<std::string>{"a.txt", "b.txt", "c.txt"}));
}

// A set destroyed before commit() leaves no temporary and no file.
TEST(AtomicFileSet, UncommittedSetLeavesNothing) {
    TempDir dir("setdrop");
    {
        AtomicFileSet set;
        std::string error;
        ASSERT_TRUE(set.add(dir.file("a.txt"), "a", kNoReplace, error)) << error;
        EXPECT_EQ(names(dir).size(), 1u);  // the temporary
    }
    EXPECT_TRUE(names(dir).empty());
}

TEST(CheckInputFile, RefusesWhatIsNotARegularFileWithoutOpeningIt) {
    TempDir dir("inputs");
    std::string why;
    EXPECT_TRUE(checkInputFile(dir.write("a.txt", "x"), false, why));
    EXPECT_TRUE(checkInputFile(dir.file("missing"), false, why));  // the reader says so
    EXPECT_TRUE(checkInputFile("/vsizip/nowhere.zip/dem.tif", false, why));
    EXPECT_FALSE(checkInputFile(dir.path.string(), false, why));
    EXPECT_NE(why.find("directory"), std::string::npos) << why;
    EXPECT_TRUE(checkInputFile(dir.path.string(), true, why));  // a Shapefile folder
    // No writer ever opens this FIFO: an open() for reading would block forever.
    ASSERT_EQ(mkfifo(dir.file("fifo").c_str(), 0644), 0);
    EXPECT_FALSE(checkInputFile(dir.file("fifo"), true, why));
    EXPECT_NE(why.find("FIFO"), std::string::npos) << why;
    EXPECT_FALSE(checkInputFile("/dev/null", true, why));
    EXPECT_NE(why.find("character device"), std::string::npos) << why;
}

TEST(CheckInputFile, ReaderRefusesAFifoWithoutBlocking) {
    TempDir dir("reader");
    const std::string fifo = dir.file("model.ulod");
    ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
    // In a child with an alarm, so that a regression fails instead of hanging the test.
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        alarm(20);
        Reader reader;
        std::string error;
        if (reader.open(fifo, error)) _exit(1);
        _exit(error.find("FIFO") != std::string::npos && error.find(fifo) != std::string::npos ? 0
                                                                                               : 2);
    }
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status))
        << "Reader::open blocked (killed by signal " << WTERMSIG(status) << ")";
    EXPECT_EQ(WEXITSTATUS(status), 0);
}
