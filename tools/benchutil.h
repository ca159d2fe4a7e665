// Shared by the benchmark programs: run one measurement in a child process, so that the peak
// resident set size (getrusage in the child) belongs to that measurement alone.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

#include "jsontext.h"

namespace unilod::bench {

// Runs f() (returning JSON) in a forked child and returns its result; exits the program with 1
// when the child fails.
template <class F>
nlohmann::json runInChild(F f) {
    int fd[2];
    if (pipe(fd) != 0) std::exit(1);
    const pid_t pid = fork();
    if (pid == 0) {
        close(fd[0]);
        const std::string text = jsonText(f());
        if (write(fd[1], text.data(), text.size()) < 0) _exit(1);
        _exit(0);
    }
    close(fd[1]);
    std::string text;
    char buf[4096];
    for (ssize_t k; (k = read(fd[0], buf, sizeof buf)) > 0;)
        text.append(buf, std::size_t(k));
    close(fd[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) std::exit(1);
    return nlohmann::json::parse(text);
}

}  // namespace unilod::bench
