// Persistent worker threads for index loops run on the calling thread's behalf: the scene's
// open and preload (every entry read and validated) and each frame's view refinements (one leaf
// or node a task, lod/refine.h), which would otherwise cost the render thread about 1-2 ms a frame
// on the bundled paths (bench `refine_ms`) and bound a fast GPU's frame; `check` (one entry a
// task, preprocess/ulodcheck.cpp). In unilod_lod, the CPU-only library both the engine and
// preprocess link.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace unilod::engine {

class WorkerPool {
public:
    // `threads` in all, the calling thread of run() included (threads - 1 workers are started);
    // 0: std::thread::hardware_concurrency(), at most kMaxThreads. A worker that cannot be
    // started leaves the pool smaller (at worst run() calls fn on the caller alone).
    static constexpr std::size_t kMaxThreads = 16;
    explicit WorkerPool(std::size_t threads = 0);
    ~WorkerPool();
    WorkerPool(const WorkerPool&) = delete;
    WorkerPool& operator=(const WorkerPool&) = delete;

    std::size_t threads() const { return workers_.size() + 1; }

    // Calls fn(i) once for every i in [0, n), on the caller and the workers, and returns when
    // every call has returned. fn must be safe to call concurrently for different i; which thread
    // runs which i is not defined, so results must depend on i only. An exception thrown by fn
    // (std::bad_alloc under a memory limit) stops the other threads at their next index and is
    // rethrown here once they are done. Not reentrant: one run() at a time, from one thread.
    void run(std::size_t n, const std::function<void(std::size_t)>& fn);

private:
    void work();
    void workerMain();

    std::vector<std::thread> workers_;
    std::mutex mutex_;
    std::condition_variable wake_, done_;
    const std::function<void(std::size_t)>* job_ = nullptr;  // under mutex_ while a run lasts
    std::size_t count_ = 0;
    std::atomic<std::size_t> next_{0};
    std::uint64_t generation_ = 0;  // one per run(): wakes the workers
    std::size_t busy_ = 0;          // workers not yet done with the current run
    std::exception_ptr thrown_;
    bool stop_ = false;
};

}  // namespace unilod::engine
